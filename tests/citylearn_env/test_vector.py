"""N copies stepped together give, copy by copy, exactly what N separate environments give."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, rewards
from citylearn_env.example import write_example_district
from citylearn_env.vector import CityLearnVectorEnv


@pytest.fixture(scope="module")
def schema(tmp_path_factory):
    return write_example_district(tmp_path_factory.mktemp("vec"), n_buildings=2, hours=48, seed=5)


def test_copies_match_single_envs(schema):
    n = 4
    vec = CityLearnVectorEnv(schema, n)
    singles = [CityLearnEnv(schema) for _ in range(n)]
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (n, *singles[0].observation_space.shape)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(obs[i], env.reset(seed=0)[0])
    rng = np.random.default_rng(0)
    low, high = singles[0].action_space.low, singles[0].action_space.high
    for _ in range(47):
        actions = rng.uniform(low, high, size=(n, low.size))
        obs, rewards, terminated, truncated, _ = vec.step(actions)
        for i, env in enumerate(singles):
            o, r, term, trunc, _ = env.step(actions[i])
            np.testing.assert_allclose(obs[i], o, rtol=1e-6)
            assert rewards[i] == pytest.approx(r, rel=1e-9, abs=1e-12)
            assert terminated[i] == term and truncated[i] == trunc
    assert terminated.all()
    # NEXT_STEP autoreset: the call after the last step resets every copy
    obs, rewards, terminated, _, _ = vec.step(np.zeros((n, low.size)))
    assert not terminated.any() and np.all(rewards == 0)
    np.testing.assert_array_equal(obs[0], singles[0].reset(seed=0)[0])


def test_spaces_are_batched(schema):
    vec = CityLearnVectorEnv(schema, 3)
    assert vec.action_space.shape == (3, 4)
    assert vec.single_action_space.shape == (4,)
    assert vec.observation_space.shape[0] == 3


REWARD_CLASSES = {cls: name for name, cls in reversed(rewards.REWARDS.items())}  # each class once


def test_a_reward_that_overrides_call_is_not_batchable():
    for cls in REWARD_CLASSES:
        if cls.__call__ is not rewards.Reward.__call__:
            assert not cls.batchable, cls.__name__


@pytest.mark.parametrize("name", sorted(REWARD_CLASSES.values()))
def test_declared_batching_is_what_the_vector_env_does_and_matches_single_envs(schema, name):
    """Every registered reward: the vector env batches exactly the rewards declared ``batchable`` (one call
    over all copies' buildings), and either way each copy's reward equals a separate environment's."""
    n = 3
    vec = CityLearnVectorEnv(schema, n, reward_function=name)
    assert vec.batched_reward == rewards.REWARDS[name].batchable
    singles = [CityLearnEnv(schema, reward_function=name) for _ in range(n)]
    vec.reset(seed=2)
    for env in singles:
        env.reset(seed=2)
    rng = np.random.default_rng(2)
    low, high = singles[0].action_space.low, singles[0].action_space.high
    for _ in range(12):
        actions = rng.uniform(low, high, size=(n, low.size))
        _, values, *_ = vec.step(actions)
        expected = [env.step(actions[i])[1] for i, env in enumerate(singles)]
        np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-12)
