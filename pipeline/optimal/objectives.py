"""The oracle's objectives: the SimBuild paper's storage objectives (``citylearn_env.kpis.objectives``, same
definitions) and weighted sums of them.

* cost [$] = sum over buildings and steps of max(net, 0) x price (exports earn nothing);
* emissions [kg] = sum of max(net, 0) x carbon intensity;
* consumption [kWh] = sum of max(net, 0);
* average_daily_peak [kW] = (sum over days d of max over the steps of d of the district net) x 24 / T, days in
  blocks of 24 steps from the episode start, T the number of steps (1-h steps: kWh per step = kW).

A weighted sum is ``{name: weight}``; ``normalise`` divides each weight by the objective's no-control value, so
that the sum weighs ratios to the baseline (as the paper's KPIs do) instead of mixed units.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pipeline.errors import InputError

OBJECTIVES = ("cost", "emissions", "consumption", "average_daily_peak")
#: objectives summed over buildings and steps of the grid import (the LP's per-building import variables)
IMPORT_OBJECTIVES = ("cost", "emissions", "consumption")
PEAK = "average_daily_peak"
DAY_STEPS = 24


def weights_of(objective: str | Mapping[str, float]) -> dict[str, float]:
    """``objective`` (a name or ``{name: weight}``) as weights of :data:`OBJECTIVES` (unknown names and
    negative or all-zero weights are refused: :class:`pipeline.errors.InputError` naming the known ones)."""
    spec = {objective: 1.0} if isinstance(objective, str) else dict(objective)
    unknown = sorted(set(spec) - set(OBJECTIVES))
    if unknown:
        hint = " (discomfort is not a storage objective: the oracle moves storage, not the heat pump)" \
            if "discomfort" in unknown else ""
        raise InputError(f"unknown objective(s) {unknown}; known: {', '.join(OBJECTIVES)}{hint}", column="objective")
    weights = {k: float(v) for k, v in spec.items()}
    if any(v < 0 or not np.isfinite(v) for v in weights.values()) or not any(weights.values()):
        raise InputError(f"objective weights must be finite, >= 0 and not all 0, got {weights}", column="objective")
    return {k: weights.get(k, 0.0) for k in OBJECTIVES}


def normalised(weights: Mapping[str, float], baseline: Mapping[str, float]) -> dict[str, float]:
    """``weights`` divided by the no-control ``baseline`` values (an objective whose baseline is 0 keeps its
    weight: there is nothing to compare it with)."""
    return {k: (w / baseline[k] if baseline[k] not in (0.0,) and np.isfinite(baseline[k]) else w)
            for k, w in weights.items()}


def daily_peak(district: np.ndarray, steps_per_day: int = DAY_STEPS) -> float:
    """Average daily peak [kW] of a district net series (T,) [kWh per 1-h step]."""
    n = district.size
    if n == 0:
        return float("nan")
    peaks = [district[i:i + steps_per_day].max() for i in range(0, n, steps_per_day)]
    return float(np.sum(peaks) * steps_per_day / n)


def values(net: np.ndarray, price: np.ndarray, carbon: np.ndarray) -> dict[str, float]:
    """The four objectives of a net consumption ``net`` (B, T) [kWh] with ``price`` [$ / kWh] and ``carbon``
    [kg / kWh] (B, T)."""
    grid = np.clip(net, 0.0, None)
    return {"cost": float((grid * price).sum()), "emissions": float((grid * carbon).sum()),
            "consumption": float(grid.sum()), PEAK: daily_peak(net.sum(axis=0))}


def weighted(objectives: Mapping[str, float], weights: Mapping[str, float]) -> float:
    """Sum of weight x objective over the objectives with a weight (the others may be NaN)."""
    return float(sum(w * objectives[k] for k, w in weights.items() if w))


def import_coefficients(weights: Mapping[str, float], price: np.ndarray, carbon: np.ndarray) -> np.ndarray:
    """Objective coefficient of each building's grid import [objective units per kWh], (B, T)."""
    return weights["cost"] * price + weights["emissions"] * carbon + weights["consumption"]
