"""The oracle at scale and what it certifies (issues 48 and 51): seconds, the best plan, the certified lower bound
and their gap.

    .venv/bin/python benchmarks/oracle_scale.py [--cases peak-17-year,peak-100-month,cost-100-month,gaps-2022]

Cases (CityLearn's upstream v2.1.2 sets in ../shared/data; a case whose data is absent is skipped):

* ``peak-17-year``: citylearn_challenge_2022_phase_all, 17 buildings x 8,760 steps, average daily peak (the
  17 batteries are scaled copies: merged in lockstep, :mod:`pipeline.optimal.lockstep`);
* ``peak-100-month``: the same set's first month with its 17 buildings repeated to 100 (building i is data
  building i mod 17), average daily peak;
* ``cost-100-month``: those 100 buildings, cost: one LP group per building, mapped on an InProcessRunner and on
  a ProcessRunner of 2 workers (:mod:`pipeline.runners`);
* ``gaps-2022``: cost on every 2022 set over its first month and the paper's test period (rows 312..719), the
  best plan replayed in the env beside the bound.

Timed: :func:`pipeline.optimal.oracle.solve_plant` (plan, polish, bound, schedule) on a plant read from a reset
env (the read is not timed); for ``gaps-2022`` the oracle and the replay apart. Prints the CPU and the load
average before and after (the machine may be shared).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpc_speed import cpu_family  # noqa: E402  (this folder is on the path when the script runs)
from oracle_speed import cpu_name  # noqa: E402

from citylearn_env import CityLearnEnv  # noqa: E402  (after the path set-up: runs from a checkout)
from pipeline.optimal.optimum import CERTIFY_SECONDS, district, optimal  # noqa: E402
from pipeline.optimal.oracle import solve_plant  # noqa: E402
from pipeline.optimal.plant import Plant, plant_from_env  # noqa: E402
from pipeline.runners import InProcessRunner, ProcessRunner  # noqa: E402

UPSTREAM = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2"
ALL = UPSTREAM / "citylearn_challenge_2022_phase_all" / "schema.json"
CASES = ("peak-17-year", "peak-100-month", "cost-100-month", "gaps-2022")


def plant_of(schema: Path, first: int, last: int) -> Plant:
    env = CityLearnEnv(district(schema, start=first, end=last))
    env.reset(seed=0)
    return plant_from_env(env)


def repeated(plant: Plant, count: int) -> Plant:
    """``plant`` with its buildings repeated to ``count`` (building i is building i mod B of ``plant``)."""
    source = np.arange(count) % len(plant.building_names)
    storages = tuple(dataclasses.replace(s, building=i) for i, b in enumerate(source)
                     for s in plant.storages if s.building == b)
    return dataclasses.replace(
        plant, building_names=tuple(f"{plant.building_names[b]}#{i}" for i, b in enumerate(source)),
        base_net=plant.base_net[source], price=plant.price[source], carbon=plant.carbon[source],
        outage=plant.outage[source], surplus=plant.surplus[source], storages=storages)


def report(name: str, seconds: float, result, what: str) -> None:
    print(f"{name:22s} {seconds:8.2f} s  best plan {result.value:.6g}, certified bound {result.bound:.6g}, "
          f"gap {result.gap * 100:.3f} %; {result.iterations} LP solves, largest LP {result.size[0]} cols; {what}",
          flush=True)


def timed(name: str, plant: Plant, objective: str, what: str, **keywords) -> None:
    began = time.perf_counter()
    result = solve_plant(plant, objective, **keywords)
    report(name, time.perf_counter() - began, result, what)


def gaps() -> None:
    for label in ("phase_1", "phase_2", "phase_3"):
        schema = UPSTREAM / f"citylearn_challenge_2022_{label}" / "schema.json"
        for rows in ((0, 719), (312, 719)):
            began = time.perf_counter()
            result = optimal(schema, "cost", *rows, quiet=True, certify=CERTIFY_SECONDS)
            seconds = time.perf_counter() - began
            print(f"2022 {label} rows {rows[0]}..{rows[1]}: best plan (env) {result.value:.6g} $, certified bound "
                  f"{result.bound:.6g} $, gap {result.gap * 100:.3f} %; plan vs env "
                  f"{result.replay.gap['cost'] * 100:+.4f} %; oracle {result.oracle.seconds:.1f} s, with the "
                  f"replay {seconds:.1f} s", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of {', '.join(CASES)}")
    args = parser.parse_args()
    print(f"CPU: {cpu_name()}{cpu_family()} ({os.cpu_count()} logical cores); load average before: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if not ALL.exists():
        print(f"skipped: {ALL} is absent")
        return
    for name in args.cases.split(","):
        if name == "peak-17-year":
            timed(name, plant_of(ALL, 0, 8759), "average_daily_peak", "17 bldg x 8,760 steps (lockstep)")
        elif name == "peak-100-month":
            timed(name, repeated(plant_of(ALL, 0, 719), 100), "average_daily_peak", "100 bldg x 720 steps (lockstep)")
        elif name == "cost-100-month":
            plant = repeated(plant_of(ALL, 0, 719), 100)
            timed(name + " in-process", plant, "cost", "100 bldg x 720 steps", runner=InProcessRunner())
            timed(name + " 2 processes", plant, "cost", "100 bldg x 720 steps", runner=ProcessRunner(2))
        elif name == "gaps-2022":
            gaps()
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
