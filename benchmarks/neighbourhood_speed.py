"""Speed of a 100-house LSTM neighbourhood, one full episode: our env (2.5 preset; numba and numpy LSTM paths)
against CityLearn 2.5.0, side by side in one run.

    .venv/bin/python benchmarks/neighbourhood_speed.py --upstream-python /tmp/cl250/bin/python \
        [--buildings 100] [--repeats 3] [--upstream-repeats 1] [--policy zero|random] [--steps N] [--json OUT]

The neighbourhood: upstream's v2.4.2 ``citylearn_challenge_2023_phase_3_1`` (six ResStock single-family houses
in Austin TX, LSTM indoor-temperature dynamics, one ``dynamics`` model each; read in place from
../shared/data/citylearn/upstream/v2.4.2) repeated to ``--buildings`` houses (renamed copies ``Building_1_c0``
...; copies share the source house's data files and LSTM weights). Ours builds it through the typed config
(``load_schema(..., settings="citylearn-2.5")`` then ``config.replace(buildings=...)``); upstream gets the same
repeated buildings as a schema dict whose ``root_directory`` is the dataset folder, from a small driver script
this benchmark writes to a temporary folder and runs with ``--upstream-python``.

Each episode runs in a fresh subprocess with one thread (OMP/MKL/OPENBLAS/NUMBA = 1; upstream: torch 1 thread):
``ours-numba`` (numba installed and used), ``ours-numpy`` (numba blocked at import: the plain install's path) and
``upstream``. Ours repeats ``--repeats`` times, upstream ``--upstream-repeats`` times; the sides alternate per
repeat. Actions: ``zero`` (every action 0) or ``random`` (``numpy.random.default_rng(0).uniform(low, high)``, one
row per step, the same table on every side). Timed: the ``step`` calls of the episode after ``reset`` but the
first (timed apart: it loads numba's cached kernels); reported are the median steps/s (wall and CPU) with min and
max, the build + reset seconds, the CPU model (``lscpu``) and the load average before and after.
``--steps`` / ``--upstream-steps`` cap the step calls (upstream needs about a second per step at 100 houses on
a loaded machine: ``--upstream-steps 300`` keeps a side-by-side run short; the rate is then of the first calls).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2023_phase_3_1"
THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
SIDES = ("ours-numba", "ours-numpy", "upstream")

#: shared by both drivers: the repeated-building names and the timed episode (no project code: upstream runs it)
COMMON = r'''
import json, sys, time
import numpy as np


def repeated_names(names, n):
    """(source building, copy name) for n copies cycling through names: Building_1_c0, ..."""
    return [(names[i % len(names)], f"{names[i % len(names)]}_c{i // len(names)}") for i in range(n)]


def timed_episode(step, low, high, policy, max_steps, t_build):
    """Run the episode (at most max_steps calls) with the policy's action table; its timing as a dict."""
    n = len(low)
    rows = min(max_steps, 100_000)
    table = (np.zeros((rows, n)) if policy == "zero"
             else np.random.default_rng(0).uniform(low, high, size=(rows, n)))
    t0 = time.perf_counter()
    done = step(table[0])  # apart: it loads (or compiles) numba kernels
    first = time.perf_counter() - t0
    calls = 1
    t0, c0 = time.perf_counter(), time.process_time()
    while not done and calls < max_steps:
        done = step(table[calls])
        calls += 1
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"steps": calls, "wall_s": wall, "cpu_s": cpu, "steps_per_s": (calls - 1) / wall,
            "steps_per_cpu_s": (calls - 1) / cpu, "first_step_s": first, "build_s": t_build, "actions": n,
            "numba_loaded": "numba" in sys.modules}
'''

UPSTREAM_DRIVER = COMMON + r'''
job = json.load(open(sys.argv[1]))
import torch
torch.set_num_threads(1)
from citylearn.citylearn import CityLearnEnv

t0 = time.perf_counter()
schema = json.load(open(job["schema"]))
schema["root_directory"] = job["root"]
schema["central_agent"] = True
copies = repeated_names(list(schema["buildings"]), job["buildings"])
schema["buildings"] = {new: json.loads(json.dumps(schema["buildings"][src])) for src, new in copies}
env = CityLearnEnv(schema, central_agent=True)
env.reset()
space = env.action_space[0]
result = timed_episode(lambda a: env.step([a.tolist()])[2], space.low, space.high, job["policy"],
                       job["max_steps"], time.perf_counter() - t0)
result.update(buildings=len(env.buildings), citylearn=__import__("citylearn").__version__)
json.dump(result, open(sys.argv[2], "w"))
'''

OURS_DRIVER = COMMON + r'''
job = json.load(open(sys.argv[1]))
if job["block_numba"]:  # the plain install: numba cannot be imported
    import importlib.abc

    class _NoNumba(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] == "numba":
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)

    sys.meta_path.insert(0, _NoNumba())
import dataclasses
from citylearn_env import CityLearnEnv, load_schema

t0 = time.perf_counter()
config = load_schema(job["schema"], settings="citylearn-2.5")
by_name = {b.name: b for b in config.buildings}
copies = repeated_names(list(by_name), job["buildings"])
config = config.replace(buildings=tuple(dataclasses.replace(by_name[src], name=new) for src, new in copies))
env = CityLearnEnv(config, settings="citylearn-2.5", central_agent=True)
env.reset(seed=0)
space = env.action_space
result = timed_episode(lambda a: env.step(a)[2], space.low, space.high, job["policy"], job["max_steps"],
                       time.perf_counter() - t0)
result.update(buildings=len(config.buildings))
json.dump(result, open(sys.argv[2], "w"))
'''


def cpu_model() -> str:
    """The ``Model name`` line of ``lscpu`` (empty when lscpu is missing)."""
    try:
        text = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    except OSError:
        return ""
    return next((line.split(":", 1)[1].strip() for line in text.splitlines() if line.startswith("Model name")), "")


def load_average() -> tuple[float, float, float]:
    """The 1, 5 and 15 minute load averages (runnable processes)."""
    return os.getloadavg()


def run_side(side: str, python: str, args: argparse.Namespace, scratch: Path, k: int) -> dict:
    """One episode of ``side`` in a fresh subprocess; its timing record."""
    driver = scratch / ("upstream_driver.py" if side == "upstream" else "ours_driver.py")
    job, out = scratch / f"{side}.{k}.job.json", scratch / f"{side}.{k}.out.json"
    job.write_text(json.dumps({"schema": str(SOURCE / "schema.json"), "root": str(SOURCE),
                               "buildings": args.buildings, "policy": args.policy,
                               "max_steps": args.upstream_steps if side == "upstream" else args.steps,
                               "block_numba": side == "ours-numpy"}))
    env = {**os.environ, **THREADS}
    if side == "upstream":
        env = {**THREADS, "PATH": "/usr/bin:/bin", "HOME": str(Path.home())}
    else:
        env["PYTHONPATH"] = str(ROOT)
    done = subprocess.run([python, str(driver), str(job), str(out)], capture_output=True, text=True, env=env,
                          cwd=scratch)
    if done.returncode != 0:
        raise RuntimeError(f"{side} failed: {done.stderr.strip()[-3000:]}")
    record = json.loads(out.read_text())
    if record["numba_loaded"] != (side == "ours-numba"):
        raise RuntimeError(f"{side}: numba loaded = {record['numba_loaded']}")
    return record


def summary(records: list[dict]) -> dict:
    """Median (min, max) steps/s over the repeats of one side, with the steps and build seconds."""
    rates = [r["steps_per_s"] for r in records]
    return {"repeats": len(records), "steps": records[0]["steps"], "buildings": records[0]["buildings"],
            "steps_per_s": statistics.median(rates), "min": min(rates), "max": max(rates),
            "steps_per_cpu_s": statistics.median(r["steps_per_cpu_s"] for r in records),
            "build_s": statistics.median(r["build_s"] for r in records)}


def print_table(result: dict) -> None:
    """The result as aligned text rows."""
    print(f"CPU: {result['cpu']}; load average before {result['load_before']}, after {result['load_after']}")
    print(f"{result['buildings']} houses, policy {result['policy']}, one thread per side")
    print(f"{'side':<12} {'repeats':>7} {'steps':>6} {'steps/s (min-max)':>24} {'steps/CPU s':>11} {'build s':>8}")
    for side, s in result["sides"].items():
        span = f"{s['steps_per_s']:.1f} ({s['min']:.1f}-{s['max']:.1f})"
        print(f"{side:<12} {s['repeats']:>7} {s['steps']:>6} {span:>24} {s['steps_per_cpu_s']:>11.1f} "
              f"{s['build_s']:>8.1f}")


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream-python", help="an interpreter with citylearn 2.5.0 (omit: ours only)")
    parser.add_argument("--buildings", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3, help="episodes per side of ours")
    parser.add_argument("--upstream-repeats", type=int, default=1)
    parser.add_argument("--policy", choices=("zero", "random"), default="zero")
    parser.add_argument("--steps", type=int, default=10**9, help="cap on step calls (default: whole episode)")
    parser.add_argument("--upstream-steps", type=int, default=10**9,
                        help="cap on upstream's step calls (it needs about a second per step at 100 houses)")
    parser.add_argument("--sides", nargs="+", choices=SIDES, default=list(SIDES))
    parser.add_argument("--json", type=Path, help="also write the result here")
    return parser.parse_args(argv)


def main(argv: list[str]) -> None:
    args = parse(argv)
    sides = [s for s in args.sides if s != "upstream" or args.upstream_python]
    result = {"cpu": cpu_model(), "load_before": load_average(), "buildings": args.buildings,
              "policy": args.policy, "source": str(SOURCE.relative_to(ROOT.parent))}
    records: dict[str, list[dict]] = {side: [] for side in sides}
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        (scratch / "upstream_driver.py").write_text(UPSTREAM_DRIVER)
        (scratch / "ours_driver.py").write_text(OURS_DRIVER)
        for k in range(max(args.repeats, args.upstream_repeats)):
            for side in sides:
                if k < (args.upstream_repeats if side == "upstream" else args.repeats):
                    python = args.upstream_python if side == "upstream" else sys.executable
                    records[side].append(run_side(side, python, args, scratch, k))
                    print(f"  {side} #{k + 1}: {records[side][-1]['steps_per_s']:.1f} steps/s", flush=True)
    result["load_after"] = load_average()
    result["sides"] = {side: summary(recs) for side, recs in records.items()}
    result["time_utc"] = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    print_table(result)
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
