"""The gymnasium contract: spaces, checkers, seeding, registration, wrappers, PettingZoo, history."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import citylearn_env
from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from citylearn_env.wrappers import NormalizedActionWrapper, NormalizedObservationWrapper, parallel_env


@pytest.fixture(scope="module")
def schema(tmp_path_factory):
    return write_example_district(tmp_path_factory.mktemp("example"), n_buildings=3, hours=96, seed=3)


def _episode(env, seed):
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    done = False
    while not done:
        _, _, done, _, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high))
    return env.unwrapped.history()


def test_gymnasium_check_env(schema):
    check_env(CityLearnEnv(schema), skip_render_check=True)


def test_sb3_check_env(schema):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(CityLearnEnv(schema), warn=False)


def test_episode_length_and_termination(schema):
    env = CityLearnEnv(schema)
    obs, info = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape and info["time_step"] == 0
    calls = 0
    terminated = False
    while not terminated:
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        calls += 1
        assert isinstance(reward, float) and not truncated
    assert calls == 95 and info["time_step"] == 95
    with pytest.raises(RuntimeError, match="reset"):
        env.step(env.action_space.sample())


def test_episode_length_is_known_before_the_first_reset(schema):
    """``SAC.learn(total_timesteps=2 * env.episode_length)`` on a fresh env must not train 0 steps."""
    env = CityLearnEnv(schema)
    assert env.episode_length == 96
    env.reset(seed=0)
    assert env.episode_length == 96
    split = CityLearnEnv(citylearn_env.load_schema(schema).replace(episode_time_steps=24))
    assert split.episode_length == 24


def test_seeded_determinism(schema):
    a = _episode(CityLearnEnv(schema), seed=7)
    b = _episode(CityLearnEnv(schema), seed=7)
    assert a.equals(b)
    c = _episode(CityLearnEnv(schema), seed=8)
    assert not a["net_electricity_consumption"].equals(c["net_electricity_consumption"])


def test_registered_ids(schema):
    env = gym.make("citylearn_env/CityLearn-v0", schema=str(schema))
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs) or obs.shape == env.observation_space.shape
    example = gym.make("citylearn_env/Example-v0", n_buildings=2, hours=48)
    example.reset(seed=1)
    assert example.unwrapped.building_names == ("Building_1", "Building_2")


def test_central_observation_shares_names_once(schema):
    env = CityLearnEnv(schema)
    names = env.observation_names
    for shared in env.config.shared_observations:
        assert names.count(shared) <= 1
    # building observations and actions name their building; shared ones stay bare, once
    assert [n for n in names if n.endswith("electrical_storage_soc")] == [
        f"Building_{b}.electrical_storage_soc" for b in (1, 2, 3)]
    assert env.action_names == [f"Building_{b}.{a}" for b in (1, 2, 3) for a in ("dhw_storage", "electrical_storage")]


def test_normalized_wrappers(schema):
    env = NormalizedActionWrapper(NormalizedObservationWrapper(CityLearnEnv(schema)))
    obs, _ = env.reset(seed=0)
    names = env.env.observation_names
    assert names[:4] == ["month_cos", "month_sin", "day_type_cos", "day_type_sin"]
    for _ in range(30):
        obs, *_ = env.step(env.action_space.sample())
    assert obs.min() >= -1e-6 and obs.max() <= 1 + 1e-6
    # action 0.5 in [0, 1] is the middle of the battery's symmetric range: no battery flow requested
    env.reset(seed=0)
    env.step(np.full(env.action_space.shape, 0.5))
    assert np.allclose(env.unwrapped.series()["electrical_storage_energy_balance"][:, 1], 0.0)


def test_pettingzoo_parallel_api(schema):
    test = pytest.importorskip("pettingzoo.test")
    env = parallel_env(str(schema))
    test.parallel_api_test(env, num_cycles=50)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"Building_1", "Building_2", "Building_3"}
    _, rewards, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})
    assert len(rewards) == 3


def test_history_columns_and_district_rows(schema):
    history = _episode(CityLearnEnv(schema), seed=0)
    for column in ("net_electricity_consumption", "cooling_electricity_consumption", "dhw_electricity_consumption",
                   "electrical_storage_soc", "dhw_storage_soc", "indoor_dry_bulb_temperature", "solar_generation",
                   "net_electricity_consumption_without_storage_and_pv"):
        assert column in history.columns
    assert len(history) == 4 * 96
    buildings = history[history.building != "District"]
    district = history[history.building == "District"].set_index("time_step")
    summed = buildings.groupby("time_step")["net_electricity_consumption"].sum()
    np.testing.assert_allclose(district["net_electricity_consumption"], summed)
    assert district["electrical_storage_soc"].isna().all()
    # energy balance: net = device consumption + NSL + battery - PV, every row
    b = buildings
    parts = (b.cooling_electricity_consumption + b.heating_electricity_consumption + b.dhw_electricity_consumption
             + b.non_shiftable_load_electricity_consumption + b.electrical_storage_electricity_consumption
             + b.solar_generation)
    np.testing.assert_allclose(b.net_electricity_consumption, parts, atol=1e-12)


def test_import_is_light():
    # CPU time, not wall time: the suite runs on 2 busy cores; the import costs ~0.25 s of CPU here
    code = ("import sys, time; t = time.process_time(); import citylearn_env; "
            "print(time.process_time() - t, 'torch' in sys.modules, 'prefect' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert float(out[0]) < 1.0
    assert out[1:] == ["False", "False"]


def test_version_and_public_api():
    assert set(citylearn_env.__all__) >= {"CityLearnEnv", "load_schema", "SchemaError"}
