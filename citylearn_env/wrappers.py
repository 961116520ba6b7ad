"""Wrappers: upstream-style normalisation and a PettingZoo ParallelEnv for independent agents."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.dataset import PERIODS, periodic_encoding
from citylearn_env.env import CityLearnEnv


class NormalizedObservationWrapper(gym.ObservationWrapper):
    """Periodic hour/day_type/month as (cos, sin) pairs, then min-max scaling of everything to [0, 1].

    The bounds are the environment's observation bounds, *estimated* over the simulation range (upstream's
    estimates: a net consumption, a delivered demand or an LSTM temperature can leave them -- on upstream's
    2023 LSTM data sets a random-action week goes up to 1.36 of the range beyond [0, 1]). So that every
    observation lies in the declared space:

    * ``clip=True`` (the default): every scaled value is clipped to [0, 1] and the space is ``Box(0, 1)``;
    * ``clip=False``: the values are upstream's, unclipped (``NormalizedObservationWrapper`` of CityLearn), and
      the space is declared ``Box(-inf, inf)`` -- most values lie in [0, 1], but the space says no more than
      is true (a ``Box(0, 1)`` that the values leave would mislead agents that trust it; gymnasium's
      ``check_env`` does not look at the values of a whole episode).

    The day_type period is the environment's ``settings.wrapper_day_type_period`` (8 in CityLearn 2.1, 7
    corrected) unless ``day_type_period`` is given.
    """

    def __init__(self, env: gym.Env, *, day_type_period: float | None = None, clip: bool = True):
        super().__init__(env)
        self.clip = bool(clip)
        base = env.unwrapped
        if day_type_period is None:
            day_type_period = base.settings.wrapper_day_type_period
        periods = dict(PERIODS, day_type=float(day_type_period))
        kinds = base.layout.names(central=True)  # bare observation names, to find the periodic ones
        names = base.observation_names
        low, high = base.observation_space.low.astype(np.float64), base.observation_space.high.astype(np.float64)
        self._plan: list[tuple[int, float | None]] = []
        out_names, lo, hi = [], [], []
        for i, (kind, name) in enumerate(zip(kinds, names, strict=True)):
            if kind in periods:
                self._plan.append((i, periods[kind]))
                out_names += [f"{name}_cos", f"{name}_sin"]
                lo += [-1.0, -1.0]
                hi += [1.0, 1.0]
            else:
                self._plan.append((i, None))
                out_names.append(name)
                lo.append(low[i])
                hi.append(high[i])
        self.observation_names = out_names
        self._lo = np.array(lo)
        span = np.array(hi) - self._lo
        self._span = np.where(span > 0, span, 1.0)
        low, high = (0.0, 1.0) if self.clip else (-np.inf, np.inf)
        self.observation_space = gym.spaces.Box(low, high, shape=(len(out_names),), dtype=np.float32)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        values = []
        for i, period in self._plan:
            x = float(observation[i])
            if period is None:
                values.append(x)
            else:
                sin, cos = periodic_encoding(x, period)
                values += [float(cos), float(sin)]
        scaled = (np.array(values) - self._lo) / self._span
        if self.clip:
            scaled = np.clip(scaled, 0.0, 1.0)
        return scaled.astype(np.float32)


class NormalizedActionWrapper(gym.ActionWrapper):
    """The agent acts in [0, 1] per action; mapped linearly onto the environment's [low, high]."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        #: the environment's action bounds: an agent action x in [0, 1] maps to ``low + x * span``
        self.low = env.action_space.low.astype(np.float64)
        self.span = env.action_space.high.astype(np.float64) - self.low
        self.action_space = gym.spaces.Box(0.0, 1.0, shape=env.action_space.shape, dtype=np.float32)

    def action(self, action: np.ndarray) -> np.ndarray:
        return self.low + np.asarray(action, dtype=np.float64) * self.span


def parallel_env(schema: Any, **kwargs: Any) -> Any:
    """A PettingZoo ParallelEnv with one agent per building (its own observations, actions and reward)."""
    from pettingzoo import ParallelEnv  # lazy: pettingzoo is an optional dependency (the rl extra)

    class CityLearnParallelEnv(ParallelEnv):
        metadata = {"name": "citylearn_env_parallel_v0", "render_modes": []}

        def __init__(self):
            self.env = CityLearnEnv(schema, central_agent=False, **kwargs)
            env = self.env
            self.possible_agents = list(env.building_names)
            self.agents = list(self.possible_agents)
            lo, hi = env.observation_bounds
            self._obs_slices = dict(zip(self.possible_agents, env.layout.building_slices, strict=True))
            self._act_index = {a: [i for i, (_, b) in enumerate(env.action_pairs) if b == k]
                               for k, a in enumerate(self.possible_agents)}
            self._obs_spaces = {a: gym.spaces.Box(lo[s].astype(np.float32), hi[s].astype(np.float32),
                                                  dtype=np.float32) for a, s in self._obs_slices.items()}
            self._act_spaces = {a: gym.spaces.Box(env.action_space.low[ix], env.action_space.high[ix],
                                                  dtype=np.float32) for a, ix in self._act_index.items()}

        def observation_space(self, agent: str) -> gym.spaces.Box:
            return self._obs_spaces[agent]

        def action_space(self, agent: str) -> gym.spaces.Box:
            return self._act_spaces[agent]

        def _split(self) -> dict[str, np.ndarray]:
            flat = self.env.flat_observations()
            return {a: flat[s].astype(np.float32) for a, s in self._obs_slices.items()}

        def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
            self.agents = list(self.possible_agents)
            self.env.reset(seed=seed, options=options)
            return self._split(), {a: {} for a in self.agents}

        def step(self, actions: dict[str, Any]) -> tuple[dict, ...]:
            vector = np.zeros(self.env.action_space.shape)
            for a, ix in self._act_index.items():
                vector[ix] = np.asarray(actions[a], dtype=np.float64).reshape(-1)
            _, reward, terminated, truncated, info = self.env.step(vector)
            rewards = info.get("building_rewards", np.full(len(self.agents), reward / len(self.agents)))
            obs = self._split()
            out = ({a: float(r) for a, r in zip(self.agents, rewards, strict=True)},
                   {a: terminated for a in self.agents}, {a: truncated for a in self.agents},
                   {a: {} for a in self.agents})
            if terminated or truncated:
                self.agents = []
            return (obs, *out)

    return CityLearnParallelEnv()
