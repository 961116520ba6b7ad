"""Time-step bookkeeping with upstream's names (mirrors ``citylearn.base``: ``Environment``, ``EpisodeTracker``).

:class:`EpisodeTracker` is a read-only view of the native environment's episode (no state of its own);
:class:`Environment` is the small base of the compat agents (a time-step counter, seed, step length).
"""

from __future__ import annotations

import random
import uuid
from collections.abc import Mapping
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from citylearn_env.config import DistrictConfig
from citylearn_env.env import CityLearnEnv as NativeEnv
from citylearn_env.settings import Behaviour


class CompatEnv(Protocol):
    """What the building, device and episode views read of :class:`citylearn_env.compat.citylearn.CityLearnEnv`."""

    native: NativeEnv
    series_names: frozenset[str]
    settings: Behaviour

    @property
    def config(self) -> DistrictConfig: ...

    @property
    def time_step(self) -> int: ...

    @property
    def seconds_per_time_step(self) -> float: ...

    @property
    def episode_tracker(self) -> EpisodeTracker: ...

    def building_series(self, name: str, index: int) -> np.ndarray: ...

    def observation_names_of(self, index: int) -> list[str]: ...

    def action_names_of(self, index: int) -> list[str]: ...

    def observations_of(self, index: int) -> list[float]: ...

    def building_observation_space(self, index: int) -> gym.spaces.Box: ...

    def building_action_space(self, index: int) -> gym.spaces.Box: ...

    def building_observations(self, index: int) -> Mapping[str, float]: ...

    def base_metadata(self) -> dict[str, Any]: ...

    def ignores_dynamics(self, index: int) -> bool: ...

    def set_ignore_dynamics(self, index: int, flag: bool) -> None: ...


class EpisodeTracker:
    """The current episode of a compat environment's native environment (read when asked, so it follows a
    rebuilt one), with upstream's names. Time steps are absolute rows of the data files
    (``simulation_start_time_step`` .. ``simulation_end_time_step``, inclusive); read only."""

    def __init__(self, env: CompatEnv) -> None:
        self._env = env

    @property
    def _native(self) -> NativeEnv:
        return self._env.native

    @property
    def episode(self) -> int:
        """Index of the current episode (0 for the first ``reset``)."""
        return max(self._native.episode, 0)

    @property
    def episode_time_steps(self) -> int:
        """Time steps in the current episode (it has ``episode_time_steps - 1`` step calls)."""
        return self._native.episode_length

    @property
    def episode_start_time_step(self) -> int:
        """First data row of the current episode."""
        return self._native.config.simulation_start_time_step + int(getattr(self._native, "episode_start", 0))

    @property
    def episode_end_time_step(self) -> int:
        """Last data row of the current episode (inclusive)."""
        return self.episode_start_time_step + self.episode_time_steps - 1

    @property
    def simulation_start_time_step(self) -> int:
        """First data row of the simulation range."""
        return self._native.config.simulation_start_time_step

    @property
    def simulation_end_time_step(self) -> int:
        """Last data row of the simulation range (inclusive)."""
        return self._native.config.simulation_end_time_step

    @property
    def simulation_time_steps(self) -> int:
        """Time steps in the simulation range."""
        return self.simulation_end_time_step - self.simulation_start_time_step + 1


class Environment:
    """Base of the compat agents: ``time_step`` counter, ``random_seed``, ``seconds_per_time_step`` [s], a unique
    ``uid`` and the shared ``episode_tracker``."""

    def __init__(self, seconds_per_time_step: float | None = None, random_seed: int | None = None,
                 episode_tracker: EpisodeTracker | None = None, **kwargs: Any) -> None:
        self.seconds_per_time_step = 3600.0 if seconds_per_time_step is None else float(seconds_per_time_step)
        self.random_seed = random.randint(0, 100_000_000) if random_seed is None else random_seed
        self.episode_tracker = episode_tracker
        self.uid = uuid.uuid4().hex
        self.time_step = 0

    def get_metadata(self) -> dict[str, Any]:
        """``uid``, ``random_seed`` and ``seconds_per_time_step`` [s]."""
        return {"uid": self.uid, "random_seed": self.random_seed, "seconds_per_time_step": self.seconds_per_time_step}

    def next_time_step(self) -> None:
        """Advance ``time_step`` by one."""
        self.time_step += 1

    def reset_time_step(self) -> None:
        """Set ``time_step`` to 0."""
        self.time_step = 0

    def reset(self) -> None:
        """Back to the initial state (``time_step`` 0)."""
        self.reset_time_step()


__all__ = ["CompatEnv", "Environment", "EpisodeTracker"]
