"""Builds on a Dask cluster started apart: the same N-house district on one and on two worker processes.

    .venv/bin/python benchmarks/dask_scale.py --houses 24 --start 2018-06-01 --end 2018-06-07 \\
        --workers 1 2 --json /tmp/dask_scale.json

The district is ``raw/district.toml`` with ``[selection] houses = N`` (24 of the 17 hot-humid single-family
rows: every row and 7 repeats, each with its own occupant schedules), the period ``--start..--end`` and
absolute input paths: real ResStock houses simulated in EnergyPlus on Austin 2018 and given LSTM surrogates,
as ``make run`` does. For every worker count W, a fresh ``dask scheduler`` and W ``dask worker --nthreads 1
--no-nanny`` processes are started on 127.0.0.1 (as on separate machines), then ``districtgen build CONFIG
--dask tcp://127.0.0.1:PORT --cache-dir EMPTY --quiet`` runs in its own process: a cold build (every house
simulated and trained), timed end to end (the Prefect API server's start included). ``--kill-after S``:
S seconds into each build of 2+ workers one worker is killed (SIGKILL, mid-task) and a replacement worker
started (the efficiency then counts the task run again); the
run then records ``killed_at_s`` and ``in_process_sha256``, the digest of an in-process build
(``--no-prefect``) of the same configuration from the cache the Dask build filled.

Output (``--json``)::

    {"houses": N, "start": ..., "end": ..., "cpu": ..., "load_average": [before, after],
     "runs": [{"workers": 1, "wall_s": ..., "cpu_s": {"driver": ..., "workers": ..., "scheduler": ...,
               "total": ...}, "driver_peak_rss_mb": ..., "steps_s": {...}, "artifacts_sha256": ...}, ...],
     "efficiency": {"2": T1 / (2 T2), ...}}

``cpu_s``: user + system seconds of each process with the children it waited for (EnergyPlus runs count to
their worker, the Prefect API server to the driver), from ``os.wait4``. ``driver_peak_rss_mb``: the build
process's own ``ru_maxrss`` as its ``timings.json`` records it. ``artifacts_sha256``:
:func:`pipeline.builder.manifest.district_digest`; every worker count must give the same digest (the output and
cache folders have the same paths in every run, emptied in between; the surrogates train in float32: ``auto``
measures bfloat16 against float32 in each build, and under load two builds may choose differently and give
other weights). Parallel efficiency needs a quiet
machine: two single-threaded workers on a 2-core machine shared with other work measure the load, not the
build.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from datetime import date
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.build_scale import dump_toml  # noqa: E402  (one TOML writer for both scale benchmarks)
from pipeline.builder.manifest import TIMINGS, district_digest  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "raw" / "district.toml"
DASK = Path(sys.executable).parent / "dask"
START_S = 300.0


def district(houses: int, start: date, end: date) -> dict:
    """``raw/district.toml`` asking for ``houses`` houses over ``start..end``, absolute paths, name ``dask<N>``."""
    config = tomllib.loads(RAW.read_text())
    config["name"] = f"dask{houses}"
    config["period"] = {"start": start, "end": end}
    config["inputs"] = {k: str((RAW.parent / v).resolve()) for k, v in config["inputs"].items()}
    config["selection"] = {**config["selection"], "houses": houses}
    config["selection"].pop("clusters", None)
    config["surrogate"] = {**config["surrogate"], "precision": "float32"}  # not measured per build (see above)
    return config


def cpu_seconds(usage) -> float:
    return usage.ru_utime + usage.ru_stime


def stop(process: subprocess.Popen) -> float:
    """SIGTERM (a worker or scheduler closes cleanly), SIGKILL after 30 s; its CPU seconds from ``wait4``."""
    if process.poll() is not None:  # already reaped by poll(): its usage is lost
        return float("nan")
    process.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + 30
    while True:
        pid, _, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            process.returncode = 0
            return cpu_seconds(usage)
        if time.monotonic() > deadline:
            process.kill()
        time.sleep(0.1)


def start_cluster(workers: int, scratch: Path, env: dict) -> tuple[str, subprocess.Popen, list[subprocess.Popen]]:
    """A scheduler and ``workers`` single-threaded workers on 127.0.0.1, all connected."""
    from distributed import Client

    file = scratch / "scheduler.json"
    file.unlink(missing_ok=True)
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env, "cwd": ROOT}
    scheduler = subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                  "--scheduler-file", str(file)], **quiet)
    deadline = time.monotonic() + START_S
    address = None
    while address is None:
        if time.monotonic() > deadline or scheduler.poll() is not None:
            raise SystemExit("the Dask scheduler did not start")
        time.sleep(0.1)
        try:
            address = json.loads(file.read_text())["address"]
        except (OSError, ValueError, KeyError):  # not written yet, or half written
            continue
    pool = [subprocess.Popen([str(DASK), "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                              "--name", f"w{i}"], **quiet) for i in range(workers)]
    with Client(address) as client:
        client.wait_for_workers(workers, timeout=START_S)
    return address, scheduler, pool


def kill_and_replace(pool: list[subprocess.Popen], address: str, env: dict, after_s: float,
                     done: threading.Event, record: dict) -> None:
    """``after_s`` seconds into the build (unless it is ``done``), SIGKILL the first worker (mid-task: the
    scheduler reruns its task elsewhere) and start a replacement worker process; ``record`` says when."""
    if done.wait(after_s):
        return
    victim = pool[0]
    victim.kill()
    _, _, usage = os.wait4(victim.pid, 0)
    victim.returncode = -9
    record["killed_at_s"], record["killed_worker_cpu_s"] = after_s, round(cpu_seconds(usage), 2)
    pool.append(subprocess.Popen([str(DASK), "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                  "--name", "w-replacement"], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL, env=env, cwd=ROOT))


def in_process_digest(toml: Path, scratch: Path, env: dict) -> str:
    """The district digest of ``districtgen build --no-prefect`` (in process) of ``toml`` from the cache the
    Dask build filled."""
    out = scratch / "in_process"
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "pipeline.cli", "build", str(toml), "-o", str(out), "--cache-dir",
                    str(scratch / "cache"), "--no-prefect", "--quiet"], cwd=ROOT, env=env, check=True)
    return district_digest(out / toml.stem)


def one_build(toml: Path, workers: int, scratch: Path, keep: Path | None = None,
              kill_after_s: float | None = None) -> dict:
    """One cold build of ``toml`` on a fresh cluster of ``workers`` worker processes; with ``kill_after_s``
    one worker is killed then and replaced, and the district is compared with an in-process build's."""
    out, cache = scratch / "out", scratch / "cache"
    shutil.rmtree(out, ignore_errors=True)
    shutil.rmtree(cache, ignore_errors=True)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_SERVER_ANALYTICS_ENABLED": "false",
           "PREFECT_LOGGING_LEVEL": "WARNING", "PREFECT_HOME": str(scratch / "prefect")}
    env.pop("PREFECT_API_URL", None)
    address, scheduler, pool = start_cluster(workers, scratch, env)
    killed: dict = {}
    done = threading.Event()
    try:
        if kill_after_s is not None:
            threading.Thread(target=kill_and_replace, args=(pool, address, env, kill_after_s, done, killed),
                             daemon=True).start()
        started = time.perf_counter()
        build = subprocess.Popen([sys.executable, "-m", "pipeline.cli", "build", str(toml), "-o", str(out),
                                  "--cache-dir", str(cache), "--dask", address, "--quiet"], cwd=ROOT, env=env,
                                 stderr=subprocess.PIPE, text=True)
        stderr = build.stderr.read()
        _, status, usage = os.wait4(build.pid, 0)
        build.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - started
    finally:
        done.set()
        worker_cpu = sum(stop(p) for p in pool if p.returncode is None) + killed.get("killed_worker_cpu_s", 0.0)
        scheduler_cpu = stop(scheduler)
    if build.returncode != 0:
        raise SystemExit(f"build with {workers} workers failed (exit {build.returncode}):\n{stderr[-3000:]}")
    folder = out / toml.stem
    timings = json.loads((folder / TIMINGS).read_text())
    if keep is not None:
        shutil.copytree(folder, keep / f"workers{workers}", dirs_exist_ok=True)
    driver = cpu_seconds(usage)
    if kill_after_s is not None:
        killed["in_process_sha256"] = in_process_digest(toml, scratch, env)
    return {"workers": workers, "wall_s": round(wall, 2), **killed,
            "cpu_s": {"driver": round(driver, 2), "workers": round(worker_cpu, 2), "scheduler": round(scheduler_cpu, 2),
                      "total": round(driver + worker_cpu + scheduler_cpu, 2)},
            "driver_peak_rss_mb": timings.get("build_process_peak_rss_mb"), "steps_s": timings["stages_s"],
            "artifacts_sha256": district_digest(folder)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--houses", type=int, default=24)
    parser.add_argument("--start", type=date.fromisoformat, default=date(2018, 6, 1))
    parser.add_argument("--end", type=date.fromisoformat, default=date(2018, 6, 7))
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--keep", type=Path, default=None, help="copy each run's district into this folder")
    parser.add_argument("--kill-after", type=float, default=None, metavar="S",
                        help="kill one worker S seconds into each build and start a replacement; then build "
                             "in process from the filled cache and compare the districts")
    args = parser.parse_args(argv)

    from surrogates.precision import capability

    with tempfile.TemporaryDirectory(prefix="dask_scale_") as scratch:
        scratch = Path(scratch)
        toml = scratch / f"dask{args.houses}.toml"
        toml.write_text(dump_toml(district(args.houses, args.start, args.end)))
        before = os.getloadavg()
        runs = []
        for workers in args.workers:
            runs.append(one_build(toml, workers, scratch, args.keep, args.kill_after if workers > 1 else None))
            print(json.dumps(runs[-1]), flush=True)
        after = os.getloadavg()
    base = next((r for r in runs if r["workers"] == 1), None)
    efficiency = {str(r["workers"]): round(base["wall_s"] / (r["workers"] * r["wall_s"]), 3)
                  for r in runs if base is not None and r["workers"] > 1}
    result = {"houses": args.houses, "start": args.start.isoformat(), "end": args.end.isoformat(),
              "cpu": capability().describe(), "load_average": [list(before), list(after)], "runs": runs,
              "efficiency": efficiency}
    digests = {r["artifacts_sha256"] for r in runs} | {r["in_process_sha256"] for r in runs if "in_process_sha256" in r}
    print(f"efficiency {efficiency}; the same district from every worker count: {len(digests) == 1}")
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=2))
    return 0 if len(digests) == 1 else 1


if __name__ == "__main__":
    sys.exit(main())
