"""A CityLearn 2.1 program written the SimBuild 2024 way, run unchanged but for its imports (issue 49, item 6): a
static ``DataSet.get_schema``, a schema naming the program's own reward class, a DummyController of None actions,
Stable-Baselines3 SAC trained for ``episodes * time_steps`` through the upstream wrappers, then a changed episode
length for the evaluation run, all with CityLearn 2.1's ``reset``/``step`` forms."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from citylearn_env.compat.citylearn import CityLearnEnv
from tests.citylearn_env.compat.conftest import LSTM, run

pytest.importorskip("stable_baselines3", reason="stable-baselines3 (the rl extra) is not installed")

END = 47
MODULE = "simbuild_way_src.reward_function"

REWARD_MODULE = """
from citylearn_env.compat.reward_function import RewardFunction


class SignalReward(RewardFunction):
    def __init__(self, env_metadata, signal=None, exponent=1.0, **kwargs):
        super().__init__(env_metadata, **kwargs)
        self.signal, self.exponent = signal, exponent

    def calculate(self, observations):
        values = [-(max(o['net_electricity_consumption'], 0.0) * o[self.signal]) ** self.exponent * FACTOR
                  for o in observations]
        return [sum(values)] if self.central_agent else values
"""

PROGRAM = """
from stable_baselines3 import SAC
from citylearn.citylearn import CityLearnEnv
from citylearn.data import DataSet
from citylearn.wrappers import NormalizedObservationWrapper, StableBaselines3Wrapper


class DummyController:
    def __init__(self, env):
        self.env = env

    def predict(self, observations):
        return [[None] * len(self.env.action_names[0])]


schema = DataSet.get_schema(dataset_name)
schema['central_agent'] = True
schema['simulation_end_time_step'] = end
schema['reward_function'] = {'type': reward_type, 'attributes': {'signal': 'electricity_pricing'}}

env = CityLearnEnv(schema)
controller = DummyController(env)
observations = env.reset()
dummy_rewards = []
while not env.done:
    observations, reward, done, info = env.step(controller.predict(observations))
    dummy_rewards.append(reward[0])

env = CityLearnEnv(schema, episode_time_steps=24)
env = NormalizedObservationWrapper(env)
env = StableBaselines3Wrapper(env)
model = SAC('MlpPolicy', env, **sac_kwargs)
model.learn(total_timesteps=episodes * env.unwrapped.time_steps)

env.unwrapped.episode_time_steps = end + 1  # evaluate on the whole period
observations = env.reset()
evaluation_steps = 0
while not env.unwrapped.done:
    actions, _ = model.predict(observations, deterministic=True)
    observations, reward, done, info = env.step(actions)
    evaluation_steps += 1
kpis = env.unwrapped.evaluate()
"""


def reward_module(factor: float) -> types.ModuleType:
    module = types.ModuleType(MODULE)
    module.FACTOR = factor
    exec(compile(REWARD_MODULE, MODULE, "exec"), module.__dict__)  # noqa: S102 - the test's own text
    return module


def test_a_simbuild_way_program_runs_unchanged(cache, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, MODULE, reward_module(1.0))
    kwargs = {"policy_kwargs": {"net_arch": [16, 16]}, "batch_size": 16, "learning_starts": 10, "seed": 0,
              "device": "cpu"}
    ns = run(PROGRAM, dataset_name=LSTM, end=END, reward_type=f"{MODULE}.SignalReward", episodes=2,
             sac_kwargs=kwargs)
    env = ns["env"].unwrapped
    assert env.mirror.api == "2.1" and type(env.reward_function).__module__ == MODULE
    assert ns["model"].num_timesteps == 2 * 24 and ns["evaluation_steps"] == END
    assert env.time_steps == END + 1 and not ns["kpis"].empty

    # the DummyController's None actions are the ideal loads: the run equals one without device actions
    ideal = CityLearnEnv(LSTM, central_agent=True, simulation_end_time_step=END,
                         inactive_actions=["cooling_device", "heating_device"],
                         reward_function=sys.modules[MODULE].SignalReward,
                         reward_function_kwargs={"signal": "electricity_pricing"})
    ideal.reset()
    expected = [ideal.step([[0.0] * len(ideal.action_names[0])])[1][0] for _ in range(END)]
    np.testing.assert_array_equal(ns["dummy_rewards"], expected)
    assert sum(expected) < 0

    # the user doubles the reward in their own module: the program's result doubles
    monkeypatch.setitem(sys.modules, MODULE, reward_module(2.0))
    doubled = run(PROGRAM.split("env = CityLearnEnv(schema, episode_time_steps=24)")[0], dataset_name=LSTM, end=END,
                  reward_type=f"{MODULE}.SignalReward")
    np.testing.assert_allclose(doubled["dummy_rewards"], 2.0 * np.array(expected), rtol=1e-12)
