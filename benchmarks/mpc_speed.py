"""MPC speed (issue 29, part 5): seconds for one closed-loop MPC episode over the paper's 17-day test period
(data rows 312..719: 408 steps, after 13 training days), median over repeats, with the objective it reached.

    .venv/bin/python benchmarks/mpc_speed.py [--repeats 3] [--cases storage-perfect,storage-predicted,hp-surrogate]

Cases: ``storage-100``: the storage LP's MPC (cost, perfect forecasts) on 100 buildings: citylearn_challenge_2022_phase_all's
17 buildings repeated to 100 (:func:`env_scale.write_city`, each copy its own battery), issue 48's scale case;
``storage-<forecast>``: the storage LP's MPC (:func:`pipeline.optimal.mpc.mpc`, 24-step horizon, cost) on
CityLearn's citylearn_challenge_2022_phase_1 (5 buildings, battery + PV, upstream v2.1.2) with each forecast
(day-ahead profiles and the PV fit learned on rows 0..311); ``hp-surrogate``: CEM MPC through the LSTM
(:func:`pipeline.optimal.surrogate.surrogate_mpc`, 6-step horizon, 32 samples x 3 rounds) on the paper's
heat-pump benchmark building of citylearn_challenge_2023_phase_1 (upstream v2.4.2). Timed: the whole episode
(the env's steps, forecasts, LP builds and solves or rollouts); loading the schema is not. A case whose data
is absent is skipped with the reason. Prints the CPU (lscpu "Model name") and the load average before and
after (the machine may be shared).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from oracle_speed import cpu_name  # noqa: E402  (this folder is on the path when the script runs)

from citylearn_env import CityLearnEnv, load_schema  # noqa: E402  (after the path set-up: runs from a checkout)
from pipeline.optimal.optimum import district  # noqa: E402

UPSTREAM = ROOT.parent / "shared" / "data" / "citylearn" / "upstream"
STORAGE = UPSTREAM / "v2.1.2" / "citylearn_challenge_2022_phase_1" / "schema.json"
HEAT_PUMP = UPSTREAM / "v2.4.2" / "citylearn_challenge_2023_phase_1" / "schema.json"
TEST, TRAIN = (312, 719), (0, 311)
CASES = ("storage-perfect", "storage-persistence", "storage-day_ahead", "storage-predicted", "hp-surrogate",
         "storage-100")
ALL = UPSTREAM / "v2.1.2" / "citylearn_challenge_2022_phase_all" / "schema.json"
DEFAULT_CASES = ("storage-perfect", "storage-predicted", "hp-surrogate")


def storage_run(forecast: str) -> tuple[float, str]:
    """One storage MPC episode: (seconds, what it reached)."""
    from pipeline.optimal.mpc import mpc

    env = CityLearnEnv(district(STORAGE, start=TEST[0], end=TEST[1]))
    began = time.perf_counter()
    run = mpc(env, "cost", horizon=24, forecast=forecast, train=TRAIN)
    return time.perf_counter() - began, f"cost {run.objectives['cost']:.2f} $, {run.solves} LP solves"


def storage_100_run() -> tuple[float, str]:
    """One storage MPC episode of 100 buildings (perfect forecasts): (seconds, what it reached)."""
    import tempfile

    from env_scale import write_city

    from pipeline.optimal.mpc import mpc

    with tempfile.TemporaryDirectory() as folder:
        env = CityLearnEnv(district(write_city(100, Path(folder), source=ALL.parent), start=TEST[0], end=TEST[1]))
        began = time.perf_counter()
        run = mpc(env, "cost", horizon=24, forecast="perfect", train=TRAIN)
        return time.perf_counter() - began, f"cost {run.objectives['cost']:.2f} $, {run.solves} LP solves"


def heat_pump_run() -> tuple[float, str]:
    """One surrogate MPC episode on the heat-pump benchmark building: (seconds, what it reached)."""
    from pipeline.optimal.surrogate import surrogate_mpc

    whole = load_schema(HEAT_PUMP)
    config = (whole.with_buildings(whole.building_names[:1]).with_actions(["cooling_device"])
              .with_episode([TEST]).without_outages().replace(central_agent=True))
    began = time.perf_counter()
    run = surrogate_mpc(CityLearnEnv(config), horizon=6, seed=0)
    return time.perf_counter() - began, (f"value {run.value:.3f} = cost {run.cost:.3f} $ + 0.1 x penalty "
                                         f"{run.penalty:.1f} degC-h")


def cpu_family() -> str:
    """" family F model M" from /proc/cpuinfo (lscpu's model name alone can be as short as "AMD EPYC")."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return ""
    found = dict(line.split(":", 1) for line in text.splitlines() if line.startswith(("cpu family", "model\t")))
    found = {k.strip(): v.strip() for k, v in found.items()}
    return f" family {found['cpu family']} model {found['model']}" if {"cpu family", "model"} <= found.keys() else ""


def time_case(name: str, repeats: int) -> None:
    schema = {"hp-surrogate": HEAT_PUMP, "storage-100": ALL}.get(name, STORAGE)
    if not schema.exists():
        print(f"{name:20s} skipped: {schema} is absent")
        return
    runs, what = [], ""
    for _ in range(repeats):
        if name == "hp-surrogate":
            seconds, what = heat_pump_run()
        elif name == "storage-100":
            seconds, what = storage_100_run()
        else:
            seconds, what = storage_run(name.split("-", 1)[1])
        runs.append(seconds)
    print(f"{name:20s} {statistics.median(runs):7.2f} s median of {repeats} (min {min(runs):.2f}, max "
          f"{max(runs):.2f}); 408 steps; {what}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cases", default=",".join(DEFAULT_CASES), help=f"comma-separated, of {', '.join(CASES)}")
    args = parser.parse_args()
    print(f"CPU: {cpu_name()}{cpu_family()} ({os.cpu_count()} logical cores); load average before: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for name in args.cases.split(","):
        time_case(name, args.repeats)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
