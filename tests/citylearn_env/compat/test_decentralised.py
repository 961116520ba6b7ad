"""Decentralised agents: observations, actions, spaces and names as one list per building; per-building rewards;
all equal to the native environment's per-building slices and rewards with the same actions."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env.compat.agents.rbc import BasicBatteryRBC, BasicRBC, HourRBC, OptimizedRBC
from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.errors import SchemaError
from tests.citylearn_env.compat.conftest import PHASE_1, native_env, replay

END = 71


@pytest.fixture
def env(cache) -> CityLearnEnv:
    return CityLearnEnv(PHASE_1, simulation_end_time_step=END)  # the schema says central_agent: false


def test_spaces_and_names_are_per_building(env) -> None:
    assert not env.central_agent
    assert len(env.observation_space) == len(env.action_space) == len(env.buildings) == 5
    assert [len(n) for n in env.observation_names] == [28] * 5
    assert env.action_names == [["electrical_storage"]] * 5
    assert all(s.shape == (28,) for s in env.observation_space) and all(s.shape == (1,) for s in env.action_space)
    observations = env.reset()  # a v2.1-layout data set: CityLearn 2.1's API
    assert [len(o) for o in observations] == [28] * 5
    assert all(isinstance(v, float) for o in observations for v in o)
    for b, (names, space) in enumerate(zip(env.observation_names, env.observation_space, strict=True)):
        assert names == env.buildings[b].active_observations
        assert space == env.buildings[b].observation_space


def test_list_of_lists_equals_the_native_env(env) -> None:
    rng = np.random.default_rng(7)
    env.reset()
    actions, rewards, observations = [], [], []
    while not env.terminated:
        a = [list(rng.uniform(-0.7, 0.7, size=1)) for _ in range(5)]
        obs, reward, terminated, _ = env.step(a)
        actions.append(np.concatenate(a))
        rewards.append(reward)
        observations.append(obs)
        assert len(reward) == 5
    assert terminated and len(actions) == END
    native = native_env(PHASE_1, simulation_end_time_step=END)
    native_rewards, native_observations = replay(native, actions)
    np.testing.assert_array_equal(rewards, native_rewards)
    for obs, flat in zip(observations, native_observations, strict=True):
        for b, s in enumerate(native.layout.building_slices):
            np.testing.assert_array_equal(obs[b], flat[s].astype(np.float32))
    assert env.rewards[1:] == rewards


def test_rbc_acts_per_building(env) -> None:
    rbc = BasicRBC(env)
    rbc.learn(episodes=1)
    assert [len(a) for a in rbc.actions] == [END + 1] * 5
    hours = env.buildings[0].energy_simulation.hour
    for t in range(END):
        expected = -0.08 if 9 <= hours[t] <= 21 else 0.091
        assert [a[t] for a in rbc.actions] == [[expected]] * 5
    maps = [{"electrical_storage": {h: 0.01 * b for h in range(1, 25)}} for b in range(5)]
    hour_rbc = HourRBC(env, action_map=maps)
    observations = env.reset()
    assert hour_rbc.predict(observations) == [[0.0], [0.01], [0.02], [0.03], [0.04]]


def test_wrong_action_lists_are_refused_in_one_line(env) -> None:
    env.reset()
    with pytest.raises(SchemaError, match="one action list per building") as error:
        env.step([[0.0] * 5])
    assert "\n" not in str(error.value)
    with pytest.raises(SchemaError, match="expected 1 actions for building 2"):
        env.step([[0.0], [0.0], [0.0, 0.1], [0.0], [0.0]])


def test_parse_actions_records_per_building_actions(env) -> None:
    parsed = env._parse_actions([[0.1], [0.2], [0.3], [0.4], [0.5]])  # upstream's private helper, used by the paper
    assert parsed == [{"electrical_storage_action": v} for v in (0.1, 0.2, 0.3, 0.4, 0.5)]


@pytest.mark.parametrize(("cls", "at_hour"), [
    (BasicRBC, {1: 0.091, 9: -0.08, 21: -0.08, 22: 0.091}),
    (OptimizedRBC, {1: 0.05532, 7: -0.02, 16: -0.0044, 19: -0.024, 23: 0.034}),
    (BasicBatteryRBC, {5: -0.067, 6: 0.11, 14: 0.11, 15: -0.067}),
])
def test_rbc_hour_rules(env, cls, at_hour) -> None:
    rules = cls(env).action_map[0]["electrical_storage"]
    assert sorted(rules) == list(range(1, 25))
    assert {h: rules[h] for h in at_hour} == at_hour
