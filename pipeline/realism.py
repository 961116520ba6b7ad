"""Realism statistics of building load series (CityLearn building-CSV columns), for comparing a built district
with real EULP-derived houses (``benchmarks/realism.py``).

Every function is pure and takes hourly series of energy per hour (kWh); a month of one house is the unit the
benchmark compares. The electric-equivalent total converts thermal demands to electricity with fixed,
documented efficiencies (:data:`COOLING_COP`, :data:`HEATING_COP`, :data:`DHW_EFFICIENCY`) so that built and
real houses are converted alike.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

#: coefficient of performance of cooling and heating, and DHW heater efficiency, for the electric-equivalent
#: total (assumptions applied identically to every house; not the district's devices)
COOLING_COP = 3.0
HEATING_COP = 3.0
DHW_EFFICIENCY = 1.0


def hourly_peak_kwh(energy_kwh: Sequence[float] | pd.Series) -> float:
    """Largest hourly value [kWh in one hour] of an hourly energy series; 0 for an empty series."""
    values = np.asarray(energy_kwh, dtype=float)
    return float(values.max()) if values.size else 0.0


def energy_per_area_kwh_m2(energy_kwh: Sequence[float] | pd.Series, floor_area_m2: float) -> float:
    """Total energy of the series divided by the floor area [kWh/m2]; ValueError for a non-positive area."""
    if not floor_area_m2 > 0:
        raise ValueError(f"floor area must be > 0 m2, got {floor_area_m2}")
    return float(np.asarray(energy_kwh, dtype=float).sum()) / floor_area_m2


def electric_equivalent_kwh(non_shiftable_kwh: pd.Series, cooling_kwh: pd.Series, heating_kwh: pd.Series,
                            dhw_kwh: pd.Series) -> pd.Series:
    """Hourly electric-equivalent total [kWh]: plug loads + cooling / :data:`COOLING_COP` + heating /
    :data:`HEATING_COP` + DHW / :data:`DHW_EFFICIENCY` (all inputs in kWh per hour, thermal for the demands)."""
    return (non_shiftable_kwh + cooling_kwh / COOLING_COP + heating_kwh / HEATING_COP
            + dhw_kwh / DHW_EFFICIENCY)


def daily_load_factor(energy_kwh: Sequence[float] | pd.Series, hours_per_day: int = 24) -> float:
    """Mean over whole days of (the day's mean hourly load / the day's peak hourly load) [-, 0..1].

    The series starts at midnight and is cut to whole days; days with a zero peak are left out; NaN when no
    day is left.
    """
    values = np.asarray(energy_kwh, dtype=float)
    days = values[: values.size // hours_per_day * hours_per_day].reshape(-1, hours_per_day)
    peaks = days.max(axis=1)
    keep = peaks > 0
    if not keep.any():
        return float("nan")
    return float(np.mean(days[keep].mean(axis=1) / peaks[keep]))


def hour_of_day_profile(energy_kwh: Sequence[float] | pd.Series, hour: Sequence[int] | pd.Series) -> np.ndarray:
    """Normalised mean hour-of-day profile: the mean load of each hour of the day (``hour`` modulo 24, so the
    CityLearn 1..24 hour-ending labels and 0..23 labels both work), divided by the sum of the 24 means (the 24
    values sum to 1). ValueError when an hour of the day is missing or the total is zero."""
    frame = pd.DataFrame({"load": np.asarray(energy_kwh, dtype=float), "hour": np.asarray(hour) % 24})
    means = frame.groupby("hour")["load"].mean().reindex(range(24))
    if means.isna().any():
        raise ValueError(f"hours of the day without data: {means.index[means.isna()].tolist()}")
    total = float(means.sum())
    if not total > 0:
        raise ValueError("the profile sums to zero")
    return (means / total).to_numpy()


def profile_l1_distance(profile: Sequence[float], reference: Sequence[float]) -> float:
    """L1 distance of two normalised hour-of-day profiles (each summing to 1) [-, 0 = same shape, 2 =
    disjoint]."""
    a, b = np.asarray(profile, dtype=float), np.asarray(reference, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"profiles differ in length: {a.shape} vs {b.shape}")
    return float(np.abs(a - b).sum())


def median_profile(profiles: Sequence[Sequence[float]]) -> np.ndarray:
    """Hour-by-hour median of normalised profiles, renormalised to sum 1."""
    median = np.median(np.asarray(profiles, dtype=float), axis=0)
    return median / median.sum()


def percentile_band(values: Sequence[float], low: float = 5.0, high: float = 95.0) -> tuple[float, float, float]:
    """(``low`` percentile, median, ``high`` percentile) of the finite values (linear interpolation);
    NaNs when there is none."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    if not finite.size:
        return float("nan"), float("nan"), float("nan")
    p_low, median, p_high = np.percentile(finite, [low, 50.0, high])
    return float(p_low), float(median), float(p_high)


def in_band(value: float, band: tuple[float, float, float]) -> bool | None:
    """Whether ``value`` lies inside [band low, band high]; None when the band is unknown (NaN)."""
    low, _, high = band
    if not (np.isfinite(low) and np.isfinite(high)):
        return None
    return bool(low <= value <= high)


def median_ratio_pct(built: Sequence[float], real_median: float) -> float:
    """(median of ``built`` / ``real_median`` - 1) x 100 [%]; NaN when the real median is 0 or unknown."""
    if not (np.isfinite(real_median) and real_median != 0):
        return float("nan")
    return (float(np.median(np.asarray(built, dtype=float))) / real_median - 1.0) * 100.0


def cooling_degree_days(temperature_c: Sequence[float] | pd.Series, base_c: float = 18.3,
                        hours_per_day: int = 24) -> float:
    """Cooling degree-days [K day] of hourly outdoor temperatures [degC]: the sum over hours of the excess over
    ``base_c`` (18.3 degC = 65 F, the US convention) divided by ``hours_per_day``. What drives a house's cooling
    from outside: two months compared on cooling should be compared on this too."""
    values = np.asarray(temperature_c, dtype=float)
    return float(np.clip(values - base_c, 0.0, None).sum() / hours_per_day)
