"""Measure the setup step of ``make run`` / ``make test``: a fresh venv with the Makefile's three pip installs
(pip itself, torch 2.13.0, the project with some extras), with and without byte-compiling the installed files.

    python benchmarks/venv_setup.py [--repeats 1] [--extras all [--extras pipeline,energyplus]]
                                    [--modes compile,compileall,no-compile] [--venv /tmp/venv_setup]

Per repeat and variant (extras x mode, alternating, so all see the same machine): wall seconds from
``python3 -m venv`` to the last install, and the venv's size [MiB]. Prints one JSON object (CPU, load average
before and after, medians). Modes: ``compile``, pip byte-compiles as it installs (serially); ``compileall``,
``pip install --no-compile`` then ``python -m compileall -j 0`` on every core (the Makefile); ``no-compile``,
nothing compiled -- Python then compiles a module when it is imported and keeps the result only where
``PYTHONDONTWRITEBYTECODE`` is unset (else every process compiles its imports again).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks.machine import cpu_name  # noqa: E402

#: mode -> (pip's flags, compile the venv on every core after the install): pip's own serial byte-compiling;
#: none; none at install, then the standard library's compileall (the Makefile's)
MODES: dict[str, tuple[list[str], bool]] = {"compile": ([], False), "no-compile": (["--no-compile"], False),
                                            "compileall": (["--no-compile"], True)}


def setup_venv(venv: Path, extras: str, mode: str) -> float:
    """Create ``venv`` afresh and install as the Makefile does; returns the wall seconds."""
    shutil.rmtree(venv, ignore_errors=True)
    python = str(venv / "bin" / "python")
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    flags, compile_after = MODES[mode]
    for args in (["--upgrade", "pip"], ["torch==2.13.0"], ["-e", f"{REPO}[{extras}]"]):
        subprocess.run([python, "-m", "pip", "install", "-q", *flags, *args], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if compile_after:  # as the Makefile: some packages ship files that do not compile (pip skips them too)
        subprocess.run([python, "-m", "compileall", "-q", "-j", "0", str(venv / "lib")],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def venv_mib(venv: Path) -> float:
    return sum(p.stat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink()) / 2**20


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--extras", action="append", help="extras to install (repeat to compare; default all)")
    parser.add_argument("--modes", default="compile,no-compile", help=f"comma-separated, of {sorted(MODES)}")
    parser.add_argument("--venv", type=Path, default=Path("/tmp/venv_setup"))
    args = parser.parse_args()
    variants = {f"[{extras}] {mode}": (extras, mode)
                for extras in args.extras or ["all"] for mode in args.modes.split(",")}
    load_before = os.getloadavg()
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in variants}
    for _ in range(args.repeats):
        for name, (extras, mode) in variants.items():
            seconds = setup_venv(args.venv, extras, mode)
            runs[name].append({"wall_s": round(seconds, 1), "venv_mib": round(venv_mib(args.venv))})
    shutil.rmtree(args.venv, ignore_errors=True)
    print(json.dumps({"cpu": cpu_name(), "load_before": load_before,
                      "load_after": os.getloadavg(), "runs": runs,
                      "median_wall_s": {m: statistics.median(r["wall_s"] for r in v) for m, v in runs.items()}}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
