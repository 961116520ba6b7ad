"""Wrappers with upstream's names over list-of-lists observations (mirrors ``citylearn.wrappers``):
``NormalizedObservationWrapper`` and the Stable-Baselines3 ones.

``NormalizedObservationWrapper`` computes what the native
:class:`citylearn_env.wrappers.NormalizedObservationWrapper` computes, per agent: hour, day_type and month become
(cos, sin) pairs, then every value is min-max scaled with the environment's observation bounds. ``clip=False``
(the default) keeps upstream's unclipped values; their space is then declared ``Box(-inf, inf)``, as the native
wrapper does, because the bounds are estimates that values can leave. ``clip=True`` clips to [0, 1].

Every wrapper here hands unknown public attributes to the environment it wraps (``env.evaluate()``,
``env.buildings``, ``env.time_steps`` ...), as the gym 0.26 wrappers of CityLearn 2.1 did.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.version import program_call, reset_form, step_form
from citylearn_env.dataset import PERIODS, periodic_encoding
from citylearn_env.errors import SchemaError


class Forwarding:
    """Mixin: a public attribute the wrapper lacks is read from the wrapped environment; ``reset`` and ``step``
    answer in the API of the program's CityLearn version (2.1: the observations alone, four step values) when the
    program calls them, in gymnasium's when gymnasium, Stable-Baselines3 or this package does
    (:mod:`citylearn_env.compat.version`)."""

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or name == "env":
            raise AttributeError(name)
        return getattr(self.env, name)

    def _api(self) -> str:
        mirror = getattr(self.env.unwrapped, "mirror", None)
        return mirror.api if mirror is not None else "gymnasium"

    def reset(self, **kwargs: Any) -> Any:
        return reset_form(self._api(), super().reset(**kwargs), program_call())

    def step(self, action: Any) -> Any:
        return step_form(self._api(), super().step(action), program_call())


class Normalizer:
    """One agent's normalisation: ``kinds`` (bare observation names), ``low`` and ``high`` (float32 bounds),
    ``period`` of day_type [days]; see the module docstring."""

    def __init__(self, kinds: Sequence[str], low: np.ndarray, high: np.ndarray, day_type_period: float,
                 clip: bool) -> None:
        periods = dict(PERIODS, day_type=float(day_type_period))
        low, high = np.asarray(low, np.float64), np.asarray(high, np.float64)
        self.plan = [periods.get(k) for k in kinds]
        self.names: list[str] = []
        lo: list[float] = []
        hi: list[float] = []
        for kind, period, a, b in zip(kinds, self.plan, low, high, strict=True):
            self.names += [f"{kind}_cos", f"{kind}_sin"] if period else [kind]
            lo += [-1.0, -1.0] if period else [a]
            hi += [1.0, 1.0] if period else [b]
        self.low = np.array(lo)
        span = np.array(hi) - self.low
        self.span = np.where(span > 0, span, 1.0)
        self.clip = clip

    def __call__(self, values: Sequence[float]) -> list[float]:
        out: list[float] = []
        for x, period in zip(values, self.plan, strict=True):
            if period is None:
                out.append(float(x))
            else:
                sin, cos = periodic_encoding(float(x), period)
                out += [float(cos), float(sin)]
        scaled = (np.array(out) - self.low) / self.span
        if self.clip:
            scaled = np.clip(scaled, 0.0, 1.0)
        return scaled.astype(np.float32).tolist()

    def space(self) -> gym.spaces.Box:
        low, high = (0.0, 1.0) if self.clip else (-np.inf, np.inf)
        return gym.spaces.Box(low, high, shape=(len(self.names),), dtype=np.float32)


class NormalizedObservationWrapper(Forwarding, gym.ObservationWrapper):
    """Periodic encoding and min-max scaling of every agent's observations (see the module docstring);
    ``day_type_period`` [days] defaults to the environment's setting (8 in CityLearn 2.1, 7 corrected)."""

    def __init__(self, env: gym.Env, *, clip: bool = False, day_type_period: float | None = None) -> None:
        super().__init__(env)
        base = env.unwrapped
        period = base.settings.wrapper_day_type_period if day_type_period is None else day_type_period
        names = base.observation_names
        self.normalizers = [Normalizer(n, s.low, s.high, period, clip)
                            for n, s in zip(names, base.observation_space, strict=True)]

    @property
    def observation_space(self) -> list[gym.spaces.Box]:
        return [n.space() for n in self.normalizers]

    @property
    def observation_names(self) -> list[list[str]]:
        return [list(n.names) for n in self.normalizers]

    def observation(self, observation: list[list[float]]) -> list[list[float]]:
        return [n(o) for n, o in zip(self.normalizers, observation, strict=True)]


class StableBaselines3ActionWrapper(Forwarding, gym.ActionWrapper):
    """The central agent's action space as one Box; a flat action ``a`` is sent as ``[a]``."""

    @property
    def action_space(self) -> gym.spaces.Box:
        return self.env.action_space[0]

    def action(self, action: Any) -> list[Any]:
        return [action]


class StableBaselines3RewardWrapper(Forwarding, gym.RewardWrapper):
    """The central agent's reward as a float."""

    def reward(self, reward: list[float]) -> float:
        return reward[0]


class StableBaselines3ObservationWrapper(Forwarding, gym.ObservationWrapper):
    """The central agent's observations as one float32 array."""

    @property
    def observation_space(self) -> gym.spaces.Box:
        return self.env.observation_space[0]

    def observation(self, observation: list[list[float]]) -> np.ndarray:
        return np.array(observation[0], dtype=np.float32)


class StableBaselines3Wrapper(Forwarding, gym.Wrapper):
    """A central-agent environment as Stable-Baselines3 expects it: Box spaces, flat actions, float rewards."""

    def __init__(self, env: gym.Env) -> None:
        if not env.unwrapped.central_agent:
            raise SchemaError("StableBaselines3Wrapper needs central_agent=True", column="central_agent")
        env = StableBaselines3ActionWrapper(env)
        env = StableBaselines3RewardWrapper(env)
        env = StableBaselines3ObservationWrapper(env)
        super().__init__(env)


__all__ = ["NormalizedObservationWrapper", "Normalizer", "StableBaselines3ActionWrapper",
           "StableBaselines3ObservationWrapper", "StableBaselines3RewardWrapper", "StableBaselines3Wrapper"]
