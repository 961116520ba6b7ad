"""Realism of a neighbourhood as a distribution: the 10th/50th/90th percentiles of each house statistic over the
built houses against the same percentiles over real EULP-derived houses (issue 48, item 6).

    .venv/bin/python benchmarks/realism_distribution.py --district /path/to/n100 --season JJA
    .venv/bin/python benchmarks/realism_distribution.py --simulate CONFIG.toml --workers 2 --season DJF \\
        --real-folder ../shared/data/citylearn/upstream/v2.4.2/vt_chittenden_county_neighborhood

Built houses: a built district folder (its building CSVs, floor areas from buildings.json), or ``--simulate``:
the houses of a district TOML simulated now, one EnergyPlus ideal-loads pass each over the configuration's
period (the build's house model, loads and occupant schedules: a repeated stock row draws its schedules with
``schedule_seed + r`` as the build does; ``[selection] houses = N`` resolved as the build resolves it), on
``--workers`` processes.

Real houses: the 2023 challenge homes (Austin TX, June-August; :func:`realism.real_house_months`), or every
building CSV of ``--real-folder`` (e.g. upstream CityLearn's Chittenden County VT neighbourhood: 47 real ResStock
houses with EULP AMY2018 loads, the whole year). Both sides: house-months of ``--season`` (DJF, JJA, ...; or
``--months``). Statistics: :data:`realism.STATISTICS` (the hour-of-day shape as the L1 distance to the real
median profile). A statistic is "within" when each of its three built percentiles is within +-25 % of the real
one (the hour-of-day shape: within 25 % of the real houses' own distances).
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from realism import (  # noqa: E402
    CITYLEARN,
    SEASONS,
    STATISTICS,
    HouseMonth,
    built_house_months,
    fill_statistics,
    read_building_csv,
    real_house_months,
    split_months,
    total_kwh,
)

from pipeline.realism import hour_of_day_profile, median_profile, percentile_band  # noqa: E402

PERCENTILES = (10, 50, 90)
TOLERANCE = 0.25
#: statistic -> below this real median the season has none of it (not compared): kWh in the month
NEGLIGIBLE = {"cooling_kwh": 10.0, "heating_kwh": 10.0}


def folder_house_months(folder: Path) -> list[HouseMonth]:
    """Every building CSV a dataset folder's schema.json names (``energy_simulation``), split into months."""
    schema = json.loads((folder / "schema.json").read_text())
    out = []
    for name, spec in schema["buildings"].items():
        out += split_months(name, read_building_csv(folder / spec["energy_simulation"]))
    return out


def district_houses(config_path: Path) -> list[tuple[str, int, int]]:
    """(building name, bldg_id, occupant-schedule seed) of a district TOML, its selection resolved as the build
    resolves it (repeats with their own schedule seed)."""
    from pipeline.builder.houses import house_config, schedule_repeats
    from pipeline.builder.steps import building_names, resolve_selection
    from pipeline.config import read_build_config

    config, _ = resolve_selection(read_build_config(config_path))
    ids = config.inputs.buildings
    return [(name, int(bldg_id), house_config(config, repeat).simulation.schedule_seed)
            for name, bldg_id, repeat in zip(building_names(config), ids, schedule_repeats(ids), strict=True)]


def simulate_one(config_path: Path, name: str, bldg_id: int, schedule_seed: int) -> list[HouseMonth]:
    """One house's ideal-loads pass over the configuration's period (:func:`realism.simulated_house`)."""
    from realism import simulated_house

    from pipeline.config import read_build_config
    from pipeline.ingest.stock import read_characteristics_row

    config = read_build_config(config_path)
    return simulated_house(config, name, read_characteristics_row(config.inputs.characteristics, bldg_id),
                           schedule_seed)


def simulated(config_path: Path, workers: int) -> list[HouseMonth]:
    houses = district_houses(config_path)
    with ProcessPoolExecutor(workers) as pool:
        parts = pool.map(simulate_one, *zip(*[(config_path, *h) for h in houses], strict=True))
        return [item for part in parts for item in part]


def percentiles(values: list[float]) -> np.ndarray:
    """The 10th, 50th and 90th percentiles of the finite ``values`` (:func:`pipeline.realism.percentile_band`)."""
    return np.asarray(percentile_band(values, PERCENTILES[0], PERCENTILES[2]), dtype=float)


def distribution_table(built: list[HouseMonth], real: list[HouseMonth]) -> tuple[str, dict]:
    """Markdown: per statistic the real and built 10/50/90th percentiles, built / real, and whether all three
    are within +-25 %; and the same as a dict."""
    header = ["statistic", *(f"real p{p}" for p in PERCENTILES), *(f"built p{p}" for p in PERCENTILES),
              "built / real (p10, p50, p90)", "within +-25 %"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    summary = {}
    for key, (label, decimals) in STATISTICS.items():
        ours, theirs = percentiles([b.stats[key] for b in built]), percentiles([r.stats[key] for r in real])
        if not np.isfinite(theirs).all() or not np.isfinite(ours).all():
            continue
        if theirs[1] < NEGLIGIBLE.get(key, -np.inf):
            lines.append("| " + " | ".join([label, *(f"{v:,.{decimals}f}" for v in theirs),
                                            *(f"{v:,.{decimals}f}" for v in ours), "-",
                                            "not compared (real median below "
                                            f"{NEGLIGIBLE[key]:g} kWh)"]) + " |")
            continue
        ratios = ours / np.where(theirs == 0, np.nan, theirs)
        within = bool(np.all(np.abs(ratios - 1.0) <= TOLERANCE))
        lines.append("| " + " | ".join([label, *(f"{v:,.{decimals}f}" for v in theirs),
                                        *(f"{v:,.{decimals}f}" for v in ours),
                                        ", ".join(f"{r:.2f}" for r in ratios), "yes" if within else "**no**"]) + " |")
        summary[key] = {"real": theirs.tolist(), "built": ours.tolist(), "ratios": ratios.tolist(), "within": within}
    return "\n".join(lines), summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--district", type=Path, help="a built district folder")
    source.add_argument("--simulate", type=Path, metavar="DISTRICT_TOML", help="simulate the district's houses now")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--real-folder", type=Path, help="real houses: every building of this dataset folder "
                        "(default: the 2023 challenge homes of ../shared)")
    parser.add_argument("--season", default="JJA", choices=sorted(set(SEASONS.values())))
    parser.add_argument("--months", type=int, nargs="+", help="compare these calendar months (default: the season's)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    months = set(args.months or [m for m, s in SEASONS.items() if s == args.season])
    if args.real_folder is not None:
        if not (args.real_folder / "schema.json").is_file():
            print(f"no schema.json in {args.real_folder}")
            return 2
        real = [r for r in folder_house_months(args.real_folder) if r.month in months]
        real_name = args.real_folder.name
    else:
        if not CITYLEARN.is_dir():
            print(f"real reference data not found: {CITYLEARN} (needs ../shared/data/citylearn)")
            return 2
        real = [r for r in real_house_months(CITYLEARN, args.season) if r.month in months]
        real_name = "the 2023 challenge homes (Austin TX)"
    built = simulated(args.simulate, args.workers) if args.simulate else built_house_months(args.district)
    built = [b for b in built if b.month in months]
    if not real or not built:
        print(f"nothing to compare in months {sorted(months)}: {len(built)} built, {len(real)} real house-months")
        return 2
    reference = median_profile([hour_of_day_profile(total_kwh(r.loads), r.loads["hour"]) for r in real])
    fill_statistics(real, reference)
    fill_statistics(built, reference)
    table, summary = distribution_table(built, real)
    print(f"built: {len(built)} house-months of {len({b.name for b in built})} houses "
          f"({args.simulate or args.district}); real: {len(real)} house-months of {len({r.name for r in real})} "
          f"houses, {real_name}; months {sorted(months)}\n")
    print(table)
    if args.json:
        args.json.write_text(json.dumps({"months": sorted(months), "built": len(built), "real": len(real),
                                         "statistics": summary}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
