"""The CityLearn version a program was written for decides the API and the physics (issue 49, item 1): the data
set's layout tells a 2.1 program (v2.1 layout: ``reset()`` -> observations, four step values, the 2.1 preset) from a
2.2+ one (v2.2+ layout: gymnasium's API, the 2.5 preset and KPI names); ``citylearn_version=`` and
``$DISTRICTGEN_CITYLEARN_VERSION`` override; one notice line names the version mirrored."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from citylearn_env.compat import version
from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.version import VERSION_VAR
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_1, CITYLEARN_2_5
from tests.citylearn_env.compat.conftest import PHASE_1, UPSTREAM, native_env, replay, run

END = 23

PROGRAM_2_1 = """
from citylearn.citylearn import CityLearnEnv

env = CityLearnEnv(schema, central_agent=True, simulation_end_time_step=end)
observations = env.reset()
rewards = []
while not env.done:
    observations, reward, done, info = env.step([[0.1] * len(env.action_space[0].low)])
    rewards.append(reward[0])
"""

PROGRAM_2_5 = """
from citylearn.citylearn import CityLearnEnv

env = CityLearnEnv(schema, central_agent=True, simulation_end_time_step=end)
observations, info = env.reset()
rewards = []
while not env.terminated:
    observations, reward, terminated, truncated, info = env.step([[0.1] * len(env.action_space[0].low)])
    rewards.append(reward[0])
kpis = env.evaluate()
"""


def schema_of(tag: str) -> str:
    return str(UPSTREAM / tag / PHASE_1 / "schema.json")


def test_a_2_1_program_on_a_v2_1_schema_gets_2_1_api_and_physics(cache, monkeypatch) -> None:
    monkeypatch.delenv(VERSION_VAR)
    ns = run(PROGRAM_2_1, schema=schema_of("v2.1.2"), end=END)
    env = ns["env"]
    assert env.mirror.version == "2.1" and env.settings is CITYLEARN_2_1 and "v2.1" in env.mirror.reason
    native = native_env(PHASE_1, central_agent=True, simulation_end_time_step=END)
    rewards, _ = replay(native, [np.full(5, 0.1)] * END)
    assert len(ns["rewards"]) == END
    np.testing.assert_array_equal(ns["rewards"], rewards)


def test_a_2_5_program_on_a_v2_2_schema_gets_gymnasium_and_2_5_physics(cache, monkeypatch) -> None:
    monkeypatch.delenv(VERSION_VAR)
    ns = run(PROGRAM_2_5, schema=schema_of("v2.4.2"), end=END)
    env = ns["env"]
    assert env.mirror.version == "2.5" and env.settings is CITYLEARN_2_5
    native = native_env(PHASE_1, "citylearn-2.5", "v2.4.2", central_agent=True, simulation_end_time_step=END)
    rewards, _ = replay(native, [np.full(5, 0.1)] * END)
    np.testing.assert_array_equal(ns["rewards"], rewards)
    names = set(ns["kpis"]["cost_function"])
    assert "all_time_peak_average" in names and "annual_peak_average" not in names  # 2.5's KPI names


def test_an_explicit_choice_overrides_the_layout(cache, monkeypatch) -> None:
    monkeypatch.delenv(VERSION_VAR)
    env = CityLearnEnv(schema_of("v2.4.2"), citylearn_version="2.1.2", central_agent=True,
                       simulation_end_time_step=END)
    assert env.mirror.version == "2.1" and env.settings is CITYLEARN_2_1
    assert isinstance(env.reset(), list)  # the observations alone
    assert len(env.step([[0.0] * 5])) == 4
    monkeypatch.setenv(VERSION_VAR, "2.5")
    env = CityLearnEnv(schema_of("v2.1.2"), central_agent=True, simulation_end_time_step=END)
    assert env.mirror.version == "2.5" and len(env.reset()) == 2 and len(env.step([[0.0] * 5])) == 5
    # settings= overrides the physics alone
    env = CityLearnEnv(schema_of("v2.1.2"), citylearn_version="2.1", settings="corrected",
                       simulation_end_time_step=END)
    assert env.mirror.api == "2.1" and not env.settings.kpi_float32_score


def test_one_notice_line_names_the_mirrored_version(cache, monkeypatch, caplog) -> None:
    monkeypatch.delenv(VERSION_VAR)
    monkeypatch.setattr(version, "_NOTICED", set())
    with caplog.at_level(logging.WARNING, logger="citylearn_env.compat"):
        CityLearnEnv(schema_of("v2.1.2"), simulation_end_time_step=END)
        CityLearnEnv(schema_of("v2.1.2"), simulation_end_time_step=END)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "\n" not in lines[0]
    assert "CityLearn 2.1.2" in lines[0] and "v2.1 layout" in lines[0] and VERSION_VAR in lines[0]


@pytest.mark.parametrize("bad", ["3.0", "2.9", "latest", 2])
def test_an_unknown_version_is_one_line(cache, bad) -> None:
    with pytest.raises(SchemaError, match="unknown CityLearn version") as error:
        CityLearnEnv(schema_of("v2.1.2"), citylearn_version=bad)
    assert "\n" not in str(error.value)


def test_version_parsing() -> None:
    assert [version.parse_version(v) for v in ("2.1", "2.1.0", "v2.1.2", "2.2", "2.4.2", "2.5.0")] == \
        ["2.1", "2.1", "2.1", "2.5", "2.5", "2.5"]
