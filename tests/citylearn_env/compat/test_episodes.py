"""Episode bookkeeping known from construction (``time_steps``, ``episode_length``, ``episode_tracker``), episode
splits, upstream's constructor keywords, ``rewards`` / ``episode_rewards`` and ``get_metadata()``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.utilities import write_json
from citylearn_env.errors import SchemaError
from tests.citylearn_env.compat.conftest import PHASE_1, native_env

END = 47


def run_episode(env: CityLearnEnv) -> None:
    env.reset()
    zeros = [[0.0] * s.shape[0] for s in env.action_space]
    while not env.terminated:
        env.step(zeros)


def test_time_steps_are_known_before_reset(cache) -> None:
    env = CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=END)
    assert env.time_steps == env.episode_length == END + 1  # what SAC.learn(total_timesteps=2 * ...) reads
    assert env.episode_tracker.episode_time_steps == END + 1 and env.episode_tracker.episode == 0
    assert env.time_step == 0 and not env.terminated and len(env.observations[0]) == 60
    assert native_env(PHASE_1, simulation_end_time_step=END).episode_length == END + 1  # the native env too
    env.reset()
    assert env.native.episode == 0  # the construction reset does not use up episode 0


def test_episode_splits_and_the_tracker(cache) -> None:
    env = CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=END, episode_time_steps=24)
    assert env.time_steps == 24 and env.episode_time_steps == 24
    starts = []
    for _ in range(3):
        run_episode(env)
        tracker = env.episode_tracker
        starts.append((tracker.episode, tracker.episode_start_time_step, tracker.episode_end_time_step))
        assert env.time_step == 23 and len(env.rewards) == 24 and env.rewards[0] == []
    assert starts == [(0, 0, 23), (1, 24, 47), (2, 0, 23)]
    assert len(env.episode_rewards) == 3 and set(env.episode_rewards[0]) == {"min", "max", "sum", "mean"}
    # the SimBuild program's evaluation: a new split set between episodes
    env.episode_time_steps = [[12, 35]]
    assert env.time_steps == 24
    env.reset()
    assert env.episode_tracker.episode_start_time_step == 12 and env.episode_tracker.episode == 3
    assert env.buildings[0].energy_simulation.hour[0] == env.native.data("hour")[0, 0] == 12


def test_constructor_keywords(cache) -> None:
    env = CityLearnEnv(PHASE_1, buildings=[3, "Building_1"], simulation_start_time_step=24,
                       simulation_end_time_step=71, random_seed=5, central_agent=True)
    assert [b.name for b in env.buildings] == ["Building_4", "Building_1"]
    assert env.random_seed == 5 and env.central_agent and env.time_steps == 48
    tracker = env.episode_tracker
    assert (tracker.simulation_start_time_step, tracker.simulation_end_time_step) == (24, 71)
    native = native_env(PHASE_1, simulation_start_time_step=24, simulation_end_time_step=71)
    native.reset()
    np.testing.assert_array_equal(env.buildings[0].energy_simulation.non_shiftable_load,
                                  native.data("non_shiftable_load")[3])
    with pytest.raises(SchemaError, match="unsupported keyword"):
        CityLearnEnv(PHASE_1, simulation_end_time_step=END, no_such_keyword=1)


def test_metadata_is_upstream_shaped_and_json_writable(cache, tmp_path) -> None:
    env = CityLearnEnv(PHASE_1, simulation_end_time_step=END)
    meta = env.get_metadata()
    assert meta["central_agent"] is False and meta["reward_function"] == "RewardFunction"
    assert meta["simulation_time_steps"] == END + 1 and len(meta["buildings"]) == 5
    b = meta["buildings"][0]
    assert b["name"] == "Building_1" and b["action_metadata"]["electrical_storage"] is True
    assert b["electrical_storage"]["capacity"] == 6.4 and b["electrical_storage"]["type"] == "Battery"
    assert b["dhw_storage"]["initial_soc"] == 0.0 and b["pv"]["nominal_power"] > 0
    assert b["observation_metadata"]["hour"] is True
    write_json(tmp_path / "meta.json", meta)
    assert json.loads((tmp_path / "meta.json").read_text())["buildings"][0]["name"] == "Building_1"
    assert env.reward_function.env_metadata["buildings"][0]["name"] == "Building_1"


def test_observation_action_and_device_keywords(cache) -> None:
    env = CityLearnEnv(PHASE_1, simulation_end_time_step=END, central_agent=True, solar_generation=False,
                       active_observations=["hour", "solar_generation", "net_electricity_consumption"],
                       shared_observations=["hour"], inactive_actions=["electrical_storage"])
    assert env.observation_names == [["hour"] + ["solar_generation", "net_electricity_consumption"] * 5]
    assert env.action_space[0].shape == (0,)
    env.reset()
    assert all(b.pv.nominal_power == 0.0 for b in env.buildings) and not any(env.observations[0][1::2])
    with pytest.raises(SchemaError, match="per-building lists are not supported"):
        CityLearnEnv(PHASE_1, simulation_end_time_step=END, active_actions=[["electrical_storage"]] * 5)
    with pytest.raises(SchemaError, match="no building of the schema defines power outages"):
        CityLearnEnv(PHASE_1, simulation_end_time_step=END, simulate_power_outage=True)
    with pytest.raises(SchemaError, match="unknown building"):
        CityLearnEnv(PHASE_1, simulation_end_time_step=END, buildings=["Building_9"])
