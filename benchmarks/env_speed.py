"""Environment speed: env steps per second and peak memory, side by side with upstream CityLearn if given.

    .venv/bin/python benchmarks/env_speed.py [--repeats 5] [--upstream /path/to/python-with-citylearn]

Every case runs in its own subprocess (one thread: OMP/MKL/NUMBA threads = 1) so its peak RSS is its own;
the speed is the median over ``--repeats`` full episodes with random actions drawn up front. The district
is the shared CityLearn 2023 phase-3-1 dataset (../shared/data); "no LSTM" cases turn its buildings into
plain buildings (cooling = ideal load), "17 buildings" repeats its six buildings.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATASET = ROOT.parent / "shared" / "data" / "citylearn" / "citylearn_challenge_2023_phase_3_1-v2.1"

CASES = {
    "3 bldg, month, no LSTM": dict(n=3, hours=720, lstm=False, actions=("dhw_storage", "electrical_storage")),
    "6 bldg, month, no LSTM": dict(n=6, hours=720, lstm=False, actions=("dhw_storage", "electrical_storage")),
    "3 bldg, month, LSTM + heat pump": dict(n=3, hours=720, lstm=True,
                                            actions=("dhw_storage", "electrical_storage", "cooling_device")),
    "6 bldg, month, LSTM + heat pump": dict(n=6, hours=720, lstm=True,
                                            actions=("dhw_storage", "electrical_storage", "cooling_device")),
    "17 bldg, 2208 h, battery + PV": dict(n=17, hours=2208, lstm=False, actions=("electrical_storage",)),
}


def make_schema(n: int, hours: int, lstm: bool, actions) -> dict:
    schema = json.loads((DATASET / "schema.json").read_text())
    schema.update(root_directory=str(DATASET), simulation_start_time_step=0, simulation_end_time_step=hours - 1,
                  central_agent=True)
    for name, spec in schema["actions"].items():
        spec["active"] = name in actions
    source = list(schema["buildings"].items())
    buildings = {}
    for i in range(n):
        name, spec = source[i % len(source)]
        spec = json.loads(json.dumps(spec))
        spec["power_outage"]["simulate_power_outage"] = False
        if not lstm:
            spec["type"] = "citylearn.building.Building"
            spec.pop("dynamics", None)
        buildings[f"{name}_{i}" if n > len(source) else name] = spec
    schema["buildings"] = buildings
    return schema


OURS = r"""
import json, resource, statistics, sys, time
import numpy as np
from citylearn_env import CityLearnEnv
schema, repeats = json.loads(sys.argv[1]), int(sys.argv[2])
t0 = time.perf_counter(); env = CityLearnEnv(schema, compat=True); build = time.perf_counter() - t0
rng = np.random.default_rng(0)
env.reset(seed=0)
table = rng.uniform(env.action_space.low, env.action_space.high, size=(env.episode_length - 1, env.action_space.shape[0]))
rates = []
for _ in range(repeats):
    env.reset(seed=0)
    t0 = time.perf_counter()
    for a in table:
        env.step(a)
    rates.append(len(table) / (time.perf_counter() - t0))
print(json.dumps({"steps_per_s": statistics.median(rates), "build_s": build,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""

UPSTREAM = r"""
import json, resource, statistics, sys, time
import numpy as np
from citylearn.citylearn import CityLearnEnv
schema, repeats = json.loads(sys.argv[1]), int(sys.argv[2])
t0 = time.perf_counter(); env = CityLearnEnv(schema); build = time.perf_counter() - t0
space = env.action_space[0]
rng = np.random.default_rng(0)
n = schema["simulation_end_time_step"] - schema["simulation_start_time_step"]
table = rng.uniform(space.low, space.high, size=(n, space.shape[0]))
rates = []
for _ in range(repeats):
    env.reset()
    t0 = time.perf_counter()
    for a in table:
        env.step([list(a)])
    rates.append(len(table) / (time.perf_counter() - t0))
print(json.dumps({"steps_per_s": statistics.median(rates), "build_s": build,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def run(python: str, code: str, schema: dict, repeats: int) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", NUMBA_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    out = subprocess.run([python, "-c", code, json.dumps(schema), str(repeats)], capture_output=True, text=True,
                         env=env, cwd=ROOT)
    if out.returncode:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--upstream", help="a Python interpreter that has upstream citylearn installed")
    parser.add_argument("--upstream-repeats", type=int, default=1)
    parser.add_argument("--cases", nargs="*", default=list(CASES))
    args = parser.parse_args()
    if not DATASET.exists():
        sys.exit(f"needs the shared dataset at {DATASET}")
    print("| case | ours steps/s | ours peak RSS MB | upstream steps/s | upstream peak RSS MB | ratio |")
    print("|---|---|---|---|---|---|")
    for name in args.cases:
        schema = make_schema(**CASES[name])
        ours = run(sys.executable, OURS, schema, args.repeats)
        up = run(args.upstream, UPSTREAM, schema, args.upstream_repeats) if args.upstream else {}
        ratio = (f"{ours['steps_per_s'] / up['steps_per_s']:.1f}x"
                 if "steps_per_s" in up and "steps_per_s" in ours else "-")
        print(f"| {name} | {_fmt(ours, 'steps_per_s')} | {_fmt(ours, 'peak_rss_mb')} | "
              f"{_fmt(up, 'steps_per_s')} | {_fmt(up, 'peak_rss_mb')} | {ratio} |", flush=True)


def _fmt(result: dict, key: str) -> str:
    if key in result:
        return f"{result[key]:,.0f}"
    return result.get("error", "-")


if __name__ == "__main__":
    main()
