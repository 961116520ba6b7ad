"""An RBC and a Stable-Baselines3 SAC program written the CityLearn 2.1 way (``BasicRBC.learn``, then SAC through
``NormalizedObservationWrapper`` and ``StableBaselines3Wrapper``, trained for ``2 * env.unwrapped.time_steps``),
run unchanged but for its imports (its own ``reset``/``step`` calls get CityLearn 2.1's API, SB3's calls gymnasium's
while it trains); its actions and KPIs equal the native environment's (the RBC replayed, the SAC
trained the same way on the native env and its native normalising wrapper)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from citylearn_env.wrappers import NormalizedObservationWrapper as NativeNormalized
from tests.citylearn_env.compat.conftest import PHASE_1, native_env, replay, run

sb3 = pytest.importorskip("stable_baselines3", reason="stable-baselines3 (the rl extra) is not installed")

END = 47  # two days: 48 time steps, 47 step calls
SAC_KWARGS = {"policy_kwargs": {"net_arch": [32, 32]}, "batch_size": 32, "learning_starts": 20, "seed": 0,
              "device": "cpu"}

PROGRAM = """
from stable_baselines3 import SAC
from citylearn.agents.rbc import BasicRBC
from citylearn.citylearn import CityLearnEnv
from citylearn.wrappers import NormalizedObservationWrapper, StableBaselines3Wrapper

env = CityLearnEnv(dataset_name, central_agent=True, simulation_end_time_step=end)
rbc = BasicRBC(env)
rbc.learn(episodes=1)
rbc_kpis = env.evaluate()

env = CityLearnEnv(dataset_name, central_agent=True, simulation_end_time_step=end)
env = NormalizedObservationWrapper(env)
env = StableBaselines3Wrapper(env)
model = SAC('MlpPolicy', env, **sac_kwargs)
model.learn(total_timesteps=2 * env.unwrapped.time_steps)

observations = env.reset()
sac_actions = []
while not env.unwrapped.terminated:
    actions, _ = model.predict(observations, deterministic=True)
    sac_actions.append(actions)
    observations, _, done, _ = env.step(actions)

sac_kpis = env.unwrapped.evaluate()
"""


@pytest.fixture(scope="module")
def program(cache) -> dict:
    """The program's namespace after it ran (torch on one thread: the two SAC runs are compared bit for bit)."""
    import torch

    torch.set_num_threads(1)
    return run(PROGRAM, dataset_name=PHASE_1, end=END, sac_kwargs=SAC_KWARGS)


def test_basic_rbc_applies_its_hour_rule_and_equals_the_native_env(program) -> None:
    rbc = program["rbc"]
    names = rbc.observation_names[0]
    env = rbc.env
    actions = [np.asarray(a) for a in rbc.actions[0][:-1]]
    assert len(actions) == END
    native = native_env(PHASE_1, central_agent=True, simulation_end_time_step=END)
    rewards, _ = replay(native, actions)
    hours = native.data("hour")[0]
    for t, a in enumerate(actions):  # chosen from the observation at t: 9..21 discharge 8 %, else charge 9.1 %
        assert np.all(a == (-0.08 if 9 <= hours[t] <= 21 else 0.091)), t
    assert names.index("hour") == 2
    np.testing.assert_array_equal([r[0] for r in env.rewards[1:]], rewards)
    pd.testing.assert_frame_equal(program["rbc_kpis"], native.evaluate())


def test_sac_trains_two_episodes_and_equals_sac_on_the_native_env(program) -> None:
    model, env = program["model"], program["env"]
    assert env.unwrapped.time_steps == END + 1  # known before any reset: SAC.learn got 2 episodes, not 0 steps
    assert model.num_timesteps == 2 * (END + 1)
    assert env.observation_space.shape == (63,) and env.action_space.shape == (5,)

    native = native_env(PHASE_1, central_agent=True, simulation_end_time_step=END)
    wrapped = NativeNormalized(native, clip=False)
    native_model = sb3.SAC("MlpPolicy", wrapped, **SAC_KWARGS)
    native_model.learn(total_timesteps=2 * (END + 1))
    observations, _ = wrapped.reset()
    native_actions = []
    while native.t < native.episode_length - 1:
        actions, _ = native_model.predict(observations, deterministic=True)
        native_actions.append(actions)
        observations, *_ = wrapped.step(actions)
    np.testing.assert_array_equal(np.array(program["sac_actions"]), np.array(native_actions))
    pd.testing.assert_frame_equal(program["sac_kpis"], native.evaluate())


def test_wrapped_env_forwards_upstream_attributes(program) -> None:
    env = program["env"]
    assert env.time_steps == END + 1 and env.central_agent
    assert env.buildings[0].name == "Building_1"
    assert len(env.observation_names[0]) == 63 and env.observation_names[0][0] == "month_cos"
