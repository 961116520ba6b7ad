"""The CityLearn v2.2+ vocabulary: the combined heat-pump action, split set points and their deltas, renamed
observations, and the RL interface (building-qualified names, make_vec, clipped normalisation)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest

import citylearn_env  # noqa: F401  (registers the ids)
from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.example import write_example_district
from citylearn_env.wrappers import NormalizedObservationWrapper
from tests.conftest import SHARED, need_shared

UPSTREAM = SHARED / "data/citylearn/upstream/v2.4.2/citylearn_challenge_2023_phase_1/schema.json"


def _split_set_point_district(tmp_path):
    """The example district with Building_1's set point split into cooling 24 / heating 20 degC and
    hvac_mode 2 (heating) in the first 6 hours, as a v2.2+ file has them."""
    schema = write_example_district(tmp_path, n_buildings=2, hours=48)
    path = tmp_path / "Building_1.csv"
    frame = pd.read_csv(path)
    frame = frame.drop(columns=["indoor_dry_bulb_temperature_set_point"])
    frame["indoor_dry_bulb_temperature_cooling_set_point"] = 24.0
    frame["indoor_dry_bulb_temperature_heating_set_point"] = 20.0
    frame["hvac_mode"] = np.where(np.arange(len(frame)) < 6, 2, 1)
    frame["heating_demand"], frame.loc[:5, "cooling_demand"] = 0.0, 0.0  # never both > 0
    frame.to_csv(path, index=False)
    raw = json.loads(schema.read_text())
    for name in ("indoor_dry_bulb_temperature_cooling_delta", "indoor_dry_bulb_temperature_heating_delta",
                 "indoor_dry_bulb_temperature_cooling_set_point", "cooling_device_efficiency"):
        raw["observations"][name] = {"active": True, "shared_in_central_agent": False}
    schema.write_text(json.dumps(raw))
    return schema, frame


def test_split_set_points_and_signed_deltas(tmp_path):
    schema, frame = _split_set_point_district(tmp_path)
    series = load_schema(schema).buildings[0].series
    np.testing.assert_array_equal(series["indoor_dry_bulb_temperature_cooling_set_point"], 24.0)
    np.testing.assert_array_equal(series["indoor_dry_bulb_temperature_heating_set_point"], 20.0)
    # comfort is measured against the heating set point in heating mode, the cooling one otherwise
    np.testing.assert_array_equal(series["indoor_dry_bulb_temperature_set_point"][:8], [20] * 6 + [24] * 2)
    env = CityLearnEnv(schema)
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape))
    obs = env.step_observations()
    t_in = float(np.float32(frame["indoor_dry_bulb_temperature"][1]))  # data are held float32-rounded
    assert obs["indoor_dry_bulb_temperature_cooling_delta"][0] == pytest.approx(t_in - 24.0)
    assert obs["indoor_dry_bulb_temperature_heating_delta"][0] == pytest.approx(t_in - 20.0)
    assert obs["indoor_dry_bulb_temperature_delta"][0] == pytest.approx(abs(t_in - 20.0))  # heating hour
    # the v2.2+ name of a heat pump's COP: efficiency * (T_target + 273.15) / (T_out - T_target)
    t_out = float(obs["outdoor_dry_bulb_temperature"][0])
    cop = 0.25 * (8.0 + 273.15) / (t_out - 8.0)
    assert obs["cooling_device_efficiency"][0] == pytest.approx(min(cop, 20.0) if cop > 0 else 20.0)
    assert "Building_1.indoor_dry_bulb_temperature_cooling_delta" in env.observation_names


def test_predicted_1_2_3_observe_the_6_12_24_hour_forecasts(tmp_path):
    schema = write_example_district(tmp_path, n_buildings=1, hours=48)
    raw = json.loads(schema.read_text())
    raw["observations"] = {"outdoor_dry_bulb_temperature_predicted_1": {"active": True},
                           "outdoor_dry_bulb_temperature_predicted_6h": {"active": True}}
    env = CityLearnEnv(raw | {"root_directory": str(tmp_path)})
    obs, _ = env.reset(seed=0)
    assert obs[0] == obs[1]  # the v2.2+ name _1 is the 6-hour slot


@pytest.fixture(scope="module")
def upstream_2023():
    need_shared(UPSTREAM)
    return UPSTREAM


def test_combined_action_equals_the_split_device_actions(upstream_2023):
    """cooling_or_heating_device = -a acts as cooling_device = a (and heating_device 0) on LSTM buildings."""
    base = load_schema(upstream_2023).with_episode([(0, 60)])
    runs = {}
    for active, value in ((["cooling_or_heating_device"], -0.4), (["cooling_device", "heating_device"], None)):
        env = CityLearnEnv(base.with_actions(active))
        env.reset(seed=0)
        if value is None:  # cooling 0.4, heating 0: per building in action order
            action = np.array([0.4 if n.endswith(".cooling_device") else 0.0 for n in env.action_names])
        else:
            assert env.action_names == [f"Building_{b}.cooling_or_heating_device" for b in (1, 2, 3)]
            assert env.action_space.low.tolist() == [-1.0] * 3 and env.action_space.high.tolist() == [1.0] * 3
            action = np.full(3, value)
        for _ in range(59):
            env.step(action)
        runs[value] = env.series()
    combined, split = runs[-0.4], runs[None]
    np.testing.assert_array_equal(combined["net_electricity_consumption"], split["net_electricity_consumption"])
    np.testing.assert_array_equal(combined["indoor_dry_bulb_temperature"], split["indoor_dry_bulb_temperature"])
    # the action did something: from the warm-up on, the heat pump serves 0.4 of its power, not the ideal load
    assert not np.allclose(combined["cooling_demand"][:, 20:], combined["cooling_demand_without_partial_load"][:, 20:])


def test_make_vec_returns_the_batched_vector_env():
    from citylearn_env.vector import CityLearnVectorEnv

    vec = gym.make_vec("citylearn_env/Example-v0", num_envs=3, vectorization_mode="vector_entry_point",
                       n_buildings=2, hours=48)
    assert isinstance(vec, CityLearnVectorEnv)
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (3, *vec.single_observation_space.shape)
    obs, reward, terminated, truncated, _ = vec.step(vec.action_space.sample())
    assert reward.shape == (3,) and not terminated.any()


def test_clipped_normalised_observations(tmp_path):
    schema = write_example_district(tmp_path, n_buildings=2, hours=48)
    env = CityLearnEnv(schema)
    clipped = NormalizedObservationWrapper(CityLearnEnv(schema))  # clip=True is the default
    plain = NormalizedObservationWrapper(env, clip=False)
    raw = np.asarray(env.observation_space.high, dtype=np.float64) + 100.0  # far above every bound
    assert plain.observation(raw).max() > 1.0
    # unclipped values are declared as such: the space never claims [0, 1] for values that leave it
    assert np.isinf(plain.observation_space.low).all() and np.isinf(plain.observation_space.high).all()
    assert plain.observation_space.contains(plain.observation(raw))
    out = clipped.observation(raw)
    assert out.min() >= 0.0 and out.max() <= 1.0 and clipped.observation_space.contains(out)
