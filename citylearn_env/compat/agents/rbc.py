"""Rule-based controllers with upstream's API and rules (mirrors ``citylearn.agents.rbc`` of CityLearn 2.1:
``RBC``, ``HourRBC``, ``BasicRBC``, ``OptimizedRBC``, ``BasicBatteryRBC``).

An hour rule maps each action name to a value per ``hour`` observation (1..24; hour h is the hour ending at h):
storage actions are fractions of capacity (> 0 charge, < 0 discharge), device actions fractions of nominal
power. Every action whose name contains ``storage`` follows the storage rule; ``cooling_device`` and
``heating_device`` their own; any other action name is refused, as upstream.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym

from citylearn_env.compat.agents.base import Agent
from citylearn_env.errors import SchemaError

#: an hour band table: ((first hour, last hour, value), ...), hours 1..24 inclusive
Bands = tuple[tuple[int, int, float], ...]
HOURS = range(1, 25)


def hourly(bands: Bands) -> dict[int, float]:
    """hour (1..24) -> value of the band holding it (0 outside every band)."""
    return {h: next((v for a, b, v in bands if a <= h <= b), 0.0) for h in HOURS}


class RBC(Agent):
    """Base rule-based controller."""


class HourRBC(RBC):
    """Actions looked up by the ``hour`` observation in ``action_map``: ``{hour: value}`` for every action,
    ``{action name: {hour: value}}``, or one such dict per agent; random actions without a map."""

    def __init__(self, env: gym.Env, action_map: Any = None, **kwargs: Any) -> None:
        super().__init__(env, **kwargs)
        self.action_map = action_map

    @property
    def action_map(self) -> list[dict[str, Mapping[int, float]]] | None:
        """One ``{action name: {hour: value}}`` per agent (None: random actions)."""
        return self._action_map

    @action_map.setter
    def action_map(self, action_map: Any) -> None:
        self._action_map = self.expand(action_map)

    def expand(self, action_map: Any) -> list[dict[str, Mapping[int, float]]] | None:
        """``action_map`` in its per-agent form, checked to cover every action."""
        if action_map is None:
            return None
        if isinstance(action_map, Sequence):
            if len(action_map) != len(self.action_names):
                raise SchemaError(f"one action map per agent is needed ({len(self.action_names)})", column="action_map")
            maps = [dict(m) for m in action_map]
        elif action_map and isinstance(next(iter(action_map.values())), Mapping):
            maps = [dict(action_map) for _ in self.action_names]
        else:
            maps = [{n: action_map for n in names} for names in self.action_names]
        for i, (m, names) in enumerate(zip(maps, self.action_names, strict=True)):
            missing = sorted(set(names) - set(m))
            if missing:
                raise SchemaError(f"no map for actions {missing} of agent {i}", column="action_map")
        return maps

    def predict(self, observations: list[list[float]], deterministic: bool | None = None) -> list[list[float]]:
        """Each agent's actions at its ``hour`` observation."""
        if self.action_map is None:
            return super().predict(observations, deterministic=deterministic)
        actions = []
        for m, names, obs_names, obs in zip(self.action_map, self.action_names, self.observation_names, observations,
                                            strict=True):
            hour = obs[obs_names.index("hour")]
            actions.append([m[a][hour] for a in names])
        self.actions = actions
        self.next_time_step()
        return actions


class BandRBC(HourRBC):
    """An :class:`HourRBC` whose default map comes from band tables: :attr:`STORAGE`, :attr:`COOLING`,
    :attr:`HEATING` (``action_map`` given: used instead)."""

    STORAGE: Bands = ()
    COOLING: Bands = ()
    HEATING: Bands = ()

    def expand(self, action_map: Any) -> list[dict[str, Mapping[int, float]]] | None:
        if action_map is None:
            action_map = {n: self.rule(n) for names in self.action_names for n in names}
        return super().expand(action_map)

    def rule(self, name: str) -> dict[int, float]:
        """hour -> value of action ``name``."""
        if "storage" in name:
            return hourly(self.STORAGE)
        if name == "cooling_device":
            return hourly(self.COOLING)
        if name == "heating_device":
            return hourly(self.HEATING)
        raise SchemaError(f"unknown action name {name!r} for {type(self).__name__}", column="action_map")


class BasicRBC(BandRBC):
    """Charge storages 9.1 % of capacity per hour from 22:00 to 08:00, discharge 8 % otherwise; cooling device at
    40 % / 80 % and heating device at 80 % / 40 % of nominal power in those hours."""

    STORAGE = ((9, 21, -0.08), (1, 8, 0.091), (22, 24, 0.091))
    COOLING = ((9, 21, 0.8), (1, 8, 0.4), (22, 24, 0.4))
    HEATING = ((9, 21, 0.4), (1, 8, 0.8), (22, 24, 0.8))


class OptimizedRBC(BasicRBC):
    """BasicRBC's grid-searched variant: five hour bands (7-15, 16-18, 19-22, 23-24, 1-6). Storage values as
    upstream's code (-0.0044 in 16-18, where its docstring says 4.4 %)."""

    STORAGE = ((7, 15, -0.02), (16, 18, -0.0044), (19, 22, -0.024), (23, 24, 0.034), (1, 6, 0.05532))
    COOLING = ((7, 15, 0.7), (16, 18, 0.6), (19, 22, 0.8), (23, 24, 0.4), (1, 6, 0.2))
    HEATING = ((7, 15, 0.3), (16, 18, 0.4), (19, 22, 0.6), (23, 24, 0.7), (1, 6, 0.8))


class BasicBatteryRBC(BasicRBC):
    """Charge storages 11 % of capacity per hour from 06:00 to 14:00 (solar hours), discharge 6.7 % otherwise."""

    STORAGE = ((6, 14, 0.11), (1, 5, -0.067), (15, 24, -0.067))
    COOLING = ((6, 14, 0.7), (1, 5, 0.3), (15, 24, 0.3))
    HEATING = ((6, 14, 0.3), (1, 5, 0.7), (15, 24, 0.7))


__all__ = ["RBC", "BandRBC", "BasicBatteryRBC", "BasicRBC", "HourRBC", "OptimizedRBC", "hourly"]
