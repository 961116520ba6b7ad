"""Time the build report of a built district: the two policy runs once, then ``write_report`` repeated.

    .venv/bin/python benchmarks/build_report.py artifacts/default --repeats 5

Prints the load average, the policy-run seconds and the median (min-max) wall and CPU seconds of
``pipeline.builder.report.write_report`` (tables + every figure) into a scratch folder, and the PNG count and bytes.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("district", type=Path, help="a built district folder (schema.json, surrogates/)")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from citylearn_env import load_schema
    from pipeline.builder.report import report_series, write_report
    from pipeline.controllers import run_policy

    print(f"load average before: {os.getloadavg()}")
    started = time.perf_counter()
    district = load_schema(args.district / "schema.json")
    results = {}
    for policy in ("no_control", "cost_rbc"):
        env = run_policy(district, policy)
        results[policy] = {"objectives": {k: v for k, v in env.objectives().items() if np.isscalar(v)},
                           "kpis": env.evaluate(), "series": report_series(env)}
    steps = results["no_control"]["series"]["hour"].shape
    print(f"policy runs: {time.perf_counter() - started:.1f} s wall, (buildings, steps) = {steps}")
    schema = json.loads((args.district / "schema.json").read_text())
    walls, cpus = [], []
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(args.repeats):
            wall, cpu = time.perf_counter(), time.process_time()
            write_report(Path(scratch), args.district.name, schema, results, args.district / "surrogates")
            walls.append(time.perf_counter() - wall)
            cpus.append(time.process_time() - cpu)
        pngs = sorted(Path(scratch).glob("*.png"))
        size = sum(p.stat().st_size for p in pngs)
    print(f"write_report over {args.repeats} repeats: wall median {statistics.median(walls):.2f} s "
          f"({min(walls):.2f}-{max(walls):.2f}), CPU median {statistics.median(cpus):.2f} s "
          f"({min(cpus):.2f}-{max(cpus):.2f}); {len(pngs)} PNGs, {size / 1e6:.2f} MB")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
