"""Environment speed: env steps per second and peak memory, side by side with upstream CityLearn if given.

    .venv/bin/python benchmarks/env_speed.py [--repeats 5] [--upstream /path/to/python-with-citylearn]
        [--cases "paper 2 houses, month, LSTM"] [--schema artifacts/default/schema.json]
    .venv/bin/python benchmarks/env_speed.py --profile   # where one step of ours goes, paper case

Every case runs in its own subprocess (one thread: OMP/MKL/NUMBA threads = 1) so its peak RSS is its own;
the speed is the median over ``--repeats`` full episodes with random actions drawn up front. The paper case
is the district ``make run`` builds (``--schema``, default artifacts/default/schema.json: six ResStock houses
with LSTM surrogates, Austin, June 2018): its Building_1 and Building_2, central agent, every action the
houses have active, the 720 hours of June. The other cases use the shared CityLearn 2023 phase-3-1 dataset
(../shared/data); "no LSTM" cases turn its buildings into plain buildings (cooling = ideal load), "17
buildings" repeats its six buildings.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATASET = ROOT.parent / "shared" / "data" / "citylearn" / "citylearn_challenge_2023_phase_3_1-v2.1"
#: the district ``make run`` builds (the paper's houses)
PAPER_SCHEMA = ROOT / "artifacts" / "default" / "schema.json"
#: the paper case: these houses of the ``make run`` district, a month of hours
PAPER_CASE = "paper 2 houses, month, LSTM"
PAPER_HOUSES = ("Building_1", "Building_2")
PAPER_HOURS = 720
#: device key of a building -> the actions it makes possible (all of them active in the paper case)
DEVICE_ACTIONS = {"cooling_storage": ("cooling_storage",), "heating_storage": ("heating_storage",),
                  "dhw_storage": ("dhw_storage",), "electrical_storage": ("electrical_storage",),
                  "cooling_device": ("cooling_device",), "heating_device": ("heating_device",)}

CASES = {
    "3 bldg, month, no LSTM": dict(n=3, hours=720, lstm=False, actions=("dhw_storage", "electrical_storage")),
    "6 bldg, month, no LSTM": dict(n=6, hours=720, lstm=False, actions=("dhw_storage", "electrical_storage")),
    "3 bldg, month, LSTM + heat pump": dict(n=3, hours=720, lstm=True,
                                            actions=("dhw_storage", "electrical_storage", "cooling_device")),
    "6 bldg, month, LSTM + heat pump": dict(n=6, hours=720, lstm=True,
                                            actions=("dhw_storage", "electrical_storage", "cooling_device")),
    "17 bldg, 2208 h, battery + PV": dict(n=17, hours=2208, lstm=False, actions=("electrical_storage",)),
}


#: the building-file columns CityLearn 2.1 reads, by position (``EnergySimulation(*values.T)``)
CITYLEARN_2_1_COLUMNS = 16


def paper_schema(path: Path, folder: Path, houses=PAPER_HOUSES, hours: int = PAPER_HOURS) -> dict:
    """The ``make run`` district at ``path`` cut to ``houses`` over ``hours`` steps: central agent, every
    action their devices allow active, no power outages. Its files are rewritten into ``folder`` in CityLearn
    2.1's file layout (:func:`citylearn_env.convert.convert_dataset`: 2.1 reads building files by column
    position and wants one dynamics block per mode) without the cooling/heating set-point columns, which 2.1
    does not know; both sides read that copy."""
    from citylearn_env.convert import convert_dataset

    schema = json.loads(path.read_text())
    schema.update(root_directory=str(path.resolve().parent), simulation_start_time_step=0,
                  simulation_end_time_step=hours - 1, central_agent=True, episode_time_steps=None)
    buildings = {name: schema["buildings"][name] for name in houses}
    present = {action for spec in buildings.values() for key, acts in DEVICE_ACTIONS.items()
               if isinstance(spec.get(key), dict) for action in acts}
    known = {action for acts in DEVICE_ACTIONS.values() for action in acts}  # 2.1 passes every listed action on
    schema["actions"] = {name: dict(spec, active=name in present) for name, spec in schema["actions"].items()
                         if name in known}
    for spec in buildings.values():
        spec["inactive_actions"] = []
        spec["power_outage"] = {"simulate_power_outage": False, "stochastic_power_outage": False}
    schema["buildings"] = buildings
    cut = folder / "paper_cut.json"
    cut.write_text(json.dumps(schema))
    converted = convert_dataset(cut, folder / "paper_v2_1", to_layout="v2.1")
    schema = json.loads(converted.read_text())
    for spec in schema["buildings"].values():  # 2.1 takes at most 16 columns (later ones: its start/end step)
        data = converted.parent / spec["energy_simulation"]
        data.write_text("".join(",".join(line.split(",")[:CITYLEARN_2_1_COLUMNS]) + "\n"
                                for line in data.read_text().splitlines()))
    schema["root_directory"] = str(converted.parent)
    return schema


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
for k in range(repeats + 1):  # episode 0 warms up (numba's cached kernels load at the first step)
    env.reset(seed=0)
    t0 = time.perf_counter()
    for a in table:
        env.step(a)
    if k:
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
for k in range(repeats + 1):  # episode 0 warms up, as ours
    env.reset()
    t0 = time.perf_counter()
    for a in table:
        env.step([list(a)])
    if k:
        rates.append(len(table) / (time.perf_counter() - t0))
print(json.dumps({"steps_per_s": statistics.median(rates), "build_s": build,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


#: (owner module, class, method, label) of the sections ``--profile`` times, nested ones inside "step"
PROFILE_SECTIONS = (
    ("citylearn_env.env", "CityLearnEnv", "step", "step"),
    ("citylearn_env.env", "CityLearnEnv", "advance", "advance"),
    ("citylearn_env.district", "District", "act", "act"),
    ("citylearn_env.thermal", "ThermalModel", "demands", "lstm_demands"),
    ("citylearn_env.thermal", "ThermalModel", "update", "lstm_update"),
    ("citylearn_env.dynamics", "LSTMBank", "step_raw", "lstm_kernel"),
    ("citylearn_env.district", "District", "_end_use", "end_uses"),
    ("citylearn_env.district", "District", "_battery", "battery"),
    ("citylearn_env.env", "CityLearnEnv", "_refresh", "observations"),
    ("citylearn_env.env", "CityLearnEnv", "_observation", "observation_float32"),
    ("citylearn_env.rewards", "RewardFunction", "__call__", "reward"),
)


def profile(schema: dict, repeats: int) -> None:
    """Thread CPU time per step of each section of ours (wrapped methods; about 0.5 us of wrapping per call
    included), over ``repeats`` episodes after a warm-up one; prints us per step."""
    import importlib
    import time
    from collections import Counter

    import numpy as np

    spent: Counter = Counter()

    def timed(method, label):
        def wrapper(*args, **kwargs):
            start = time.thread_time_ns()
            try:
                return method(*args, **kwargs)
            finally:
                spent[label] += time.thread_time_ns() - start
        return wrapper

    for module, cls, name, label in PROFILE_SECTIONS:
        owner = getattr(importlib.import_module(module), cls)
        setattr(owner, name, timed(getattr(owner, name), label))
    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(schema, compat=True)
    env.reset(seed=0)
    table = np.random.default_rng(0).uniform(env.action_space.low, env.action_space.high,
                                             size=(env.episode_length - 1, env.action_space.shape[0]))
    for k in range(repeats + 1):
        if k == 1:
            spent.clear()
        env.reset(seed=0)
        for a in table:
            env.step(a)
    us = {k: v / (repeats * len(table)) / 1000 for k, v in spent.items()}
    lstm = us["lstm_demands"] + us["lstm_update"]
    rows = [("step", us["step"]), ("LSTM: demands + update", lstm), ("  of which the bank's kernel call", us["lstm_kernel"]),
            ("district physics outside the LSTM", us["act"] - lstm), ("  end uses (device + tank)", us["end_uses"]),
            ("  battery", us["battery"]), ("observations", us["observations"] + us["observation_float32"]),
            ("reward", us["reward"]), ("action checks + table", us["advance"] - us["act"] - us["observations"]),
            ("rest of step", us["step"] - us["advance"] - us["reward"] - us["observation_float32"])]
    for label, value in rows:
        print(f"{label:40s} {value:7.1f} us/step")


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
    parser.add_argument("--upstream-repeats", type=int, default=5)
    parser.add_argument("--cases", nargs="*", default=[PAPER_CASE, *CASES])
    parser.add_argument("--schema", type=Path, default=PAPER_SCHEMA,
                        help="the make-run district of the paper case (default: artifacts/default/schema.json)")
    parser.add_argument("--profile", action="store_true", help="only: where one step of ours goes (paper case)")
    args = parser.parse_args()
    if args.profile:
        with tempfile.TemporaryDirectory(prefix="env_speed_") as folder:
            profile(paper_schema(args.schema, Path(folder)), args.repeats)
        return
    if any(name in CASES for name in args.cases) and not DATASET.exists():
        sys.exit(f"needs the shared dataset at {DATASET}")
    if PAPER_CASE in args.cases and not args.schema.exists():
        sys.exit(f"needs the make-run district at {args.schema} (make run)")
    scratch = tempfile.TemporaryDirectory(prefix="env_speed_")
    print("| case | ours steps/s | ours peak RSS MB | upstream steps/s | upstream peak RSS MB | ratio |")
    print("|---|---|---|---|---|---|")
    for name in args.cases:
        schema = paper_schema(args.schema, Path(scratch.name)) if name == PAPER_CASE else make_schema(**CASES[name])
        ours = run(sys.executable, OURS, schema, args.repeats)
        up = run(args.upstream, UPSTREAM, schema, args.upstream_repeats) if args.upstream else {}
        ratio = (f"{ours['steps_per_s'] / up['steps_per_s']:.1f}x"
                 if "steps_per_s" in up and "steps_per_s" in ours else "-")
        print(f"| {name} | {_fmt(ours, 'steps_per_s')} | {_fmt(ours, 'peak_rss_mb')} | "
              f"{_fmt(up, 'steps_per_s')} | {_fmt(up, 'peak_rss_mb')} | {ratio} |", flush=True)
    scratch.cleanup()


def _fmt(result: dict, key: str) -> str:
    if key in result:
        return f"{result[key]:,.0f}"
    return result.get("error", "-")


if __name__ == "__main__":
    main()
