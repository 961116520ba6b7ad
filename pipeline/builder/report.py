"""The build report: ``report/summary.md`` (tables), ``kpis_<policy>.csv`` and the PNG figures the summary shows
(:mod:`pipeline.builder.report_figures`), written once by :func:`write_report` from what the district holds
(:class:`ReportInputs`: the schema, the validation's runs and oracle bounds, the surrogates' records,
``buildings.json`` and the selection). Formatting only: the runs and the LPs are the validation's
(:mod:`pipeline.builder.validate`).

``summary.md`` holds the devices the sizing chose, the surrogates' held-out fit, the no-control vs cost-RBC
objectives (absolute units, district and per building), the oracle's bound on cost, emissions and average
daily peak (the perfect-foresight storage schedule of :mod:`pipeline.optimal`; one line saying why where it
does not apply), the district KPIs of ``kpis_<policy>.csv`` (CityLearn's ``evaluate``: ratios to the
no-storage baseline), the figures, each building's heating device and set points, and the selection. It holds
no timings and no dates, so two builds of the same configuration write the same bytes, and a district's report
rewritten (``surrogate install``) is what a build of it would write.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.builder.report_figures import (
    POLICY_LABELS,
    heatmap_figure,
    load_figure,
    parse_calendar,
    peak_week,
    policies_figure,
    safe_name,
    temperature_figure,
)
from pipeline.builder.validate import ORACLE_BOUNDS, OracleBounds, Validation
from pipeline.controllers import MISFIT_REASON, RULE_OBJECTIVES
from pipeline.select import describe_selection, format_validity

#: objective -> (unit, decimals) of :func:`citylearn_env.kpis.objectives`
OBJECTIVES = {"cost": ("$", 2), "emissions": ("kg CO2", 1), "discomfort": ("degC h", 1),
              "consumption": ("kWh", 1), "average_daily_peak": ("kW", 3)}
#: KPI name prefix -> unit of the KPI table (first match; else a ratio to the no-storage baseline)
KPI_UNITS = (("discomfort_delta", "degC"), ("discomfort", "fraction of occupied hours"),
             ("one_minus_thermal_resilience", "fraction of outage hours"))
#: the columns of a selection's validity table (pipeline.select.validity_table)
VALIDITY = ("k", "sse", "calinski_harabasz", "silhouette", "davies_bouldin")


@dataclass(frozen=True)
class SelectionSummary:
    """What the report shows of a k-means selection: the chosen ``k`` and the validity-index rows
    (:data:`VALIDITY`; empty when the build did not record them). Its JSON form (:meth:`to_json`) is kept in
    the district's ``manifest.json`` (``selection``), so a rewritten report shows it again."""

    k: int
    validity: tuple[Mapping[str, float], ...] = ()
    #: how the houses were picked, naming repeated rows (:func:`pipeline.select.describe_selection`)
    heading: str = ""

    @classmethod
    def of(cls, selection: Any) -> SelectionSummary:
        """From a :class:`pipeline.select.Selection`."""
        rows = selection.validity[list(VALIDITY)].to_dict("records")
        return cls(int(selection.chosen["k"].iloc[0]),
                   tuple({key: int(row["k"]) if key == "k" else float(row[key]) for key in VALIDITY} for row in rows),
                   describe_selection(selection.chosen))

    def to_json(self) -> dict[str, Any]:
        return {"k": self.k, "validity": [dict(row) for row in self.validity], "heading": self.heading}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> SelectionSummary:
        return cls(int(data["k"]), tuple(dict(row) for row in data.get("validity") or ()), str(data.get("heading", "")))


@dataclass(frozen=True)
class ReportInputs:
    """Everything the report shows: the district ``name`` and ``schema`` (dict), the :class:`Validation`, the
    surrogates' ``*.metrics.json`` records (sorted by file name; none without surrogates), the buildings' notes
    (``buildings.json``; None: no Buildings section) and the selection (None: the buildings were listed)."""

    name: str
    schema: Mapping[str, Any]
    validation: Validation
    surrogates: Sequence[Mapping[str, Any]] = ()
    buildings: Mapping[str, Mapping[str, Any]] | None = None
    selection: SelectionSummary | None = None


def district_report(folder: Path, name: str, schema: Mapping[str, Any], validation: Validation,
                    selection: SelectionSummary | None) -> ReportInputs:
    """The report's inputs of the district in ``folder``: its surrogates' records (``surrogates/``) and
    ``buildings.json`` read from there, with the ``schema`` (dict), ``validation`` and ``selection`` given."""
    notes = folder / "buildings.json"
    buildings = json.loads(notes.read_text()) if notes.is_file() else None
    return ReportInputs(name, schema, validation, read_surrogate_metrics(folder / "surrogates"), buildings,
                        selection)


def write_report(report_dir: Path, inputs: ReportInputs) -> Path:
    """Write ``kpis_<policy>.csv``, every figure and ``summary.md`` into ``report_dir`` (created); return the
    summary's path."""
    report_dir.mkdir(parents=True, exist_ok=True)
    runs = inputs.validation.runs
    for policy, run in runs.items():
        run.kpis.to_csv(report_dir / f"kpis_{policy}.csv", index=False)
    first = next(iter(runs.values()))
    figures = write_figures(report_dir, list(first.series_buildings), {p: r.series for p, r in runs.items()},
                            {p: r.district_net for p, r in runs.items()})
    path = report_dir / "summary.md"
    path.write_text(summary_text(inputs, figures))
    return path


def summary_text(inputs: ReportInputs, figures: list[tuple[str, str, str]]) -> str:
    """``summary.md``: the tables of ``inputs`` and the links of ``figures`` ((section, caption, file name),
    :func:`write_figures`)."""
    buildings = included_buildings(inputs.schema)
    runs = inputs.validation.runs
    objectives = {p: r.objectives for p, r in runs.items()}
    steps = next(iter(runs.values())).district_net.size
    lines = [f"# District {inputs.name}", "",
             f"{len(buildings)} buildings, {steps} hourly time steps; each policy runs once over the period with "
             "the heat pumps serving the ideal load (pipeline/controllers.py).", ""]
    lines += sizing_table(inputs.schema, buildings)
    lines += surrogate_table(list(inputs.surrogates))
    lines += objectives_table(objectives)
    lines += oracle_table(inputs.validation.oracle, objectives)
    lines += building_objectives_table({p: r.per_building for p, r in runs.items()}, buildings)
    lines += kpi_table({p: r.kpis for p, r in runs.items()})
    lines += figure_section(figures)
    drawn = len(next(iter(runs.values())).series_buildings)
    if drawn < len(buildings):
        lines += [f"Figures of the first {drawn} of the {len(buildings)} buildings; every building's series are in "
                  "its CSV file and its objectives in the tables above.", ""]
    if inputs.buildings is not None:
        lines += building_section(inputs.buildings)
    if inputs.selection is not None:
        lines += selection_section(inputs.selection)
    return "\n".join(lines) + "\n"


def included_buildings(schema: Mapping[str, Any]) -> list[str]:
    """Names of the schema's included buildings, in schema order."""
    return [b for b, spec in schema["buildings"].items() if spec.get("include", True)]


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(row) + " |" for row in rows)]


def _attribute(spec: Mapping[str, Any], device: str, key: str, decimals: int) -> str:
    """A device attribute of a building's schema entry, "-" when the building has no such device."""
    block = spec.get(device)
    return "-" if not block else f"{block.get('attributes', {}).get(key, 0.0):.{decimals}f}"


def _heating(spec: Mapping[str, Any]) -> str:
    """The heating device: its kind and nominal power [kW], "-" when the building has none."""
    block = spec.get("heating_device")
    if not block:
        return "-"
    kind = {"HeatPump": "heat pump", "ElectricHeater": "electric heater"}.get(block["type"].rsplit(".", 1)[-1],
                                                                             block["type"])
    return f"{kind} {block.get('attributes', {}).get('nominal_power', 0.0):.2f}"


def sizing_table(schema: Mapping[str, Any], buildings: list[str]) -> list[str]:
    """The devices of each building as sized by citylearn_env.sizing (the paper's rules) [kW, kWh, kWp]; "-": no such device."""
    rows = []
    for building in buildings:
        spec = schema["buildings"][building]
        rows.append([building, _attribute(spec, "cooling_device", "nominal_power", 2), _heating(spec),
                     _attribute(spec, "dhw_device", "nominal_power", 2), _attribute(spec, "dhw_storage", "capacity", 2),
                     f"{_attribute(spec, 'electrical_storage', 'capacity', 1)} / "
                     f"{_attribute(spec, 'electrical_storage', 'nominal_power', 2)}",
                     _attribute(spec, "pv", "nominal_power", 2)])
    return ["## Devices (sized by citylearn_env.sizing: the paper's rules)", "",
            *_table(["building", "heat pump kW", "heating device kW", "DHW heater kW", "DHW tank kWh",
                     "battery kWh / kW", "PV kWp"], rows), ""]


def read_surrogate_metrics(surrogates_dir: Path) -> list[dict]:
    """The ``*.metrics.json`` of the build's surrogates (sorted by file name); none without surrogates."""
    if not surrogates_dir.is_dir():
        return []
    return [json.loads(path.read_text()) for path in sorted(surrogates_dir.glob("*.metrics.json"))]


def surrogate_table(metrics: list[dict]) -> list[str]:
    """Held-out closed-loop fit of each surrogate [degC]: monthly RMSE median / max, whole-run RMSE, one-step
    RMSE and the held-out hours; empty without surrogates."""
    if not metrics:
        return []
    rows = []
    for m in metrics:
        test, training = m["test"], m.get("training", {})
        epochs = training.get("config", {}).get("epochs")
        best = training.get("best_epoch")
        rows.append([m["building"], f"{test['monthly_rmse_c']['median']:.2f} / {test['monthly_rmse_c']['max']:.2f}",
                     f"{test['closed_loop_rmse_c']:.2f}", f"{test['one_step_rmse_c']:.3f}", f"{test['hours']}",
                     "-" if best is None else f"{best + 1} of {epochs}", trained_on(m), *judge_cells(m.get("judge"))])
    return ["## Surrogates (held-out runs, closed loop)", "",
            "Judge: the house's own physics, a fresh EnergyPlus run at a finer zone timestep with partial-load "
            "multipliers the training never saw (surrogates/judge.py); bound: monthly RMSE median <= 0.25 and "
            "worst month <= 0.5 degC. With ideal loads met (no control) the discomfort is the surrogate's own "
            "error: its mean absolute error on the judge's ideal-load replay (goal <= 0.3 degC).", "",
            *_table(["building", "monthly RMSE median / max degC", "closed-loop RMSE degC", "one-step RMSE degC",
                     "held-out hours", "best epoch", "trained and scored on",
                     "judge: monthly RMSE median / worst degC", "judge: mean abs error degC, partial / ideal loads"],
                    rows), ""]


def judge_cells(judge: dict | None) -> list[str]:
    """The judge's cells of a surrogate row [degC]: median / worst month (with "over the bound" when it
    misses) and mean absolute error on partial and ideal loads; "-" without a judge."""
    if not judge:
        return ["-", "-"]
    miss = "" if judge.get("passes", True) else " (over the bound)"
    ideal = judge.get("ideal_mean_abs_c")
    return [f"{judge['median_c']:.2f} / {judge['worst_c']:.2f}{miss}",
            f"{judge.get('mean_abs_c', float('nan')):.2f} / {'-' if ideal is None else f'{ideal:.2f}'}"]


def trained_on(metrics: dict) -> str:
    """The ILV table a surrogate was trained and scored on: its name, the first 12 hex of its content sha256
    and, for a model trained on a season, its calendar months (``-`` where the record has none of them)."""
    digest = metrics.get("table_sha256")
    name = Path(str(metrics.get("source") or "")).name
    months = metrics.get("training", {}).get("config", {}).get("months")
    return " ".join(filter(None, [name or None, f"`{digest[:12]}`" if digest else None,
                                  f"(months {','.join(str(m) for m in months)})" if months else None])) or "-"


def _change(new: float, old: float) -> str:
    return "-" if old == 0 or not math.isfinite(old) else f"{100.0 * (new - old) / abs(old):+.1f} %"


def objectives_table(objectives: Mapping[str, Mapping[str, float]]) -> list[str]:
    """The paper's five objectives (to minimise) per policy, with units and the change from the first."""
    policies = list(objectives)
    first = policies[0]
    rows = []
    for key, (unit, decimals) in OBJECTIVES.items():
        values = [objectives[p][key] for p in policies]
        rows.append([key.replace("_", " "), unit, *(f"{v:.{decimals}f}" for v in values),
                     *(_change(v, values[0]) for v in values[1:])])
    header = ["objective", "unit", *(POLICY_LABELS.get(p, p) for p in policies),
              *(f"change {POLICY_LABELS.get(p, p)}" for p in policies[1:])]
    return ["## Objectives over the period (district)", "",
            "Cost, emissions and consumption count grid imports only; discomfort is the sum over the hours of the "
            "distance of the indoor temperature outside the comfort band [heating set point, cooling set point] "
            f"(0 inside); change relative to {POLICY_LABELS.get(first, first)}.", "",
            *_table(header, rows), "", *rule_misfits(objectives)]



def rule_misfits(objectives: Mapping[str, Mapping[str, float]]) -> list[str]:
    """One line (then a blank) per rule-based policy that does worse than the first policy (no control) on
    the objective its rule is written for: its fixed charge and discharge hours do not fit the period."""
    policies = list(objectives)
    first = policies[0]
    out = []
    for policy in policies[1:]:
        key = RULE_OBJECTIVES.get(policy)
        if key is None or not objectives[policy][key] > objectives[first][key]:
            continue
        label = POLICY_LABELS.get(policy, policy)
        out += [f"Note: the {label} raises {key.replace('_', ' ')} by "
                f"{_change(objectives[policy][key], objectives[first][key])} against "
                f"{POLICY_LABELS.get(first, first)}: {MISFIT_REASON.format(period='period')}; read its row as a rule "
                "that does not fit, not as a benchmark.", ""]
    return out


def oracle_table(bounds: OracleBounds, objectives: Mapping[str, Mapping[str, float]]) -> list[str]:
    """The oracle's best plan and certified lower bound per objective next to each policy's value
    (``objectives``: policy -> name -> value), with the share of the best plan's saving each policy captures;
    one line with the reason where the oracle does not apply."""
    head = ["## Oracle (perfect-foresight storage schedule)", ""]
    if bounds.reason is not None:
        return [*head, f"No oracle: {bounds.reason}", ""]
    skipped = [f"- {ORACLE_BOUNDS[k][0]}: {why}" for k, why in bounds.skipped.items()]
    if not bounds.bounds:
        return [*head, "The oracle was not run:", "", *skipped, ""]
    policies = list(objectives)
    rows = []
    for key, (label, unit, decimals) in ORACLE_BOUNDS.items():
        found = bounds.bounds.get(key)
        if found is None:
            continue
        base = objectives.get("no_control", {}).get(key, found.no_control)
        values = [objectives[p][key] for p in policies]
        lower = f"{found.lower_bound:.{decimals}f}" if np.isfinite(found.lower_bound) else "-"
        rows.append([label, unit, *(f"{v:.{decimals}f}" for v in values), f"{found.plan:.{decimals}f}", lower,
                     _change(found.plan, base),
                     *(_captured(base, v, found.plan) for p, v in zip(policies, values, strict=True)
                       if p != "no_control")])
    labels = [POLICY_LABELS.get(p, p) for p in policies]
    header = ["objective", "unit", *labels, "oracle best plan", "certified lower bound", "best plan vs no control",
              *(f"{POLICY_LABELS.get(p, p)}: share of the best plan's saving" for p in policies
                if p != "no_control")]
    return [*head, f"The best schedule found for each objective by scheduling the {bounds.storages} storages "
            "(DHW tanks, batteries) alone, with perfect knowledge of the period, and a certified lower bound no "
            "schedule can beat (pipeline/optimal, docs/controllers.md); one schedule per objective. Share = "
            "(no control - policy) / (no control - best plan).", "", *_table(header, rows), "",
            *([*skipped, ""] if skipped else [])]


def _captured(base: float, value: float, bound: float) -> str:
    saving = base - bound
    return "-" if abs(saving) <= 1e-9 * max(abs(base), 1e-12) else f"{100.0 * (base - value) / saving:.1f} %"


def building_objectives_table(per: Mapping[str, Mapping[str, np.ndarray]], buildings: list[str]) -> list[str]:
    """Cost [$], emissions [kg CO2], consumption [kWh] and discomfort [degC h] per building and policy, from
    ``per``: policy -> the ``per_building`` arrays of :func:`citylearn_env.kpis.objectives`."""
    policies = list(per)
    names = " / ".join(POLICY_LABELS.get(p, p) for p in policies)
    keys = ("cost", "emissions", "consumption", "discomfort")
    rows = [[building, *(" / ".join(f"{per[p][k][b]:.{OBJECTIVES[k][1]}f}" for p in policies) for k in keys)]
            for b, building in enumerate(buildings)]
    return [f"## Objectives per building ({names})", "",
            *_table(["building", *(f"{k} {OBJECTIVES[k][0]}" for k in keys)], rows), ""]


def kpi_unit(kpi: str) -> str:
    """The unit of a CityLearn KPI of the district table."""
    return next((unit for prefix, unit in KPI_UNITS if kpi.startswith(prefix)), "ratio to no-storage baseline")


def kpi_table(kpis: Mapping[str, Any]) -> list[str]:
    """The district rows of each policy's KPI table (``kpis_<policy>.csv``), 4 decimals, "n/a" for NaN."""
    policies = list(kpis)
    district = {p: t[t["level"] == "district"].set_index("cost_function")["value"] for p, t in kpis.items()}
    rows = []
    for kpi in district[policies[0]].index:
        values = [float(district[p].get(kpi, float("nan"))) for p in policies]
        rows.append([kpi, kpi_unit(kpi), *("n/a" if math.isnan(v) else f"{v:.4f}" for v in values)])
    return ["## KPIs (CityLearn evaluate, district level; kpis_<policy>.csv)", "",
            "Ratios compare each policy's run with its own run without storage (1 = no change, lower is "
            "better); n/a: not defined for the period (no outage).", "",
            *_table(["KPI", "unit", *(POLICY_LABELS.get(p, p) for p in policies)], rows), ""]


def write_figures(report_dir: Path, buildings: list[str], series: Mapping[str, Mapping[str, np.ndarray]],
                  nets: Mapping[str, np.ndarray]) -> list[tuple[str, str, str]]:
    """Draw every figure into ``report_dir``: the district's from ``nets`` (policy -> district net
    consumption (T,) [kWh]), one load and one temperature figure per building of ``buildings`` (the rows of
    ``series``: policy -> name -> (F, T)); return (section, caption, file name) in report order."""
    baseline = series["no_control"] if "no_control" in series else next(iter(series.values()))
    calendar = parse_calendar(baseline["hour"][0], baseline["month"][0], baseline["day_type"][0])
    window = peak_week(nets.get("no_control", next(iter(nets.values()))), calendar)
    out = [("District", "district net load, no control vs cost RBC (daily energy, daily peak, peak week)",
            policies_figure(report_dir / "district_net.png", nets, baseline["electricity_pricing"][0],
                                    calendar, window).name),
           ("District", "district net load by day and hour of day (heat maps)",
            heatmap_figure(report_dir / "district_heatmap.png", nets, calendar).name)]
    for b, building in enumerate(buildings):
        stem = safe_name(building)
        out.append((building, f"{building}: electricity by end use with tariff and carbon intensity",
                    load_figure(report_dir / f"load_{stem}.png", building, b, baseline, calendar,
                                        window).name))
        out.append((building, f"{building}: indoor temperature vs set point",
                    temperature_figure(report_dir / f"temperature_{stem}.png", building, b, baseline,
                                               calendar, window).name))
    return out


def figure_section(figures_written: list[tuple[str, str, str]]) -> list[str]:
    """Markdown image links of the figures, under one heading per section."""
    lines = ["## Figures", "", "Daily values over the whole period and hourly values over the peak week (the "
             "seven days around the day of the highest no-control district net load); no control unless named.",
             ""]
    section = None
    for name, caption, filename in figures_written:
        if name != section:
            lines += [f"### {name}", ""]
            section = name
        lines += [f"![{caption}]({filename})", ""]
    return lines[:-1]


def building_section(buildings: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """The buildings' stock heating, heating device [kW], demands [kWh], set points [degC] and set-point
    repairs, from their notes (``buildings.json``), after a blank line."""
    lines = ["", "## Buildings", "",
             "| building | bldg_id | stock heating | heating device | kW | heating / cooling demand kWh | "
             "set points degC (heat / cool) | set-point hours repaired |", "|---|---|---|---|---|---|---|---|"]
    for name, b in buildings.items():
        fuel = b.get("heating_fuel", "")
        stock = f"{b['heating_system']}{f' ({fuel})' if fuel else ''}"
        device = {"heat_pump": "heat pump", "electric_heater": "electric heater", None: "none"}[b["heating_device"]]
        heat, cool = b.get("heating_set_point_c"), b.get("cooling_set_point_c")
        points = f"{heat[0]:.1f}-{heat[1]:.1f} / {cool[0]:.1f}-{cool[1]:.1f}" if heat and cool else "-"
        power = f"{b['heating_power_kw']:.2f}" if b.get("heating_power_kw") is not None else "-"
        lines.append(f"| {name} | {b['bldg_id']} | {stock} | {device}: {b['heating_note']} | {power} | "
                     f"{b['heating_demand_kwh']:.0f} / {b['cooling_demand_kwh']:.0f} | {points} | "
                     f"{b.get('set_point_hours_repaired', '-')} |")
    if any(b.get("set_point_hours_repaired") for b in buildings.values()):
        lines += ["", "Repaired set points: where the stock's heating set point is at or above its cooling set "
                      "point (EnergyPlus refuses it), both move to their mean -/+ 0.5 K."]
    return lines


def selection_section(selection: SelectionSummary) -> list[str]:
    """The selection's k and its validity-index table (:func:`pipeline.select.format_validity`), after a blank
    line."""
    lines = ["", f"## Selection ({selection.heading or f'k = {selection.k}, one building per k-means cluster'})", ""]
    if not selection.validity:
        return [*lines, "Validity indices: not recorded by the build."]
    table = pd.DataFrame(list(selection.validity), columns=list(VALIDITY))
    return [*lines, "```", format_validity(table, selection.k), "```"]
