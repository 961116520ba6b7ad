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

import itertools
from collections.abc import Mapping, Sequence
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


# ---------------------------------------------------------------------------- discrete spaces (tabular agents)
def _bins(env: gym.Env, bin_sizes: Sequence[Mapping[str, int]] | None, default: int | None, kind: str) -> list[list[int]]:
    """Bins of every value of every agent: ``bin_sizes`` holds one ``{name: bins}`` per building (names not given
    get ``default``, 10 when None); a central agent's shared observations counted once, as upstream."""
    base = env.unwrapped
    count = len(base.buildings)
    if bin_sizes is not None and len(bin_sizes) != count:
        raise SchemaError(f"one bin-size dict per building is needed ({count}), got {len(bin_sizes)}",
                          column="bin_sizes")
    default = 10 if default is None else default
    sizes = [{} for _ in range(count)] if bin_sizes is None else [dict(s) for s in bin_sizes]
    names_of = base.observation_names_of if kind == "observation" else base.action_names_of
    shared = set(base.shared_observations) if kind == "observation" else set()
    per_building = [[sizes[i].get(n, default) for n in names_of(i) if i == 0 or n not in shared]
                    for i in range(count)]
    if base.central_agent:
        return [[b for building in per_building for b in building]]
    return [[sizes[i].get(n, default) for n in names_of(i)] for i in range(count)]


class DiscreteObservationWrapper(Forwarding, gym.ObservationWrapper):
    """Each observation digitised into ``bin_sizes`` bins (default ``default_bin_size``, 10) over its space's
    bounds, as upstream: ``np.digitize(x, linspace(low, high, bins), right=True)`` (0..bins; bins only above
    ``high``)."""

    def __init__(self, env: gym.Env, bin_sizes: Sequence[Mapping[str, int]] | None = None,
                 default_bin_size: int | None = None) -> None:
        super().__init__(env)
        self.bins = _bins(env, bin_sizes, default_bin_size, "observation")

    @property
    def observation_space(self) -> list[gym.spaces.MultiDiscrete]:
        return [gym.spaces.MultiDiscrete(b) for b in self.bins]

    def observation(self, observation: list[list[float]]) -> list[list[int]]:
        spaces = self.env.unwrapped.observation_space
        return [[int(np.digitize(x, np.linspace(lo, hi, n), right=True)) for x, lo, hi, n
                 in zip(values, space.low, space.high, bins, strict=True)]
                for values, space, bins in zip(observation, spaces, self.bins, strict=True)]


class DiscreteActionWrapper(Forwarding, gym.ActionWrapper):
    """Each action chosen as one of ``bin_sizes`` evenly spaced values over its space's bounds (index i of
    ``linspace(low, high, bins)``), as upstream."""

    def __init__(self, env: gym.Env, bin_sizes: Sequence[Mapping[str, int]] | None = None,
                 default_bin_size: int | None = None) -> None:
        super().__init__(env)
        self.bins = _bins(env, bin_sizes, default_bin_size, "action")

    @property
    def action_space(self) -> list[gym.spaces.MultiDiscrete]:
        return [gym.spaces.MultiDiscrete(b) for b in self.bins]

    def action(self, action: list[list[int]]) -> list[list[float]]:
        spaces = self.env.unwrapped.action_space
        return [[float(np.linspace(lo, hi, n)[int(i)]) for i, lo, hi, n in zip(indices, space.low, space.high, bins,
                                                                               strict=True)]
                for indices, space, bins in zip(action, spaces, self.bins, strict=True)]


class DiscreteSpaceWrapper(Forwarding, gym.Wrapper):
    """:class:`DiscreteObservationWrapper` then :class:`DiscreteActionWrapper`."""

    def __init__(self, env: gym.Env, observation_bin_sizes: Sequence[Mapping[str, int]] | None = None,
                 action_bin_sizes: Sequence[Mapping[str, int]] | None = None) -> None:
        env = DiscreteObservationWrapper(env, bin_sizes=observation_bin_sizes)
        super().__init__(DiscreteActionWrapper(env, bin_sizes=action_bin_sizes))


def mixed_radix(digits: Sequence[int], radices: Sequence[int]) -> int:
    """Position of ``digits`` in ``itertools.product(*(range(r) for r in radices))`` (the last digit fastest)."""
    index = 0
    for d, r in zip(digits, radices, strict=True):
        index = index * r + int(d)
    return index


class TabularQLearningObservationWrapper(Forwarding, gym.ObservationWrapper):
    """Each agent's digitised observations as one state index: its position among all combinations of the
    values 0..bins of each observation (upstream's enumeration; computed, not searched). The space is
    ``Discrete(combinations - 1)``, as upstream (the last combination, every value above its bound, has no row)."""

    def __init__(self, env: gym.Env, bin_sizes: Sequence[Mapping[str, int]] | None = None) -> None:
        super().__init__(DiscreteObservationWrapper(env, bin_sizes=bin_sizes))
        self.radices = [[n + 1 for n in bins] for bins in self.env.bins]

    @property
    def observation_space(self) -> list[gym.spaces.Discrete]:
        return [gym.spaces.Discrete(int(np.prod(r)) - 1) for r in self.radices]

    def observation(self, observation: list[list[int]]) -> list[list[int]]:
        return [[mixed_radix(o, r)] for o, r in zip(observation, self.radices, strict=True)]


class TabularQLearningActionWrapper(Forwarding, gym.ActionWrapper):
    """Each agent's action as one index over all combinations of its discretised actions."""

    def __init__(self, env: gym.Env, bin_sizes: Sequence[Mapping[str, int]] | None = None) -> None:
        super().__init__(DiscreteActionWrapper(env, bin_sizes=bin_sizes))
        self.combinations = [list(itertools.product(*(range(n) for n in bins))) for bins in self.env.bins]

    @property
    def action_space(self) -> list[gym.spaces.Discrete]:
        return [gym.spaces.Discrete(len(c)) for c in self.combinations]

    def action(self, action: list[list[int]]) -> list[list[int]]:
        return [list(c[int(a[0])]) for a, c in zip(action, self.combinations, strict=True)]


class TabularQLearningWrapper(Forwarding, gym.Wrapper):
    """The spaces :class:`~citylearn_env.compat.agents.q_learning.TabularQLearning` learns on: one ``Discrete``
    observation and action per agent (observation, then action wrapper, as upstream)."""

    def __init__(self, env: gym.Env, observation_bin_sizes: Sequence[Mapping[str, int]] | None = None,
                 action_bin_sizes: Sequence[Mapping[str, int]] | None = None) -> None:
        env = TabularQLearningObservationWrapper(env, bin_sizes=observation_bin_sizes)
        super().__init__(TabularQLearningActionWrapper(env, bin_sizes=action_bin_sizes))


# ---------------------------------------------------------------------------- RLlib
RAY_MISSING = "citylearn_env.compat: {name} needs ray: pip install 'ray[rllib]'"


class ClippedObservationWrapper(Forwarding, gym.ObservationWrapper):
    """Every agent's observations clipped to its observation space's bounds (upstream's wrapper in front of
    RLlib, whose spaces check values)."""

    def observation(self, observation: list[list[float]]) -> list[list[float]]:
        return [np.clip(np.array(o, dtype=np.float64), s.low, s.high).tolist()
                for o, s in zip(observation, self.env.observation_space, strict=True)]


def _need_ray(name: str) -> None:
    try:
        import ray  # noqa: F401
    except ImportError:
        raise ModuleNotFoundError(RAY_MISSING.format(name=name)) from None
    raise NotImplementedError(f"citylearn_env.compat: {name} is not mirrored yet (docs/compat.md, Not supported)")


class RLlibSingleAgentWrapper:
    """Upstream's RLlib single-agent wrapper: needs ray (one line naming ``pip install ray[rllib]``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        _need_ray(type(self).__name__)


class RLlibMultiAgentEnv:
    """Upstream's RLlib multi-agent environment: needs ray (one line naming ``pip install ray[rllib]``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        _need_ray(type(self).__name__)


__all__ = ["ClippedObservationWrapper", "DiscreteActionWrapper", "DiscreteObservationWrapper", "DiscreteSpaceWrapper",
           "NormalizedObservationWrapper", "Normalizer", "RLlibMultiAgentEnv", "RLlibSingleAgentWrapper",
           "StableBaselines3ActionWrapper", "StableBaselines3ObservationWrapper", "StableBaselines3RewardWrapper",
           "StableBaselines3Wrapper", "TabularQLearningActionWrapper", "TabularQLearningObservationWrapper",
           "TabularQLearningWrapper", "mixed_radix"]
