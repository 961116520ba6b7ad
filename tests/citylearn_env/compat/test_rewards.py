"""Reward functions with upstream's API: a custom ``RewardFunction`` subclass with ``calculate(observations)``
(observations as upstream gives them: one mapping per building), ``env_metadata`` and ``reset()``; the built-in
classes, by class or type string; all equal to the native rewards with the same actions."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.reward_function import ComfortReward, RewardFunction, SolarPenaltyReward
from citylearn_env.errors import SchemaError
from tests.citylearn_env.compat.conftest import LSTM, PHASE_1, native_env, replay, run

END = 47

PROGRAM = """
from citylearn.citylearn import CityLearnEnv
from citylearn.reward_function import RewardFunction


class CostReward(RewardFunction):
    def __init__(self, env_metadata, **kwargs):
        super().__init__(env_metadata, **kwargs)

    def calculate(self, observations):
        reward_list = [-max(o['net_electricity_consumption'], 0.0) * o['electricity_pricing'] for o in observations]
        return [sum(reward_list)] if self.central_agent else reward_list


class BatteryThroughputReward(RewardFunction):
    # reads env_metadata and keeps state between steps, reset by the environment
    def reset(self):
        self.previous = [b['electrical_storage']['initial_soc'] for b in self.env_metadata['buildings']]

    def calculate(self, observations):
        values = []
        for i, (b, o) in enumerate(zip(self.env_metadata['buildings'], observations)):
            values.append(-abs(o['electrical_storage_soc'] - self.previous[i]) * b['electrical_storage']['capacity'])
            self.previous[i] = o['electrical_storage_soc']
        return [sum(values)] if self.central_agent else values


reward = {'cost': CostReward, 'battery': BatteryThroughputReward}[which]
env = CityLearnEnv(dataset_name, central_agent=central_agent, simulation_end_time_step=end, reward_function=reward)
"""


def actions_for(env: CityLearnEnv, seed: int = 1) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    low = np.concatenate([s.low for s in env.action_space])
    high = np.concatenate([s.high for s in env.action_space])
    return [rng.uniform(low, high) for _ in range(env.time_steps - 1)]


def step_all(env: CityLearnEnv, actions: list[np.ndarray]) -> list[list[float]]:
    env.reset()
    sizes = np.cumsum([s.shape[0] for s in env.action_space])[:-1]
    return [env.step(np.split(a, sizes))[1] for a in actions]


@pytest.mark.parametrize("central_agent", [True, False])
def test_custom_calculate_equals_the_native_cost_reward(cache, central_agent) -> None:
    ns = run(PROGRAM, which="cost", dataset_name=PHASE_1, central_agent=central_agent, end=END)
    env = ns["env"]
    assert type(env.reward_function).__name__ == "CostReward" and env.get_metadata()["reward_function"] == "CostReward"
    actions = actions_for(env)
    rewards = step_all(env, actions)
    native = native_env(PHASE_1, central_agent=central_agent, simulation_end_time_step=END,
                        reward_function={"type": "cost"})
    native_rewards, _ = replay(native, actions)
    np.testing.assert_allclose(np.array(rewards).reshape(END, -1), np.array(native_rewards).reshape(END, -1),
                               rtol=1e-12, atol=1e-15)


def test_custom_reward_reads_metadata_and_is_reset(cache) -> None:
    ns = run(PROGRAM, which="battery", dataset_name=PHASE_1, central_agent=False, end=END)
    env = ns["env"]
    actions = actions_for(env, seed=2)
    for _ in range(2):  # a second episode starts from the initial SOCs again
        rewards = np.array(step_all(env, actions))
        soc = np.array([b.electrical_storage.soc for b in env.buildings])
        capacity = np.array([b.electrical_storage.capacity for b in env.buildings])
        np.testing.assert_allclose(rewards, (-np.abs(np.diff(soc, axis=1)) * capacity[:, None]).T, rtol=1e-12)


def test_built_in_classes_compute_natively_and_by_calculate(cache) -> None:
    env = CityLearnEnv(LSTM, simulation_end_time_step=END, reward_function=ComfortReward,
                       reward_function_kwargs={"band": 1.0, "higher_exponent": 2.0})
    actions = actions_for(env, seed=4)
    rewards = step_all(env, actions)
    native = native_env(LSTM, simulation_end_time_step=END, reward_function={
        "type": "citylearn.reward_function.ComfortReward", "attributes": {"band": 1.0, "higher_exponent": 2.0}})
    native_rewards, _ = replay(native, actions)
    np.testing.assert_array_equal([r[0] for r in rewards], native_rewards)
    observations = [b.observations(include_all=True) for b in env.buildings]  # what a subclass's calculate gets
    assert env.reward_function.calculate(observations) == rewards[-1]


def test_a_subclass_may_extend_the_built_in_calculation(cache) -> None:
    class Doubled(SolarPenaltyReward):
        def calculate(self, observations):
            return [2.0 * v for v in super().calculate(observations)]

    doubled = CityLearnEnv(PHASE_1, simulation_end_time_step=END, reward_function=Doubled)
    plain = CityLearnEnv(PHASE_1, simulation_end_time_step=END,
                         reward_function="citylearn.reward_function.SolarPenaltyReward")
    actions = actions_for(plain, seed=5)
    np.testing.assert_allclose(step_all(doubled, actions), 2.0 * np.array(step_all(plain, actions)), rtol=1e-12)


def test_schema_and_native_reward_types(cache) -> None:
    env = CityLearnEnv(LSTM, simulation_end_time_step=END)  # the schema's ComfortReward(band=1)
    assert isinstance(env.reward_function, ComfortReward) and env.reward_function.band == 1.0
    signal = CityLearnEnv(PHASE_1, simulation_end_time_step=END, reward_function="src.reward_function.SignalReward",
                          reward_function_kwargs={"signal": "electricity_pricing", "exponent": 1.0})
    assert signal.get_metadata()["reward_function"] == "SignalReward"
    assert isinstance(signal.reward_function, RewardFunction)
    with pytest.raises(SchemaError, match="pass reward_function=TheClass"):
        CityLearnEnv(PHASE_1, simulation_end_time_step=END, reward_function="my_module.MyReward")
