"""How long a build takes to start its houses: ``districtgen build`` from process start to the houses' first
simulation (imports, Prefect's temporary API server, selection), this checkout against a git revision, side by
side.

    .venv/bin/python benchmarks/build_startup.py [--ref HEAD~1] [--repeats 3] [--config raw/district.toml]

Each repeat runs the revision (a temporary ``git worktree``) and then this checkout with this venv's Python and
an empty surrogate cache, reads the build's progress lines and stops the build (SIGTERM to its process group)
when the houses start. Prints one line per run (seconds since process start: server launched, server
answering, houses started; load average) and one JSON object with the medians and the CPU.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks.machine import cpu_name  # noqa: E402

#: progress line fragment -> mark
MARKS = {"start the temporary server: started": "server_launched",
         "start the temporary server: finished": "server_answering",
         "houses: simulate + train: started": "houses"}




def startup(checkout: Path, config: str, scratch: Path) -> dict[str, float]:
    """One build in ``checkout`` until its houses start: seconds since process start of each mark."""
    cache, out = scratch / "cache", scratch / "out"
    shutil.rmtree(cache, ignore_errors=True)
    shutil.rmtree(out, ignore_errors=True)
    env = {**os.environ, "PREFECT_SERVER_ANALYTICS_ENABLED": "false", "PREFECT_LOGGING_LEVEL": "WARNING"}
    started = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "pipeline.cli", "build", config, "-o", str(out),
                             "--cache-dir", str(cache)], cwd=checkout, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    marks: dict[str, float] = {}
    try:
        for line in proc.stdout:
            for fragment, mark in MARKS.items():
                if fragment in line:
                    marks[mark] = round(time.perf_counter() - started, 1)
            if "houses" in marks:
                break
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait()
    return marks


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", default="HEAD~1")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--config", default="raw/district.toml")
    args = parser.parse_args()
    runs: dict[str, list[dict[str, float]]] = {args.ref: [], "working tree": []}
    with tempfile.TemporaryDirectory(prefix="build_startup_") as tmp:
        tmp = Path(tmp)
        worktree = tmp / "ref"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "-q", "--detach", str(worktree), args.ref],
                       check=True)
        try:
            for _ in range(args.repeats):
                for label, checkout in ((args.ref, worktree), ("working tree", REPO)):
                    marks = startup(checkout, args.config, tmp)
                    runs[label].append(marks)
                    print(label, marks, "load", round(os.getloadavg()[0], 2), flush=True)
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(worktree)], check=False)
    print(json.dumps({"cpu": cpu_name(), "median_to_houses_s": {
        label: statistics.median(m["houses"] for m in marks if "houses" in m) for label, marks in runs.items()}}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
