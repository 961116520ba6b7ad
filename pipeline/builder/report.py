"""The build report: ``report/summary.md`` (tables) and the PNG figures it shows (:mod:`pipeline.builder.report_figures`).

``summary.md`` holds the devices the sizing chose, the surrogates' held-out fit, the no-control vs cost-RBC
objectives (absolute units, district and per building), the oracle's bound on cost, emissions and average
daily peak (:func:`oracle_bounds`: the perfect-foresight storage schedule of :mod:`pipeline.optimal`; one
line saying why where it does not apply) and the district KPIs of ``kpis_<policy>.csv``
(CityLearn's ``evaluate``: ratios to the no-storage baseline), then the figures. It holds no timings and no
dates, so two builds of the same configuration write the same bytes.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.builder.report_figures import (
    END_USES,
    POLICY_LABELS,
    heatmap_figure,
    load_figure,
    parse_calendar,
    peak_week,
    policies_figure,
    safe_name,
    temperature_figure,
)
from pipeline.controllers import MISFIT_REASON, RULE_OBJECTIVES
from pipeline.select import describe_selection, format_validity

#: episode series the report needs (env.series() names), (B, T)
SERIES = ("net_electricity_consumption", "solar_generation", "electricity_pricing", "carbon_intensity",
          "indoor_dry_bulb_temperature", "indoor_dry_bulb_temperature_set_point", "outdoor_dry_bulb_temperature",
          *(key for key, _, _ in END_USES))
#: data columns the report needs for its calendar (env.data() names), (B, T)
CALENDAR = ("hour", "month", "day_type")
#: objective -> (unit, decimals) of :func:`citylearn_env.kpis.objectives`
OBJECTIVES = {"cost": ("$", 2), "emissions": ("kg CO2", 1), "discomfort": ("degC h", 1),
              "consumption": ("kWh", 1), "average_daily_peak": ("kW", 3)}
#: KPI name prefix -> unit of the KPI table (first match; else a ratio to the no-storage baseline)
KPI_UNITS = (("discomfort_delta", "degC"), ("discomfort", "fraction of occupied hours"),
             ("one_minus_thermal_resilience", "fraction of outage hours"))


def report_series(env: Any) -> dict[str, np.ndarray]:
    """What the report needs of a finished episode of ``env`` (a CityLearnEnv): name -> (B, T) arrays."""
    series = env.series()
    return {**{k: series[k] for k in SERIES}, **{k: env.data(k) for k in CALENDAR}}


def write_report(report_dir: Path, name: str, schema: dict, results: dict, surrogates_dir: Path,
                 bounds: Mapping[str, Any] | None = None) -> Path:
    """Write ``summary.md`` and its figures into ``report_dir``; return the summary's path.

    ``results``: policy ("no_control", "cost_rbc") -> {"objectives": name -> float, "per_building": name ->
    (B,) array (:func:`citylearn_env.kpis.objectives`), "kpis": the KPI table (cost_function, value, name,
    level), "series": :func:`report_series` of the finished episode}; ``bounds``: the oracle's
    (:func:`oracle_bounds`; None: no oracle section).
    """
    buildings = included_buildings(schema)
    series = {p: r["series"] for p, r in results.items()}
    steps = next(iter(series.values()))["net_electricity_consumption"].shape[1]
    lines = [f"# District {name}", "",
             f"{len(buildings)} buildings, {steps} hourly time steps; each policy runs once over the period with "
             "the heat pumps serving the ideal load (pipeline/controllers.py).", ""]
    lines += sizing_table(schema, buildings)
    lines += surrogate_table(read_surrogate_metrics(surrogates_dir))
    lines += objectives_table({p: r["objectives"] for p, r in results.items()})
    if bounds is not None:
        lines += oracle_table(bounds, {p: r["objectives"] for p, r in results.items()})
    lines += building_objectives_table({p: r["per_building"] for p, r in results.items()}, buildings)
    lines += kpi_table({p: r["kpis"] for p, r in results.items()})
    lines += figure_section(write_figures(report_dir, buildings, series))
    path = report_dir / "summary.md"
    path.write_text("\n".join(lines) + "\n")
    return path


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


#: the oracle bounds of the report: objective (pipeline.optimal.objectives) -> (label, unit, decimals)
ORACLE_BOUNDS = {"cost": ("cost", "$", 2), "emissions": ("emissions", "kg CO2", 1),
                 "average_daily_peak": ("average daily peak", "kW", 3)}


def oracle_bounds(district: Any, seed: int = 0, env: Any = None) -> dict[str, Any]:
    """The perfect-foresight optimum of ``district``'s storage (a loaded DistrictConfig) for each objective of
    :data:`ORACLE_BOUNDS`, over the episode the report's policies run (heat pumps serving the ideal load):
    {"bounds": objective -> {"bound", "no_control"} [the objective's unit], "storages": count} or, when the
    oracle does not apply, {"reason": one line}. ``env``: the report's no-control env of ``district`` (reset
    and reused; default: a new one). The cost and emission LPs are per building; the peak is one LP for the
    district, the slowest (one-month 6-building default district on a shared 2-core AMD EPYC: cost 0.5 s,
    emissions 0.5 s, peak 3.1 s)."""
    from citylearn_env import CityLearnEnv
    from pipeline.controllers import without_device_actions
    from pipeline.errors import InputError
    from pipeline.optimal.oracle import oracle
    from pipeline.optimal.solver import SolveError

    try:
        env = env if env is not None else CityLearnEnv(without_device_actions(district))
        env.reset(seed=seed)
        solved = {k: oracle(env, k) for k in ORACLE_BOUNDS}
    except (InputError, SolveError) as error:
        return {"reason": str(error).splitlines()[0]}
    storages = len(next(iter(solved.values())).schedule.storages)
    return {"storages": storages,
            "bounds": {k: {"bound": o.value, "no_control": o.baseline[k]} for k, o in solved.items()}}


def oracle_table(bounds: Mapping[str, Any], objectives: Mapping[str, Mapping[str, float]]) -> list[str]:
    """The oracle's bound per objective next to each policy's value (``objectives``: policy -> name -> value),
    with the share of the bound's saving each policy captures; one line with the reason where the oracle does
    not apply."""
    head = ["## Oracle bound (perfect-foresight storage schedule)", ""]
    if "reason" in bounds:
        return [*head, f"No oracle bound: {bounds['reason']}", ""]
    policies = list(objectives)
    rows = []
    for key, (label, unit, decimals) in ORACLE_BOUNDS.items():
        found = bounds["bounds"][key]
        base = objectives.get("no_control", {}).get(key, found["no_control"])
        values = [objectives[p][key] for p in policies]
        rows.append([label, unit, *(f"{v:.{decimals}f}" for v in values), f"{found['bound']:.{decimals}f}",
                     _change(found["bound"], base),
                     *(_captured(base, v, found["bound"]) for p, v in zip(policies, values, strict=True)
                       if p != "no_control")])
    labels = [POLICY_LABELS.get(p, p) for p in policies]
    header = ["objective", "unit", *labels, "oracle bound", "oracle vs no control",
              *(f"{POLICY_LABELS.get(p, p)}: share of the oracle's saving" for p in policies if p != "no_control")]
    return [*head, f"The lowest value each objective can reach by scheduling the {bounds['storages']} storages "
            "(DHW tanks, batteries) alone, with perfect knowledge of the period (pipeline/optimal, "
            "docs/controllers.md); one schedule per objective. Share = (no control - policy) / (no control - "
            "oracle).", "", *_table(header, rows), ""]


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


def write_figures(report_dir: Path, buildings: list[str], series: Mapping[str, Mapping[str, np.ndarray]]
                  ) -> list[tuple[str, str, str]]:
    """Draw every figure into ``report_dir``; return (section, caption, file name) in report order."""
    baseline = series["no_control"] if "no_control" in series else next(iter(series.values()))
    calendar = parse_calendar(baseline["hour"][0], baseline["month"][0], baseline["day_type"][0])
    nets = {p: s["net_electricity_consumption"].sum(axis=0) for p, s in series.items()}
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


def append_building_report(summary: Path, buildings: Mapping[str, dict], selection: Any) -> None:
    """Append the buildings' heating devices, set-point repairs and the selection to ``report/summary.md``."""
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
    if selection is not None:

        k = int(selection.chosen["k"].iloc[0])
        lines += ["", f"## Selection ({describe_selection(selection.chosen)})", "", "```",
                  format_validity(selection.validity, k), "```"]
    with open(summary, "a") as handle:
        handle.write("\n".join(lines) + "\n")
