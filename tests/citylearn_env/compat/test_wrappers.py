"""``NormalizedObservationWrapper`` computes the native normalising wrapper's values (central, clipped or not, and
per building); the wrappers hand upstream attributes through; ``StableBaselines3Wrapper`` needs a central agent."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.wrappers import NormalizedObservationWrapper, StableBaselines3Wrapper
from citylearn_env.errors import SchemaError
from citylearn_env.wrappers import NormalizedObservationWrapper as NativeNormalized
from tests.citylearn_env.compat.conftest import LSTM, PHASE_1

END = 47


@pytest.mark.parametrize("clip", [False, True])
def test_central_values_equal_the_native_wrapper(cache, clip) -> None:
    env = NormalizedObservationWrapper(CityLearnEnv(LSTM, simulation_end_time_step=END), clip=clip)
    native = NativeNormalized(env.unwrapped.native, clip=clip)  # the same native env, wrapped natively
    assert env.observation_names == [[n.split(".")[-1] for n in native.observation_names]]
    assert env.observation_space[0].shape == native.observation_space.shape
    assert (env.observation_space[0].high == native.observation_space.high).all()
    observations = env.reset()  # CityLearn 2.1's API (v2.1 data set)
    rng = np.random.default_rng(0)
    for _ in range(END):
        np.testing.assert_array_equal(observations[0], native.observation(env.unwrapped.native.flat_observations()[
            env.unwrapped.native.layout.central_index].astype(np.float32)))
        observations, _, _, _ = env.step([rng.uniform(-0.5, 0.5, size=env.action_space[0].shape)])
    assert env.unwrapped.terminated


def test_per_building_values_use_each_building_bounds(cache) -> None:
    env = NormalizedObservationWrapper(CityLearnEnv(PHASE_1, simulation_end_time_step=END))
    observations = env.reset()  # CityLearn 2.1's API (v2.1 data set)
    names = env.observation_names
    assert len(observations) == 5 and [len(o) for o in observations] == [31] * 5
    assert names[0][:6] == ["month_cos", "month_sin", "day_type_cos", "day_type_sin", "hour_cos", "hour_sin"]
    raw = env.unwrapped.observations[1]
    space = env.unwrapped.observation_space[1]
    i = env.unwrapped.observation_names[1].index("net_electricity_consumption")
    j = names[1].index("net_electricity_consumption")
    low, high = np.float64(space.low[i]), np.float64(space.high[i])
    assert observations[1][j] == np.float32((raw[i] - low) / (high - low))
    hour = raw[env.unwrapped.observation_names[1].index("hour")]
    assert observations[1][4] == np.float32((np.cos(2 * np.pi * hour / 24) + 1) / 2)


def test_wrappers_forward_upstream_attributes_and_refuse_decentralised_sb3(cache) -> None:
    env = NormalizedObservationWrapper(CityLearnEnv(PHASE_1, simulation_end_time_step=END))
    assert env.time_steps == END + 1 and env.buildings[0].name == "Building_1" and not env.central_agent
    with pytest.raises(SchemaError, match="central_agent=True"):
        StableBaselines3Wrapper(env)
