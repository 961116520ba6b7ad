"""Oracle speed (issue 29): seconds to plan the perfect-foresight storage optimum, median over repeats; and,
with ``--gaps``, the env replay gap of every upstream dataset with storage and of the default district.

    .venv/bin/python benchmarks/oracle_speed.py [--repeats 3] [--workers 2] [--cases month-1,year-17]
    .venv/bin/python benchmarks/oracle_speed.py --gaps [--peak]
    .venv/bin/python benchmarks/oracle_speed.py --repeats 1 --cases year-17-peak   (not a default case: ~20 min)

Timed: :func:`pipeline.optimal.oracle.oracle` on a reset environment (read the plan, build and solve the LPs,
iterate the battery efficiencies, assemble the schedule); loading the schema and resetting the env are timed
apart ("load"). Datasets: CityLearn's own upstream v2.1.2 sets in ../shared/data and the project's built
default district (artifacts/default); a case whose data is absent is skipped with the reason. Prints the CPU
(lscpu "Model name") and the load average before and after, because the machine may be shared.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from citylearn_env import CityLearnEnv  # noqa: E402  (after the path set-up: runs from a checkout)
from pipeline.optimal.optimum import district  # noqa: E402
from pipeline.optimal.oracle import oracle  # noqa: E402
from pipeline.optimal.replay import replay  # noqa: E402

UPSTREAM = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2"
DEFAULT = ROOT / "artifacts" / "default" / "schema.json"

#: name -> (schema, objective, first row, last row, buildings (None: all), what it is)
CASES = {
    "month-1": (UPSTREAM / "citylearn_challenge_2022_phase_1" / "schema.json", "cost", 0, 719, 1,
                "one month, one building (battery + PV)"),
    "month-1-default": (DEFAULT, "cost", 0, 719, 1, "one month, one building of the default district (DHW tank + "
                                                     "battery, LSTM)"),
    "month-6-default": (DEFAULT, "cost", 0, 719, None, "one month, the default district (6 buildings)"),
    "year-9-tanks": (UPSTREAM / "citylearn_challenge_2020_climate_zone_1" / "schema.json", "emissions", 0, 8759,
                     None, "one year, 9 buildings (cooling + DHW tanks + batteries)"),
    "year-17": (UPSTREAM / "citylearn_challenge_2022_phase_all" / "schema.json", "cost", 0, 8759, None,
                "one year, 17 buildings (batteries + PV)"),
    "month-17-peak": (UPSTREAM / "citylearn_challenge_2022_phase_all" / "schema.json", "average_daily_peak", 0,
                      719, None, "one month, 17 buildings, district peak (one joint LP)"),
    "year-17-peak": (UPSTREAM / "citylearn_challenge_2022_phase_all" / "schema.json", "average_daily_peak", 0,
                     8759, None, "one year, 17 buildings, district peak (one joint LP; ~20 min)"),
}
DEFAULT_CASES = ("month-1", "month-1-default", "month-6-default", "year-9-tanks", "year-17", "month-17-peak")


def cpu_name() -> str:
    """lscpu's "Model name" (platform.processor() when lscpu is unavailable)."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or "unknown"
    return next((line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name")),
                "unknown")


def load_env(schema: Path, first: int, last: int, buildings: int | None) -> CityLearnEnv:
    config = district(schema, start=first, end=last)
    if buildings is not None:
        config = config.with_buildings(config.building_names[:buildings])
    env = CityLearnEnv(config)
    env.reset(seed=0)
    return env


def time_case(name: str, repeats: int, workers: int) -> None:
    schema, objective, first, last, buildings, what = CASES[name]
    if not schema.exists():
        print(f"{name:16s} skipped: {schema} is absent")
        return
    began = time.perf_counter()
    env = load_env(schema, first, last, buildings)
    load = time.perf_counter() - began
    runs = []
    for _ in range(repeats):
        began = time.perf_counter()
        result = oracle(env, objective, workers=workers)
        runs.append(time.perf_counter() - began)
    print(f"{name:16s} {statistics.median(runs):7.2f} s median of {repeats} (min {min(runs):.2f}, load {load:.2f} s)"
          f"  {what}; {objective}; {len(env.building_names)} bldg x {env.episode_length} steps; "
          f"{result.iterations} solves, largest LP {result.size[0]} cols, plan vs physics {result.path_error:.0e}; "
          f"workers {workers}")


def gap_cases(peak: bool, skip: tuple[str, ...] = ()) -> list[tuple[str, Path, str]]:
    """Every upstream v2.1.2 dataset and the default district (but those whose name contains one of ``skip``),
    with its objective (cost where prices are not all 0, else emissions) and, with ``peak``, the average daily
    peak too."""
    cases = []
    for schema in sorted(UPSTREAM.glob("*/schema.json")) + [DEFAULT]:
        if not schema.exists() or any(s and s in schema.parent.name for s in skip):
            continue
        label = "default (artifacts)" if schema == DEFAULT else schema.parent.name
        cases.append((label, schema, "emissions" if "2020" in label or "2021" in label else "cost"))
        if peak:
            cases.append((label, schema, "average_daily_peak"))
    return cases


def gaps(peak: bool, workers: int, skip: tuple[str, ...]) -> None:
    """The replay gap table: LP value, the env's value following the plan's states of charge, and the gaps
    of that replay and of the open-loop one (planned energies as actions), in %."""
    print(f"{'dataset':54s} {'objective':19s} {'LP':>14s} {'env (soc)':>14s} {'gap soc %':>10s} "
          f"{'gap open-loop %':>16s} {'oracle s':>9s}")
    for label, schema, objective in gap_cases(peak, skip):
        env = CityLearnEnv(district(schema))
        env.reset(seed=0)
        plan = oracle(env, objective, workers=workers)
        tracked, open_loop = replay(env, plan.schedule, track="soc"), replay(env, plan.schedule, track="energy")
        print(f"{label:54s} {objective:19s} {plan.objectives[objective]:14.6g} {tracked.objectives[objective]:14.6g} "
              f"{tracked.gap[objective] * 100:10.5f} {open_loop.gap[objective] * 100:16.5f} {plan.seconds:9.1f}",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", type=int, default=1, help="processes solving buildings in parallel")
    parser.add_argument("--cases", default=",".join(DEFAULT_CASES), help=f"comma-separated, of {', '.join(CASES)}")
    parser.add_argument("--gaps", action="store_true", help="the replay gap table instead of the timings")
    parser.add_argument("--peak", action="store_true", help="with --gaps: also the average daily peak")
    parser.add_argument("--skip", default="", help="with --gaps: comma-separated parts of dataset names to leave out")
    args = parser.parse_args()
    print(f"CPU: {cpu_name()} ({os.cpu_count()} logical cores); load average before: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.gaps:
        gaps(args.peak, args.workers, tuple(args.skip.split(",")))
    else:
        for name in args.cases.split(","):
            time_case(name, args.repeats, args.workers)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
