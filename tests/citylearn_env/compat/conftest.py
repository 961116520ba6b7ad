"""Shared fixtures of the compat tests: the upstream data sets as the data-set cache, upstream programs ported by
their imports only, and native environments built independently of the compat layer for comparison.

The data sets are upstream's, unchanged, in ../shared/data/citylearn/upstream/<tag>/<name>/; tests that need them
skip with the reason when ../shared is absent. Nothing is downloaded.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from citylearn_env import CityLearnEnv as NativeEnv
from citylearn_env.compat.data import ENV_VAR
from citylearn_env.compat.utilities import read_json
from citylearn_env.compat.version import VERSION_VAR
from tests.conftest import SHARED, need_shared

UPSTREAM = SHARED / "data" / "citylearn" / "upstream"
PHASE_1 = "citylearn_challenge_2022_phase_1"  # 5 buildings, batteries and PV, no LSTM
LSTM = "citylearn_challenge_2023_phase_1"  # 3 LSTM buildings, DHW tank, battery, heat pump
IMPORT = re.compile(r"^(\s*)(from|import)(\s+)citylearn\.", re.MULTILINE)


@pytest.fixture(scope="module")
def cache() -> Iterator[Path]:
    """The shared upstream data sets as the data-set cache, data-set names read as CityLearn 2.1 programs read
    them (``$DISTRICTGEN_CITYLEARN_VERSION=2.1``; skip when ../shared is absent)."""
    need_shared(UPSTREAM / "v2.1.2" / PHASE_1 / "schema.json")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(ENV_VAR, str(UPSTREAM))
        mp.setenv(VERSION_VAR, "2.1")
        yield UPSTREAM


def port(program: str) -> str:
    """An upstream program with ``citylearn.`` replaced by ``citylearn_env.compat.`` in its imports, nothing else."""
    return IMPORT.sub(r"\1\2\3citylearn_env.compat.", program)


def run(program: str, **names: Any) -> dict[str, Any]:
    """Run the ported ``program`` with ``names`` defined; return its namespace."""
    namespace = dict(names)
    exec(compile(port(program), "<upstream program>", "exec"), namespace)  # noqa: S102 - the test's own text
    return namespace


def native_env(name: str, settings: str = "citylearn-2.1", tag: str = "v2.1.2", **edits: Any) -> NativeEnv:
    """A native environment on upstream data set ``name`` with top-level schema keys replaced by ``edits``
    (e.g. ``central_agent``, ``simulation_end_time_step``), built without the compat layer."""
    path = UPSTREAM / tag / name / "schema.json"
    need_shared(path)
    raw = {**read_json(path), **edits, "root_directory": str(path.parent)}
    return NativeEnv(raw, settings=settings)


def replay(env: NativeEnv, actions: list[np.ndarray]) -> tuple[list[Any], list[np.ndarray]]:
    """Reset ``env`` and step it with ``actions``; return the rewards (per building when not central) and the
    flat observations after each step."""
    env.reset()
    rewards, observations = [], []
    for a in actions:
        _, reward, _, _, info = env.step(np.asarray(a, dtype=np.float64).reshape(-1))
        rewards.append(info.get("building_rewards", reward))
        observations.append(env.flat_observations().copy())
    return rewards, observations
