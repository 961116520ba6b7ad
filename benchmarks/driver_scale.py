"""The build's driver at city scale: 1,000 houses x a year, with a documented stand-in for the per-house work.

    .venv/bin/python benchmarks/driver_scale.py --houses 1000 --workers 2 --json /tmp/driver_scale.json \\
        [--cache-dir DIR] [--keep DIR]

What is real: the whole build (:func:`pipeline.builder.driver.run_build`) of ``raw/district.toml`` with
``[selection] houses = N`` over 2018 (8,760 hours): selection, the site's signals, every building table
written, every house sized, surrogate files written, the schema, the validation of the N-building district (no
control and the cost RBC over the year, in chunks of 64 buildings on the runner), the report and the manifest.

The stand-in: the per-house work (an EnergyPlus pass and a surrogate's training, 40-60 CPU s per house on
these machines) is replaced, on the runner's workers, by ONE real house: the first house of the default
district's selection, simulated for June 2018 and its surrogate trained through the build's own cache
(``--cache-dir``; cold: about a minute). Each of the N houses gets that house's hourly loads tiled over 2018
(June's 720 hours repeated; energies scaled by a factor drawn per house in 0.7-1.3, seeded by its name) and
that house's surrogate files under its own name. The driver cannot tell: it receives the same result type at
the same size as from a real house-year.

Measured in a fresh process: wall seconds, the driver process's own CPU seconds (``os.times`` of itself: the
part that does not run in parallel) and peak RSS (``ru_maxrss`` of itself), the workers' CPU seconds, and the
stage seconds of ``timings.json``. Output (``--json``): those numbers with the CPU and the load average.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import os
import pickle
import resource
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "raw" / "district.toml"
sys.path.insert(0, str(ROOT / "benchmarks"))

from machine import cpu_name  # noqa: E402

from pipeline.runners import keep_all  # noqa: E402

#: load columns that are energies [kWh] (scaled per house); the others (set points, temperatures) are kept
ENERGIES = ("non_shiftable_load_kwh", "cooling_demand_kwh", "heating_demand_kwh", "dhw_demand_kwh")


def write_config(folder: Path, houses: int, start: str, end: str, cache_dir: Path) -> Path:
    """``raw/district.toml`` with absolute input paths, ``houses``, the period and the cache folder."""
    text = RAW.read_text()
    raw = tomllib.loads(text)
    for value in raw["inputs"].values():
        text = text.replace(f'"{value}"', f'"{(RAW.parent / value).resolve()}"') if isinstance(value, str) else text
    text = text.replace(f'name = "{raw["name"]}"', f'name = "city{houses}"\ncache_dir = "{cache_dir}"')
    text = text.replace(f"start = {raw['period']['start']}", f"start = {start}")
    text = text.replace(f"end = {raw['period']['end']}", f"end = {end}")
    text = text.replace(f"clusters = {raw['selection']['clusters']}", f"houses = {houses}")
    text = text.replace('method = "medoid"\n', "")
    path = folder / f"city{houses}.toml"
    path.write_text(text)
    return path


def template_house(cache_dir: Path, out: Path) -> Path:
    """Simulate and train the default district's first house for June 2018 (through the cache) and pickle
    its :class:`pipeline.builder.houses.HouseWork` into ``out``."""
    from pipeline.builder.driver import resolve_selection
    from pipeline.builder.houses import house_work
    from pipeline.builder.surrogates import resolve_precision
    from pipeline.config import read_build_config

    config = read_build_config(RAW)
    config = config.model_copy(update={"cache_dir": cache_dir})
    config, _ = resolve_selection(config)
    config, _ = resolve_precision(config)
    work = house_work(config, config.inputs.buildings[0], "Building_1")
    out.write_bytes(pickle.dumps(work))
    return out


def standin_house(template: str, config, bldg_id: int, name: str):
    """The stand-in for :func:`pipeline.builder.houses.house_work` (see the module docstring)."""
    work = pickle.loads(Path(template).read_bytes())
    loads = work.simulation.loads
    index = pd.date_range(f"{config.period.start.year}-01-01", periods=8760, freq="h", name=loads.index.name)
    tiled = pd.DataFrame(np.resize(loads.to_numpy(), (index.size, loads.shape[1])), index=index,
                         columns=loads.columns)
    seed = int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "little")
    scale = np.random.default_rng(seed).uniform(0.7, 1.3)
    tiled[list(ENERGIES)] *= scale
    summary = {**work.simulation.summary, "bldg_id": int(bldg_id)}
    files = {key.replace("Building_1", name): data for key, data in work.surrogate.files.items()}
    return replace(work, simulation=replace(work.simulation, loads=tiled, summary=summary),
                   surrogate=replace(work.surrogate, files=files))


class StandInRunner:
    """A runner that gives the ``house`` step's tasks (:func:`pipeline.builder.driver.house_task`)
    :func:`standin_house` as their house work, and runs everything on ``inner``."""

    def __init__(self, inner, template: Path):
        self.inner, self.template = inner, str(template)

    def map(self, step, fn, calls, keep=keep_all):
        if step == "house":
            work = functools.partial(standin_house, self.template)
            calls = {label: (*args, work) for label, args in calls.items()}
        return self.inner.map(step, fn, calls, keep)


def build(config_path: Path, template: Path, workers: int, output: Path) -> dict:
    """One build with the stand-in (in this process: call it in a fresh one)."""
    from pipeline.builder.driver import run_build
    from pipeline.config import read_build_config
    from pipeline.runners import InProcessRunner, ProcessRunner

    inner = ProcessRunner(workers) if workers > 1 else InProcessRunner()
    start, times = time.perf_counter(), os.times()
    folder = run_build(read_build_config(config_path), output, StandInRunner(inner, template))
    wall, end = time.perf_counter() - start, os.times()
    stages = json.loads((folder / "timings.json").read_text())["stages_s"]
    size = sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
    return {"wall_s": round(wall, 1), "driver_cpu_s": round(end.user + end.system - times.user - times.system, 1),
            "workers_cpu_s": round(end.children_user + end.children_system - times.children_user
                                   - times.children_system, 1),
            "driver_peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
            "stages_s": stages, "district_mb": round(size / 2**20, 1),
            "buildings": len(json.loads((folder / "schema.json").read_text())["buildings"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--houses", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--start", default="2018-01-01")
    parser.add_argument("--end", default="2018-12-31")
    parser.add_argument("--cache-dir", type=Path, default=Path.home() / ".cache" / "districtgen")
    parser.add_argument("--json", type=Path, required=True)
    parser.add_argument("--keep", type=Path, help="build into this folder (default: a temporary one)")
    parser.add_argument("--child", nargs=4, help=argparse.SUPPRESS)  # config template workers output
    args = parser.parse_args()
    if args.child:
        config, template, workers, output = args.child
        print(json.dumps(build(Path(config), Path(template), int(workers), Path(output))))
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        template = template_house(args.cache_dir, tmp / "template.pickle")
        config = write_config(tmp, args.houses, args.start, args.end, args.cache_dir)
        output = args.keep or tmp / "out"
        load_before = os.getloadavg()
        child = subprocess.run([sys.executable, __file__, "--json", str(args.json), "--child", str(config),
                                str(template), str(args.workers), str(output)], capture_output=True, text=True,
                               env={**os.environ, "PYTHONPATH": str(ROOT)})
        if child.returncode:
            raise SystemExit(child.stderr[-3000:])
        result = {"houses": args.houses, "period": [args.start, args.end], "workers": args.workers,
                  "cpu": cpu_name(), "load_average": [load_before[0], os.getloadavg()[0]],
                  **json.loads(child.stdout.strip().splitlines()[-1])}
    args.json.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
