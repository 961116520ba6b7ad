"""Wall time of EnergyPlus ILV generation for one house-year, and the speed-up with 2 worker processes.

    .venv/bin/python benchmarks/energyplus_ilv.py [--repeats 3] [--timesteps 1 4]
    .venv/bin/python benchmarks/energyplus_ilv.py --train     # surrogate accuracy on the fixture's ILV tables
    .venv/bin/python benchmarks/energyplus_ilv.py --timestep-accuracy [--timesteps 1 4] [--houses 2] [--recipe R]
        # the same houses generated at each zone timestep count, trained with a recipe of
        # benchmarks/surrogate_suite.py (default: TrainConfig()), held-out accuracy

One house-year = metadata -> epJSON model -> ideal-loads run -> multiplier-1 replay, free float and 4
partial replays (7 EnergyPlus runs, hourly reporting for the replays) -> SQLite reads -> ILV table in memory.
Target (issue 6): <= 15 s per house; near-linear speed-up with 2 workers.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from surrogates.energyplus.engine import find_energyplus
from surrogates.energyplus.ilv_runs import ILVConfig
from surrogates.sources.energyplus import energyplus_ilv_table

ROW = {"bldg_id": 1, "in.sqft": 1900, "in.geometry_stories": "2", "in.vintage": "1990s",
       "in.orientation": "South", "in.infiltration": "8 ACH50", "in.occupants": "3",
       "in.cooling_setpoint": "75F", "in.heating_setpoint": "68F"}


def epw() -> Path:
    return find_energyplus().parent / "WeatherData" / "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"


def _cpu_seconds() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def one_house(bldg_id: int, timesteps: int) -> float:
    start = time.perf_counter()
    result = energyplus_ilv_table({**ROW, "bldg_id": bldg_id}, epw(),
                                  config=ILVConfig(timesteps_per_hour=timesteps, seed=bldg_id))
    assert len(result.table) == 6 * 8760 and result.replay_mad_c <= 0.2
    return time.perf_counter() - start


def train_on_raw(epochs: int | None, use_free_float: bool = True) -> None:
    """Train one surrogate per committed raw/ ILV table (surrogates.train defaults) and print the closed-loop
    monthly RMSE (degC) on the held-out test segments."""
    import json

    import numpy as np

    from surrogates.config import TrainConfig
    from surrogates.evaluate import evaluate_segments
    from surrogates.ilv import read_ilv
    from surrogates.train import train_surrogate

    medians = []
    fixture = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "synthetic_district" / "ilv"
    for path in sorted(fixture.glob("*.parquet")):
        table = read_ilv(path)
        config = TrainConfig(progress=False, use_free_float=use_free_float,
                             **({} if epochs is None else {"epochs": epochs}))
        trained = train_surrogate(table, config, source=path)
        metrics, _ = evaluate_segments(trained.model, trained.normalization, trained.inputs, config.lookback,
                                       table, trained.splits["test"])
        medians.append(metrics["monthly_rmse_c"]["median"])
        print(path.name, json.dumps({"train_s": round(trained.seconds, 1), "best_epoch": trained.best_epoch,
                                     "monthly_rmse_c": metrics["monthly_rmse_c"],
                                     "closed_loop_rmse_c": metrics["closed_loop_rmse_c"]}), flush=True)
    print(f"median over houses of the monthly closed-loop RMSE median: {float(np.median(medians)):.3f} C")


def timestep_accuracy(timesteps: list[int], houses: int, recipe: str = "default") -> None:
    """Per house (Tampa, ``houses`` seeds of :data:`ROW`) and zone timestep count: generate the ILV table,
    train ``recipe`` (a :func:`surrogate_suite.recipes` name, with the last partial run held out as the test
    run), print the test run's closed-loop monthly RMSE (degC) and the CPU seconds."""
    import json
    from dataclasses import replace

    from surrogate_suite import recipes

    from surrogates.evaluate import evaluate_segments
    from surrogates.train import train_surrogate

    for bldg_id in range(1, houses + 1):
        for tph in timesteps:
            table = energyplus_ilv_table({**ROW, "bldg_id": bldg_id}, epw(),
                                         config=ILVConfig(timesteps_per_hour=tph, seed=bldg_id)).table
            config = replace(recipes()[recipe], test_runs=1)
            trained = train_surrogate(table, config)
            metrics, _ = evaluate_segments(trained.model, trained.normalization, trained.inputs, config.lookback,
                                           table, trained.splits["test"])
            print(json.dumps({"house": bldg_id, "timesteps_per_hour": tph, "recipe": recipe,
                              "train_cpu_s": round(trained.cpu_seconds, 1), "best_epoch": trained.best_epoch,
                              "monthly_rmse_c": metrics["monthly_rmse_c"], "load": os.getloadavg()[0]}),
                  flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timestep-accuracy", action="store_true",
                        help="held-out surrogate accuracy of houses generated at each --timesteps value")
    parser.add_argument("--train", action="store_true", help="only the surrogate accuracy on the test fixture ILV tables")
    parser.add_argument("--epochs", type=int, default=None, help="training epochs (default: TrainConfig's)")
    parser.add_argument("--no-free-float", action="store_true", help="leave the free-float run out of training")
    parser.add_argument("--recipe", default="default", help="--timestep-accuracy: a surrogate_suite.py recipe")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--timesteps", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--houses", type=int, default=4, help="houses for the 1-vs-2-worker comparison")
    args = parser.parse_args()
    if args.train:
        train_on_raw(args.epochs, use_free_float=not args.no_free_float)
        return
    if args.timestep_accuracy:
        timestep_accuracy(args.timesteps, args.houses, args.recipe)
        return
    for tph in args.timesteps:
        times, cpu = [], []
        for k in range(args.repeats):
            before = _cpu_seconds()
            times.append(one_house(k + 1, tph))
            cpu.append(_cpu_seconds() - before)
        print(f"one house-year, {tph} timestep(s)/h: median wall {statistics.median(times):.2f} s, "
              f"median CPU {statistics.median(cpu):.2f} s (wall runs: {', '.join(f'{t:.2f}' for t in times)}; "
              f"load average {os.getloadavg()[0]:.1f})")
    tph = args.timesteps[0]
    ids = list(range(101, 101 + args.houses))
    start = time.perf_counter()
    for i in ids:
        one_house(i, tph)
    serial = time.perf_counter() - start
    start = time.perf_counter()
    with ProcessPoolExecutor(2) as pool:
        list(pool.map(one_house, ids, [tph] * len(ids)))
    parallel = time.perf_counter() - start
    print(f"{args.houses} houses, {tph} timestep(s)/h: 1 worker {serial:.1f} s, 2 workers {parallel:.1f} s, "
          f"speed-up {serial / parallel:.2f}x (load average {os.getloadavg()[0]:.1f} at the end)")


if __name__ == "__main__":
    main()
