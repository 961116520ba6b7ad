"""The environment at city scale: peak memory, build + reset seconds and steps/s for N buildings (issue 48, 3).

    PYTHONPATH=$PWD .venv/bin/python benchmarks/env_scale.py [--sizes 100 1000] [--variants shared copies]
        [--steps 1000] [--repeats 3] [--run 100] [--refuse 10000] [--json OUT]

The N-building schema: citylearn_challenge_2022_phase_all's 17 buildings (battery + PV, one year, 8,760 steps)
repeated until N (``Building_1_c0`` ... ``Building_17_c58`` ...), written to a temporary folder with the
upstream files copied in once:

* ``shared``: every copy of a building names the same building CSV (17 files; weather, pricing and carbon
  intensity one file each), as upstream's own schema does;
* ``copies``: every building has its own copy of its building CSV (N files), as users' city data sets have
  one file per building. The copies are byte-identical, so the loader's interning of equal columns holds
  each distinct column once; the time is the real one (every file is read and validated).

Each (N, variant) runs in a fresh subprocess with one thread (OMP/MKL/OPENBLAS = 1) and the CityLearn 2.1
preset: build + reset seconds, wall and CPU (``load_schema`` + ``CityLearnEnv`` + ``reset``, imports excluded), then
``--repeats`` times ``--steps`` steps with random actions (``numpy.random.default_rng(0).uniform`` over the
action space, reset between repeats): the median steps/s, wall and CPU (``time.process_time``); and the child's
peak resident memory (``VmHWM`` of /proc/self/status, read by the child: interpreter, imports, data, state;
``ru_maxrss`` would start at the parent's, which a child is forked from).

``--run N``: ``districtgen run --schema <N shared> --policy random`` (a whole episode and the KPI table) in a
subprocess; its peak resident memory (the child's ``VmHWM``) beside the estimate the command checked
(:func:`citylearn_env.footprint.estimate_run_memory`). ``--refuse N``: the same command on N buildings; what it
printed and its exit status (it refuses when the estimate exceeds the memory available).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2" / "citylearn_challenge_2022_phase_all"
THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
VARIANTS = ("shared", "copies")
FILE_KEYS = ("energy_simulation", "weather", "pricing", "carbon_intensity")


def write_city(n: int, folder: Path, variant: str = "shared", source: Path = SOURCE) -> Path:
    """Write the ``n``-building schema of ``variant`` ("shared" or "copies", module docstring) into ``folder``
    (created) with the upstream data files it names; return the schema path."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}")
    folder.mkdir(parents=True, exist_ok=True)
    raw = json.loads((source / "schema.json").read_text())
    names = list(raw["buildings"])
    for spec in raw["buildings"].values():
        for key in FILE_KEYS:
            if spec.get(key) and not (folder / spec[key]).exists():
                shutil.copyfile(source / spec[key], folder / spec[key])
    buildings = {}
    for i in range(n):
        name = names[i % len(names)]
        spec = json.loads(json.dumps(raw["buildings"][name]))
        copy_name = f"{name}_c{i // len(names)}"
        if variant == "copies":
            own = f"{copy_name}.csv"
            shutil.copyfile(folder / spec["energy_simulation"], folder / own)
            spec["energy_simulation"] = own
        buildings[copy_name] = spec
    raw["buildings"] = buildings
    raw["root_directory"] = None
    path = folder / "schema.json"
    path.write_text(json.dumps(raw, indent=1))
    return path


# --------------------------------------------------------------------------- child side
def _child(schema: str, steps: int, repeats: int) -> dict:
    """Build, reset and step the environment of ``schema`` in this process; the measurements as a dict."""
    import numpy as np

    from citylearn_env import CityLearnEnv, load_schema
    from citylearn_env.footprint import peak_resident_memory

    start, cpu_start = time.perf_counter(), time.process_time()
    env = CityLearnEnv(load_schema(schema, settings="citylearn-2.1"), compat=True)
    env.reset(seed=0)
    build, build_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    rss_built = peak_resident_memory() / 2**20
    space = env.action_space
    actions = np.random.default_rng(0).uniform(space.low, space.high, size=(steps, space.shape[0]))
    wall, cpu = [], []
    for repeat in range(repeats):
        if repeat:
            env.reset(seed=0)
        t0, c0 = time.perf_counter(), time.process_time()
        for a in actions:
            env.step(a)
        wall.append(steps / (time.perf_counter() - t0))
        cpu.append(steps / (time.process_time() - c0))
    return {"buildings": len(env.building_names), "time_steps": env.district.length,
            "build_reset_s": round(build, 2), "build_reset_cpu_s": round(build_cpu, 2), "steps_per_s": round(statistics.median(wall)),
            "steps_per_cpu_s": round(statistics.median(cpu)), "steps": steps, "repeats": repeats,
            "peak_rss_mb_built": round(rss_built), "peak_rss_mb": round(peak_resident_memory() / 2**20)}


def _environment() -> dict[str, str]:
    return {**os.environ, **THREADS, "PYTHONPATH": str(ROOT)}


def measure(schema: Path, steps: int, repeats: int) -> dict:
    """One child process's measurements of ``schema``."""
    out = subprocess.run([sys.executable, __file__, "--child", str(schema), "--steps", str(steps),
                          "--repeats", str(repeats)], capture_output=True, text=True, env=_environment(),
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


#: runs ``districtgen run`` in the child process, then prints its own peak resident memory [bytes]
_RUN_AND_MEASURE = ("import sys\nfrom citylearn_env.footprint import peak_resident_memory\nfrom pipeline.cli import main\n"
                    "code = main(sys.argv[1:])\nprint('peak', peak_resident_memory())\nsys.exit(code)")


def run_command(schema: Path) -> dict:
    """``districtgen run --schema SCHEMA --policy random`` in a subprocess: exit status, the last line it wrote
    to stderr, seconds and the child's own peak resident memory [MB] (``VmHWM``, printed by the child)."""
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", _RUN_AND_MEASURE, "run", "--schema", str(schema), "--policy",
                          "random"], capture_output=True, text=True, env=_environment())
    lines = out.stderr.strip().splitlines()
    last = out.stdout.strip().splitlines()[-1:] if out.stdout.strip() else []
    peak = int(last[0].split()[1]) / 2**20 if last and last[0].startswith("peak ") else None
    return {"exit": out.returncode, "stderr": lines[-1] if lines else "", "stderr_lines": len(lines),
            "seconds": round(time.perf_counter() - start, 1), "peak_rss_mb": None if peak is None else round(peak)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[100, 1000])
    parser.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=VARIANTS)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--run", type=int, nargs="*", default=[], help="`districtgen run` on these sizes")
    parser.add_argument("--refuse", type=int, nargs="*", default=[], help="`districtgen run` expected to refuse")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args.child, args.steps, args.repeats)))
        return 0
    from citylearn_env.footprint import available_memory, estimate_run_memory

    results: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="env_scale_") as scratch:
        for n in args.sizes:
            for variant in args.variants:
                schema = write_city(n, Path(scratch) / f"{variant}_{n}", variant)
                row = {"variant": variant, **measure(schema, args.steps, args.repeats)}
                results.append(row)
                print(json.dumps(row), flush=True)
        for n, expect_refusal in [(n, False) for n in args.run] + [(n, True) for n in args.refuse]:
            schema = write_city(n, Path(scratch) / f"run_{n}", "shared")
            row = {"command": "districtgen run", "buildings": n, "refusal_expected": expect_refusal,
                   "estimate_mb": round(estimate_run_memory(schema) / 2**20),
                   "available_mb": round((available_memory() or 0) / 2**20), **run_command(schema)}
            results.append(row)
            print(json.dumps(row), flush=True)
    load = Path("/proc/loadavg").read_text().split()[:3] if Path("/proc/loadavg").exists() else []
    if args.json:
        args.json.write_text(json.dumps({"results": results, "loadavg": load}, indent=1))
    print("load average:", " ".join(load))
    return 0


if __name__ == "__main__":
    sys.exit(main())
