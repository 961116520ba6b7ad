"""Measure a plain ``pip install districtgen`` (no extras): what it installs, its size, and the import time.

    python benchmarks/plain_install.py [--venv /tmp/plainvenv] [--runs 5] [--reuse] [--ref HEAD]

Steps: a fresh venv (``python3 -m venv``), ``pip install <repo>`` non-editable and without extras, then

* the installed distributions (``pip list``) and the venv size (``du``, bytes and MiB);
* whether torch, prefect, pydantic, pvlib, scikit-learn or matplotlib got installed (they must not);
* ``import citylearn_env`` wall time, median of ``--runs`` fresh interpreters started in /tmp (so the working
  tree is not on ``sys.path``), with the load average (1, 5, 15 min) next to it;
* a smoke run in the plain venv: ``make_example_env(n_buildings=2, hours=48)``, reset and 47 steps, and the
  heavy modules found in ``sys.modules`` afterwards (must be none);
* the ``districtgen`` console script's answer without the pipeline extra (one line naming the extra).

The repository is copied (``git ls-files -co --exclude-standard``) to a temporary folder before ``pip install``
so the in-tree build does not leave ``build/`` behind in the shared working tree; the installed files are the
same as ``pip install <repo>``. With ``--ref REF`` the source is ``git archive REF`` instead, with the working
tree's packaging files (pyproject.toml, README.md, pipeline/cli.py) on top: a consistent snapshot of the code
while other files are being edited. Prints one JSON object on stdout.
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

REPO = Path(__file__).resolve().parents[1]
#: distributions that belong to extras and must not come with a plain install
HEAVY_DISTS = ("torch", "prefect", "prefect-dask", "pydantic", "pvlib", "scikit-learn", "matplotlib", "fmpy",
               "stable-baselines3", "numba", "pyarrow", "dask", "distributed")
#: modules that must not be imported by citylearn_env
HEAVY_MODULES = ("torch", "prefect", "pydantic", "pvlib", "sklearn", "matplotlib")
#: the files that define the packaging, taken from the working tree with ``--ref``
PACKAGING_FILES = ("pyproject.toml", "README.md", "pipeline/cli.py")

IMPORT_TIMER = "import time; t=time.perf_counter(); import citylearn_env; print(time.perf_counter()-t)"
SMOKE = f"""
import json, sys, time
t = time.process_time()
import citylearn_env
import_cpu_s = time.process_time() - t
env = citylearn_env.make_example_env(n_buildings=2, hours=48)
obs, info = env.reset(seed=0)
steps = 0
while True:
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    steps += 1
    if terminated or truncated:
        break
heavy = sorted(m for m in {HEAVY_MODULES!r} if m in sys.modules)
print(json.dumps({{"import_cpu_s": import_cpu_s, "steps": steps, "heavy_modules": heavy,
                   "citylearn_env_file": citylearn_env.__file__}}))
"""


def _run(cmd: list[str], cwd: str | Path | None = None, check: bool = True) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, check=check)


def copy_source(repo: Path, dest: Path) -> Path:
    """Copy the files git sees (tracked and untracked, not ignored) of ``repo`` into ``dest``; returns dest."""
    listing = _run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=repo).stdout
    for name in filter(None, listing.split("\0")):
        source = repo / name
        if source.is_file():
            target = dest / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    return dest


def export_ref(repo: Path, ref: str, dest: Path) -> Path:
    """``git archive ref`` of ``repo`` unpacked in ``dest``, with the working tree's PACKAGING_FILES on top."""
    dest.mkdir(parents=True)
    archive = subprocess.run(["git", "archive", "--format=tar", ref], cwd=repo, capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)
    for name in PACKAGING_FILES:
        shutil.copy2(repo / name, dest / name)
    return dest


def venv_bytes(venv: Path) -> int:
    """Apparent size of the venv on disk in bytes (``du -sb``)."""
    return int(_run(["du", "-sb", str(venv)]).stdout.split()[0])


def measure(venv: Path, runs: int, reuse: bool, ref: str | None = None) -> dict:
    """Create (unless ``reuse``) the plain venv, install the package (working tree, or ``ref`` with the
    working tree's packaging files), and return the measurements."""
    python = venv / "bin" / "python"
    install_s = None
    if not (reuse and python.exists()):
        shutil.rmtree(venv, ignore_errors=True)
        _run([sys.executable, "-m", "venv", str(venv)])
        with tempfile.TemporaryDirectory(prefix="districtgen_src_") as tmp:
            dest = Path(tmp) / "districtgen"
            source = copy_source(REPO, dest) if ref is None else export_ref(REPO, ref, dest)
            start = time.perf_counter()
            _run([str(python), "-m", "pip", "install", "-q", str(source)])
            install_s = time.perf_counter() - start
    dists = {d["name"].lower(): d["version"] for d in
             json.loads(_run([str(python), "-m", "pip", "list", "--format=json"]).stdout)}
    import_s = [float(_run([str(python), "-c", IMPORT_TIMER], cwd="/tmp").stdout) for _ in range(runs)]
    smoke = json.loads(_run([str(python), "-c", SMOKE], cwd="/tmp").stdout)
    cli = _run([str(venv / "bin" / "districtgen"), "--help"], cwd="/tmp", check=False)
    size = venv_bytes(venv)
    return {
        "venv": str(venv),
        "source": "working tree" if ref is None else f"git archive {ref} + working-tree {', '.join(PACKAGING_FILES)}",
        "install_wall_s": None if install_s is None else round(install_s, 1),
        "distributions": dists,
        "n_distributions": len(dists),
        "venv_bytes": size,
        "venv_mib": round(size / 2**20, 1),
        "du_sh": _run(["du", "-sh", str(venv)]).stdout.split()[0],
        "heavy_installed": sorted(d for d in HEAVY_DISTS if d in dists),
        "torch_installed": "torch" in dists,
        "prefect_installed": "prefect" in dists,
        "import_s_runs": [round(t, 4) for t in import_s],
        "import_s_median": round(statistics.median(import_s), 4),
        "smoke": smoke,
        "cli_exit_status": cli.returncode,
        "cli_stderr": cli.stderr.strip(),
        "loadavg_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
    }


def main(argv: list[str] | None = None) -> int:
    """Run the measurement and print the JSON summary; exit status 1 if a goal is missed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--venv", type=Path, default=Path("/tmp/plainvenv"))
    parser.add_argument("--runs", type=int, default=5, help="fresh interpreters for the import time")
    parser.add_argument("--reuse", action="store_true", help="measure an existing venv, do not reinstall")
    parser.add_argument("--ref", help="install `git archive REF` (plus the working tree's packaging files)")
    args = parser.parse_args(argv)
    result = measure(args.venv, args.runs, args.reuse, args.ref)
    result["goals"] = {"venv_le_400_mb": result["venv_bytes"] <= 400e6,
                       "no_torch_no_prefect": not (result["torch_installed"] or result["prefect_installed"]),
                       "import_lt_0_5_s": result["import_s_median"] < 0.5,
                       "no_heavy_modules": not result["smoke"]["heavy_modules"]}
    print(json.dumps(result, indent=2))
    return 0 if all(result["goals"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
