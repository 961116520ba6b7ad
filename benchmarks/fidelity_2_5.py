"""No-control energy and KPIs of citylearn_env on upstream's v2.4.2 datasets against CityLearn 2.5.0.

    .venv/bin/python benchmarks/fidelity_2_5.py [--datasets NAME ...] [--json OUT] [--write]

The upstream side is the stored reference run ``benchmarks/upstream_2_5_0/no_control.json`` (made by
``benchmarks/ev_upstream.py`` with CityLearn 2.5.0; every action inactive, ideal loads). Ours: the same schema
loaded with the preset (``load_schema(schema, settings=...)``: the 2.5 preset draws the device defaults 2.5.0
draws), every action inactive (the typed config's ``with_actions([])``), one episode, ``reset(seed=0)``, in two
behaviour presets:

* the CityLearn 2.5 preset (``settings="citylearn-2.5"``; on a tree without that preset, its stand-in
  ``dataclasses.replace(CORRECTED, legacy_outage_draws=True)``, the one field that moves no-control energy);
* the corrected default (``CORRECTED``).

Compared: the district net electricity consumption summed over the episode [kWh] (signed relative difference;
the 2.5 preset books it as 2.5.0 does -- act-then-advance, the last time step never simulated, the first step's
consumption booked three times -- target |.| <= 1e-6; and, for the corrected default, ours summed with 2.5.0's
bookkeeping: only the first T - 1 time steps, plus twice the first step's cooling, heating, DHW and non-shiftable
consumption), and every KPI of 2.5.0's table (district row and every building row; relative difference as in
``benchmarks/fidelity.py``: NaN on both sides or both below 1e-9 count as equal). The 2.5 preset reports 2.5.0's
names; the corrected default's 2.1 names are compared through :data:`RENAMED`: ``all_time_peak_average`` ~
``annual_peak_average`` (2.5.0's window is the episode, 2.1's 8760 steps), ``discomfort_cold_proportion`` ~
``discomfort_too_cold_proportion``, ``discomfort_hot_proportion`` ~ ``discomfort_too_hot_proportion``. Prints
Markdown tables; ``--write`` stores the comparison (district rows and each KPI's worst building) in
``benchmarks/upstream_2_5_0/kpi_fidelity.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from fidelity import kpi_rows, no_control_episode, relative  # noqa: E402

from citylearn_env import SchemaError, load_schema  # noqa: E402
from citylearn_env.settings import CORRECTED, PRESETS, Behaviour  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.4.2"
STORE = ROOT / "benchmarks" / "upstream_2_5_0"
REFERENCE = STORE / "no_control.json"
#: CityLearn 2.5.0 KPI name -> the citylearn_env (CityLearn 2.1) name of the same quantity
RENAMED = {
    "all_time_peak_average": "annual_peak_average",
    "discomfort_cold_proportion": "discomfort_too_cold_proportion",
    "discomfort_hot_proportion": "discomfort_too_hot_proportion",
}


def preset_2_5() -> Behaviour | str:
    """The CityLearn 2.5 preset: its name once ``citylearn_env.settings`` has it, else the stand-in
    ``CORRECTED`` with the legacy outage draws (2.5.0 still draws outages as 2.1 does)."""
    return "citylearn-2.5" if "citylearn-2.5" in PRESETS else dataclasses.replace(CORRECTED, legacy_outage_draws=True)


def run_ours(schema: Path, settings: Behaviour | str) -> dict:
    """One episode with every action inactive: district energy [kWh], the same with 2.5.0's bookkeeping (the
    energy itself where the preset books as 2.5.0 does: ``act_then_advance``) and the KPI rows
    ``[kpi, name, value]``."""
    env, _ = no_control_episode(load_schema(schema, settings=settings).with_actions([]), settings)
    series = env.series()
    net = np.asarray(series["net_electricity_consumption"])
    first = sum(np.asarray(series[f"{k}_electricity_consumption"])[:, 0].sum() for k in END_USES)
    booked = net.sum() if env.settings.act_then_advance else net[:, :-1].sum() + 2 * first
    return {"district_energy_kwh": float(net.sum()), "upstream_bookkeeping_kwh": float(booked),
            "kpis": kpi_rows(env)}


#: the end uses whose first-step consumption CityLearn 2.5.0 books three times
END_USES = ("cooling", "heating", "dhw", "non_shiftable_load")


def shared_names(upstream_kpis: list[dict], ours_kpis: list) -> tuple[list[str], list[str]]:
    """(KPI names both sides compute, 2.5.0 names compared through :data:`RENAMED`), sorted."""
    theirs = {r["cost_function"] for r in upstream_kpis}
    mine = {k for k, _, _ in ours_kpis}
    return sorted(theirs & mine), sorted(k for k in theirs - mine if RENAMED.get(k) in mine)


def compare(upstream: dict, ours: dict) -> dict:
    """District energy (signed relative difference) and, per shared or renamed KPI, the district values and
    relative difference plus the worst building row (name, relative difference)."""
    exact, renamed = shared_names(upstream["kpis"], ours["kpis"])
    mine = {(k, n): v for k, n, v in ours["kpis"]}
    kpis = {}
    for name in exact + renamed:
        ours_name = name if name in exact else RENAMED[name]
        rows = [(r["name"], r["value"], mine.get((ours_name, r["name"])))
                for r in upstream["kpis"] if r["cost_function"] == name]
        rel = {who: relative(o, u) if o is not None else math.inf for who, u, o in rows}
        district = next((u, o) for who, u, o in rows if who == "District")
        buildings = {who: r for who, r in rel.items() if who != "District"}
        worst = max(buildings, key=buildings.get) if buildings else None
        kpis[name] = {"ours_name": ours_name, "upstream": district[0], "ours": district[1],
                      "relative": rel["District"], "worst_building": worst,
                      "worst_building_relative": buildings.get(worst, 0.0)}
    theirs = upstream["district_net_electricity_consumption_sum"]
    return {"upstream_kwh": theirs, "ours_kwh": ours["district_energy_kwh"],
            "energy_relative": ours["district_energy_kwh"] / theirs - 1,
            "bookkeeping_relative": ours["upstream_bookkeeping_kwh"] / theirs - 1, "kpis": kpis}


def json_safe(value):
    """``value`` with every NaN or infinite float (nested in dicts and lists) replaced by None, for JSON."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    return None if isinstance(value, float) and not math.isfinite(value) else value


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="*", default=None)
    parser.add_argument("--json", type=Path, help="write the full comparison here")
    parser.add_argument("--write", action="store_true", help="store the comparison in upstream_2_5_0/")
    args = parser.parse_args()
    reference = json.loads(REFERENCE.read_text())
    names = args.datasets or sorted(n for n, r in reference.items() if r.get("mode") == "no_control")
    presets = {"citylearn-2.5": preset_2_5(), "corrected": CORRECTED}
    report = {}
    for name in names:
        upstream = reference[name]
        report[name] = {}
        for label, settings in presets.items():
            try:
                report[name][label] = compare(upstream, run_ours(DATA / name / "schema.json", settings))
            except SchemaError as error:  # e.g. the EV dataset until EVs are wired in
                report[name][label] = {"upstream_kwh": upstream["district_net_electricity_consumption_sum"],
                                       "error": str(error)}
    print(f"load average {os.getloadavg()}; 2.5 preset: {presets['citylearn-2.5']!r}"[:200])
    print_energy(report)
    print_kpis(report)
    if args.json:
        args.json.write_text(json.dumps(json_safe(report), indent=1))
    if args.write:
        store = STORE / "kpi_fidelity.json"
        old = json.loads(store.read_text()) if store.is_file() else {}
        merged = {**old, **json_safe(report)}
        lines = ",\n".join(f"{json.dumps(n)}: {json.dumps(merged[n], sort_keys=True)}" for n in sorted(merged))
        store.write_text("{\n" + lines + "\n}\n")  # a dataset a line
    return 0


def print_energy(report: dict) -> None:
    """Markdown: upstream kWh, ours in each preset and the signed relative difference."""
    print("\n| dataset | CityLearn 2.5.0 kWh | ours, 2.5 preset kWh | relative | with 2.5.0's bookkeeping | "
          "ours, corrected kWh | relative |")
    print("|---|---|---|---|---|---|---|")
    for name, sides in report.items():
        cells = [f"{sides['citylearn-2.5']['upstream_kwh']:,.1f}"]
        for label in ("citylearn-2.5", "corrected"):
            side = sides[label]
            cells += ([f"not loaded: {side['error'][-70:]}", ""] if "error" in side else
                      [f"{side['ours_kwh']:,.1f}", f"{side['energy_relative']:+.4%}"])
            if label == "citylearn-2.5":
                cells += ["" if "error" in side else f"{side['bookkeeping_relative']:+.1e}"]
        print(f"| {name} | " + " | ".join(cells) + " |")


def print_kpis(report: dict) -> None:
    """Markdown, one row per dataset: for every shared KPI, the district row's relative difference in the 2.5
    preset and, after a slash, the worst building row's (``-`` where the KPI has no building rows); then the
    same for the corrected default."""
    for label in ("citylearn-2.5", "corrected"):
        sides = {n: s[label] for n, s in report.items() if "error" not in s[label]}
        if not sides:
            continue
        names = list(next(iter(sides.values()))["kpis"])
        print(f"\nKPIs, {label}: relative difference district / worst building, against CityLearn 2.5.0")
        print("| dataset | " + " | ".join(names) + " |\n|---|" + "---|" * len(names))
        for name, side in sides.items():
            cells = [f"{cell(k['relative'])} / {cell(k['worst_building_relative']) if k['worst_building'] else '-'}"
                     for k in (side["kpis"].get(n) for n in names)]
            print(f"| {name} | " + " | ".join(cells) + " |")


def cell(value: float | None) -> str:
    """A relative difference for a table: 0, NaN-vs-number as "nan", else 1 significant digit."""
    if value is None or not math.isfinite(value):
        return "nan"
    return "0" if value == 0 else f"{value:.0e}"


if __name__ == "__main__":
    raise SystemExit(main())
