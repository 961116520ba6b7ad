"""Time the build report of a built district: the validation (two policy runs, the oracle) once, then ``write_report`` repeated.

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("district", type=Path, help="a built district folder (schema.json, surrogates/)")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from pipeline.builder.install import recorded_selection
    from pipeline.builder.manifest import read_manifest
    from pipeline.builder.report import district_report, write_report
    from pipeline.builder.validate import validate_district

    print(f"load average before: {os.getloadavg()}")
    started = time.perf_counter()
    validation = validate_district(args.district / "schema.json")
    steps = validation.runs["no_control"].series["hour"].shape
    print(f"validation (policy runs, oracle): {time.perf_counter() - started:.1f} s wall, (buildings, steps) = "
          f"{steps}")
    schema = json.loads((args.district / "schema.json").read_text())
    selection = recorded_selection(args.district, read_manifest(args.district))
    inputs = district_report(args.district, args.district.name, schema, validation, selection)
    walls, cpus = [], []
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(args.repeats):
            wall, cpu = time.perf_counter(), time.process_time()
            write_report(Path(scratch), inputs)
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
