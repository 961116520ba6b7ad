"""Builds at scale: the same N-house district built on a local Dask cluster of 1 and of 2 worker processes.

    .venv/bin/python benchmarks/build_scale.py --houses 4 --start 2018-06-01 --end 2018-06-21 \\
        --workers 1 2 --json /tmp/build_scale.json [--repeats 1]

The N houses are the first N (by ``bldg_id``) occupied single-family hot-humid ResStock dwellings of
``raw/eulp/resstock_characteristics_100_dwellings.parquet`` (the rows ``raw/district.toml``'s selection
draws from), simulated in EnergyPlus on the Austin 2018 weather and each given an LSTM surrogate, exactly as
``make run`` does, but with the list of houses given (no k-means step). Each run is ``districtgen build
CONFIG --dask --workers W --quiet`` in a fresh process with an EMPTY cache (every house is simulated and
trained: the cold build a new user pays), timed end to end.

Output (``--json``)::

    {"houses": N, "start": ..., "end": ..., "load_average": [before, after],
     "runs": [{"workers": 1, "wall_s": ..., "cpu_s": ..., "peak_rss_mb": ..., "steps_s": {...},
               "artifacts_sha256": "..."}, ...],
     "efficiency": {"2": T1 / (2 T2), ...}}

``artifacts_sha256``: :func:`pipeline.builder.manifest.district_digest`, sha256 over the artifact hashes the manifest
records (every file except ``manifest.json`` and ``timings.json``; the digests recorded before 2026-11-24 hashed
the files directly and differ in value). The output folder and the cache folder have the same path in every run (emptied in between), as
``manifest.json`` records the configuration. ``cpu_s``: user + system CPU seconds of the build process and all its
children (Dask workers, EnergyPlus); ``peak_rss_mb``: the largest single process (``ru_maxrss`` of the
children).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from datetime import date
from pathlib import Path

from pipeline.builder.manifest import district_digest

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "raw" / "district.toml"
def house_ids(config: dict, n: int) -> list[int]:
    """The first ``n`` bldg_ids (ascending) of the stock rows that ``config``'s ``[selection]`` filters keep."""
    from pipeline.select import apply_filters, read_stock_metadata

    frame = read_stock_metadata(RAW.parent / config["inputs"]["characteristics"])
    kept = apply_filters(frame, config["selection"]["filters"])
    ids = sorted(int(i) for i in kept.index)
    if len(ids) < n:
        raise SystemExit(f"only {len(ids)} houses pass the filters of {RAW}")
    return ids[:n]


def scale_config(n: int, start: date, end: date) -> dict:
    """``raw/district.toml`` with the first ``n`` filtered houses listed (no selection), the period
    ``start..end``, absolute input paths and the name ``scale<n>``."""
    config = tomllib.loads(RAW.read_text())
    ids = house_ids(config, n)
    del config["selection"]
    config["name"] = f"scale{n}"
    config["period"] = {"start": start, "end": end}
    inputs = {k: str((RAW.parent / v).resolve()) for k, v in config["inputs"].items()}
    config["inputs"] = {**inputs, "buildings": ids}
    return config


def dump_toml(config: dict) -> str:
    """A TOML text of a two-level mapping of str/int/float/bool/date/list values (all this config has)."""
    def value(v: object) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float, date)):
            return v.isoformat() if isinstance(v, date) else repr(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json.dumps(k)} = {value(x)}" for k, x in v.items()) + " }"
        return json.dumps(str(v))

    top = [f"{k} = {value(v)}" for k, v in config.items() if not isinstance(v, dict)]
    sections = [f"\n[{k}]\n" + "\n".join(f"{kk} = {value(vv)}" for kk, vv in v.items())
                for k, v in config.items() if isinstance(v, dict)]
    return "\n".join(top) + "\n" + "\n".join(sections) + "\n"


def _children_usage() -> tuple[float, float]:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def _step_timings(folder: Path) -> dict:
    from pipeline.builder.manifest import TIMINGS

    return json.loads((folder / TIMINGS).read_text())


def one_build(toml: Path, workers: int, scratch: Path, keep: Path | None = None) -> dict:
    """One cold build (empty cache) of ``toml`` on a fresh local Dask cluster of ``workers`` processes, in a
    child process; wall, CPU and peak RSS of the whole build."""
    out, cache = scratch / "out", scratch / "cache"
    shutil.rmtree(out, ignore_errors=True)
    shutil.rmtree(cache, ignore_errors=True)
    command = [sys.executable, "-m", "pipeline.cli", "build", str(toml), "-o", str(out), "--cache-dir", str(cache),
               "--dask", "--workers", str(workers), "--quiet"]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_SERVER_ANALYTICS_ENABLED": "false",
           "PREFECT_LOGGING_LEVEL": "WARNING", "PREFECT_HOME": str(scratch / "prefect")}
    cpu_before, _ = _children_usage()
    started = time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - started
    cpu_after, rss = _children_usage()
    if done.returncode != 0:
        raise SystemExit(f"build with {workers} workers failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    folder = out / toml.stem  # the district's name (scale<N>)
    if keep is not None:  # for a look at the files when two digests differ
        shutil.copytree(folder, keep / f"workers-{workers}-{time.strftime('%H%M%S')}")
    return {"workers": workers, "wall_s": round(wall, 2), "cpu_s": round(cpu_after - cpu_before, 2),
            "peak_rss_mb": round(rss, 1), "steps_s": _step_timings(folder),
            "artifacts_sha256": district_digest(folder)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--houses", type=int, default=4)
    parser.add_argument("--start", type=date.fromisoformat, default=date(2018, 6, 1))
    parser.add_argument("--end", type=date.fromisoformat, default=date(2018, 6, 21))
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeats", type=int, default=1, help="builds per worker count (median wall reported)")
    parser.add_argument("--json", type=Path, required=True)
    parser.add_argument("--keep", type=Path, help="copy each built district into this folder")
    args = parser.parse_args(argv)

    load_before = os.getloadavg()
    runs = []
    with tempfile.TemporaryDirectory(prefix="districtgen_scale_") as scratch:
        toml = Path(scratch) / f"scale{args.houses}.toml"
        toml.write_text(dump_toml(scale_config(args.houses, args.start, args.end)))
        for repeat in range(args.repeats):
            for workers in args.workers:  # side by side: 1, 2, 1, 2, ...
                run = one_build(toml, workers, Path(scratch), args.keep)
                run["repeat"] = repeat
                runs.append(run)
                print(json.dumps(run), flush=True)
    by_workers = {w: statistics.median(r["wall_s"] for r in runs if r["workers"] == w) for w in args.workers}
    base = by_workers[min(args.workers)] * min(args.workers)
    result = {"houses": args.houses, "start": args.start.isoformat(), "end": args.end.isoformat(),
              "load_average": [list(load_before), list(os.getloadavg())], "runs": runs,
              "median_wall_s": {str(w): t for w, t in by_workers.items()},
              "efficiency": {str(w): round(base / (w * t), 3) for w, t in by_workers.items()},
              "identical_artifacts": len({r["artifacts_sha256"] for r in runs}) == 1}
    args.json.write_text(json.dumps(result, indent=2))
    print(json.dumps({k: result[k] for k in ("median_wall_s", "efficiency", "identical_artifacts",
                                             "load_average")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
