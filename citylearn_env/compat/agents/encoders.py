"""Observation encoders of upstream's learning agents (mirrors ``citylearn.preprocessing``).

An encoder maps one observation value to zero, one or several encoded values; ``encoder * x`` (either side)
applies it, as upstream. The arithmetic keeps upstream's operand types (the space bounds stay float32 scalars) so
that encoded values are bit-equal to upstream's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


class Encoder:
    """Base encoder: ``encoder * x`` and ``x * encoder`` call :meth:`encode`."""

    def encode(self, x: Any) -> Any:
        raise NotImplementedError

    def __mul__(self, x: Any) -> Any:
        return self.encode(x)

    def __rmul__(self, x: Any) -> Any:
        return self.encode(x)


class NoNormalization(Encoder):
    """The value unchanged."""

    def encode(self, x: Any) -> Any:
        return x


class PeriodicNormalization(Encoder):
    """A cyclic value x (hour, month) of period ``x_max`` as ``[(sin θ + 1)/2, (cos θ + 1)/2]`` (CityLearn 2.2+;
    ``scaled=False``: ``[sin θ, cos θ]``, CityLearn 2.1.2), θ = 2πx/x_max [rad] (sine first, as upstream)."""

    def __init__(self, x_max: float, scaled: bool = True) -> None:
        self.x_max = x_max
        self.scaled = scaled

    def encode(self, x: Any) -> np.ndarray:
        theta = 2 * np.pi * x / self.x_max
        if not self.scaled:
            return np.array([np.sin(theta), np.cos(theta)])
        return np.array([(np.sin(theta) + 1) / 2.0, (np.cos(theta) + 1) / 2.0])


class OnehotEncoding(Encoder):
    """A categorical value as the row of the identity matrix at its position in ``classes``."""

    def __init__(self, classes: Sequence[Any]) -> None:
        self.classes = list(classes)

    def encode(self, x: Any) -> np.ndarray:
        return np.eye(len(self.classes))[np.array(self.classes) == x][0]


class Normalize(Encoder):
    """Min-max scaling ``(x - x_min)/(x_max - x_min)``; 0 when the bounds are equal."""

    def __init__(self, x_min: Any, x_max: Any) -> None:
        self.x_min = x_min
        self.x_max = x_max

    def encode(self, x: Any) -> Any:
        if self.x_min == self.x_max:
            return 0
        return (x - self.x_min) / (self.x_max - self.x_min)


class RemoveFeature(Encoder):
    """Drops the value (None, filtered out by the agents)."""

    def encode(self, x: Any) -> None:
        return None


def encode(encoders: Sequence[Encoder], values: Sequence[float]) -> np.ndarray:
    """One agent's observation ``values`` through its ``encoders`` (one per value), flattened, removed values
    dropped: a float64 array."""
    parts: list[float] = []
    # Python floats, as upstream's object-array product hands its encoders
    for encoder, x in zip(encoders, np.array(values, dtype=float).tolist(), strict=True):
        out = encoder * x
        if out is None:
            continue
        parts.extend(np.ravel(out).tolist())
    return np.array(parts, dtype=float)


def default_encoders(names: Sequence[str], space: Any, scaled_periodic: bool = True) -> list[Encoder]:
    """Upstream's default encoders of one agent's observations: hour and month periodic with the space's upper
    bound as period (``scaled_periodic``: see :class:`PeriodicNormalization`), day_type one-hot over 1..8,
    daylight_savings_status one-hot over 0/1, the rest min-max scaled with the space's bounds."""
    encoders: list[Encoder] = []
    for i, name in enumerate(names):
        if name in ("month", "hour"):
            encoders.append(PeriodicNormalization(space.high[i], scaled_periodic))
        elif name == "day_type":
            encoders.append(OnehotEncoding([1, 2, 3, 4, 5, 6, 7, 8]))
        elif name == "daylight_savings_status":
            encoders.append(OnehotEncoding([0, 1]))
        else:
            encoders.append(Normalize(space.low[i], space.high[i]))
    return encoders


__all__ = ["Encoder", "NoNormalization", "Normalize", "OnehotEncoding", "PeriodicNormalization", "RemoveFeature",
           "default_encoders", "encode"]
