"""N independent copies of a district stepped together as one gymnasium ``VectorEnv``.

The copies are one district of N x B buildings inside: every device, storage and LSTM update is a single
array operation over all copies, which is what makes large N cheap. Each copy keeps its own observation
vector, its own reward object (reward state is per copy) and its own action block. All copies share the
episode schedule, so they terminate together; autoreset follows gymnasium's NEXT_STEP mode (the call after
a terminal step resets every copy and ignores its actions).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from citylearn_env import rewards
from citylearn_env.config import DistrictConfig
from citylearn_env.env import CityLearnEnv
from citylearn_env.schema import load_schema
from citylearn_env.settings import Behaviour, resolve

if TYPE_CHECKING:  # pandas is imported where a table is built (importing citylearn_env stays light)
    import pandas as pd


class _CopyView(Mapping):
    """The step observations of one copy: every (B,) array sliced out of the (N x B,) arrays."""

    def __init__(self, view: Mapping[str, np.ndarray], part: slice):
        self._view, self._part = view, part

    def __getitem__(self, name: str) -> np.ndarray:
        return self._view[name][self._part]

    def __iter__(self) -> Iterator[str]:
        return iter(self._view)

    def __len__(self) -> int:
        return len(self._view)


class CityLearnVectorEnv(VectorEnv):
    """``num_envs`` copies of the district of ``schema``; batched Box observations, actions and rewards."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, schema: str | Path | Mapping[str, Any] | DistrictConfig, num_envs: int, *,
                 settings: Behaviour | str | None = None, reward_function: Any = None):
        settings = resolve(settings)
        config = schema if isinstance(schema, DistrictConfig) else load_schema(schema, settings=settings)
        self.single = CityLearnEnv(config, settings=settings, reward_function=reward_function, central_agent=True)
        self.num_envs = num_envs
        self.n_buildings = len(config.buildings)
        copies = tuple(
            dataclasses.replace(b, name=f"{b.name}#{i}") for i in range(num_envs) for b in config.buildings
        )
        self.inner = CityLearnEnv(config.replace(buildings=copies), settings=settings,
                                  reward_function="default", central_agent=True)
        self.single_observation_space = self.single.observation_space
        self.single_action_space = self.single.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        pairs = len(self.single.layout.pairs)
        self._obs_index = (np.arange(num_envs)[:, None] * pairs + self.single.layout.central_index[None, :])
        spec = reward_function if reward_function is not None else config.reward_function
        context = self.single.reward_context
        probe = rewards.make_reward(spec, context, settings=settings)
        self._batched = None
        self._rewards = []
        if probe.batchable:  # central value = sum (or mean) of per-building values (rewards.Reward.batchable)
            batched_context = dataclasses.replace(self.inner.reward_context, central_agent=False)
            self._batched = rewards.make_reward(spec, batched_context, settings=settings)
            self._batched_context = batched_context
            self._mean = probe.central_aggregate == "mean"
        else:
            self._rewards = [rewards.make_reward(spec, context, settings=settings) for _ in range(num_envs)]
        self._parts = [slice(i * self.n_buildings, (i + 1) * self.n_buildings) for i in range(num_envs)]
        self._needs_reset = False

    @property
    def batched_reward(self) -> bool:
        """True when the reward is computed in one call over all copies' buildings: the reward class declares
        itself :attr:`~citylearn_env.rewards.Reward.batchable`; otherwise one reward object per copy."""
        return self._batched is not None

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every copy (one shared episode); return the (N, obs) float32 observations and ``{}``."""
        self.inner.reset(seed=seed, options=options)
        for reward in self._rewards:
            reward.reset(self.single.reward_context)
        if self._batched is not None:
            self._batched.reset(self._batched_context)
        self._needs_reset = False
        return self._observations(), {}

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy with its row of ``actions`` (N, act); (observations, rewards, terminated,
        truncated, info) batched over the copies (NEXT_STEP autoreset after the last step)."""
        if self._needs_reset:
            obs, info = self.reset()
            zeros = np.zeros(self.num_envs, dtype=bool)
            return obs, np.zeros(self.num_envs), zeros, zeros.copy(), info
        t = self.inner.advance(np.asarray(actions, dtype=np.float64).reshape(-1))
        view = self.inner.step_observations()
        if self._batched is not None:
            per_building = np.asarray(self._batched(view)[0]).reshape(self.num_envs, self.n_buildings)
            values = per_building.mean(axis=1) if self._mean else per_building.sum(axis=1)
        else:
            values = np.array([float(np.sum(r(_CopyView(view, part))[0]))
                               for r, part in zip(self._rewards, self._parts, strict=True)])
        done = t == self.inner.episode_length - 1
        self._needs_reset = done
        terminated = np.full(self.num_envs, done)
        return self._observations(), values, terminated, np.zeros(self.num_envs, dtype=bool), {}

    def _observations(self) -> np.ndarray:
        return self.inner.flat_observations()[self._obs_index].astype(np.float32)

    def history(self) -> pd.DataFrame:
        """The inner history: buildings are named ``<building>#<copy>``."""
        return self.inner.history(include_district=False)


def make_vector_env(schema: Any, num_envs: int, **kwargs: Any) -> gym.vector.VectorEnv:
    """Convenience constructor (also what ``gym.make_vec`` style users want)."""
    return CityLearnVectorEnv(schema, num_envs, **kwargs)
