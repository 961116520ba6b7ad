"""Device physics as small pure functions over numpy arrays (one element per building).

Energies are kWh per time step, powers kW, temperatures degC. One storage model serves both the thermal tanks
and the battery (:func:`storage_charge`); the battery adds power limits, efficiency curves and capacity fade
(:func:`battery_charge`). Formulas follow CityLearn 2.1.
"""

from __future__ import annotations

import numpy as np

MAX_COP = 20.0


def carnot_cop_cooling(outdoor_c: np.ndarray, target_c: np.ndarray, efficiency: np.ndarray) -> np.ndarray:
    """Cooling COP [-] = efficiency * (T_target + 273.15) / (T_outdoor - T_target).

    A negative or larger-than-20 COP (outdoor air colder than the supply target) is replaced by 20,
    as CityLearn does.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        cop = efficiency * (target_c + 273.15) / (outdoor_c - target_c)
    return np.where((cop < 0) | (cop > MAX_COP) | ~np.isfinite(cop), MAX_COP, cop)


def carnot_cop_heating(outdoor_c: np.ndarray, target_c: np.ndarray, efficiency: np.ndarray) -> np.ndarray:
    """Heating COP [-] = efficiency * (T_target + 273.15) / (T_target - T_outdoor), replaced by 20 outside (0, 20]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        cop = efficiency * (target_c + 273.15) / (target_c - outdoor_c)
    return np.where((cop < 0) | (cop > MAX_COP) | ~np.isfinite(cop), MAX_COP, cop)


def pv_generation(nominal_kw: np.ndarray, yield_w_per_kw: np.ndarray) -> np.ndarray:
    """PV AC energy [kWh per 1-h step] = nominal power [kW] * specific yield [W/kW] / 1000 (positive)."""
    return nominal_kw * yield_w_per_kw / 1000.0


def curve_slopes(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Slopes of the segments of (B, K) padded curves, (B, K - 1); 0 for zero-width segments."""
    dx, dy = np.diff(xs, axis=1), np.diff(ys, axis=1)
    return np.divide(dy, dx, out=np.zeros_like(dy), where=dx != 0)


def interpolate_curve(x: np.ndarray, xs: np.ndarray, ys: np.ndarray, slopes: np.ndarray | None = None, *,
                      compat: bool = True) -> np.ndarray:
    """Piecewise-linear y(x) per building; ``xs``/``ys`` are (B, K) curve points padded with the last point.

    The segment is the one ending at the first point with x_k >= x (segment 0 when x <= x_0). Beyond the last
    point CityLearn 2.1 extrapolates segment 0 (``compat=True``); otherwise the last y is held.
    ``slopes`` may be passed precomputed (:func:`curve_slopes`).
    """
    if slopes is None:
        slopes = curve_slopes(xs, ys)
    above = xs >= x[:, None]
    found = above.any(axis=1)
    segment = np.maximum(above.argmax(axis=1), 1) - 1  # argmax is 0 when nothing is found: segment 0
    rows = np.arange(len(x))
    y = ys[rows, segment] + (x - xs[rows, segment]) * slopes[rows, segment]
    if not compat:
        y = np.where(found, y, ys[:, -1])
    return y


def storage_charge(
    soc_prev: np.ndarray, energy: np.ndarray, capacity: np.ndarray, loss: np.ndarray, one_way: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Charge (energy > 0) or discharge (< 0) a storage; return (new soc [-], energy balance [kWh]).

    Standby loss first: E0 = soc_prev * C * (1 - loss). Charging stores ``energy * one_way`` (capped at C),
    discharging removes ``energy / one_way`` (floored at 0). The balance is the device-side energy:
    equal to ``energy`` unless the storage limits clipped it.
    """
    e0 = np.maximum(0.0, soc_prev * capacity * (1.0 - loss))
    e1 = np.where(energy >= 0, np.minimum(e0 + energy * one_way, capacity), np.maximum(0.0, e0 + energy / one_way))
    soc = e1 / np.maximum(capacity, 1e-6)
    delta = e1 - e0
    balance = np.where(delta >= 0, delta / one_way, delta * one_way)
    return soc, balance


def battery_limit(
    energy: np.ndarray,
    soc_prev: np.ndarray,
    booked: np.ndarray,
    battery: dict[str, np.ndarray],
    state: dict[str, np.ndarray],
    *,
    compat: bool = True,
) -> np.ndarray:
    """Clip a battery request [kWh] to its power curve, nominal power, free capacity and depth of discharge."""
    capacity, nominal = battery["capacity"], battery["nominal_power"]
    e0 = np.maximum(0.0, soc_prev * capacity * (1.0 - battery["loss_coefficient"]))
    soc0 = e0 / np.maximum(capacity, 1e-6)
    p_max = nominal * interpolate_curve(soc0, battery["cp_x"], battery["cp_y"], battery["cp_slope"], compat=compat)
    charge = np.minimum(np.minimum(p_max, nominal - booked), np.minimum(state["capacity"] - e0, energy))
    floor = -np.maximum((soc_prev - (1.0 - battery["depth_of_discharge"])) * capacity
                        * np.sqrt(state["efficiency"]), 0.0)
    discharge = np.maximum(np.maximum(-p_max, floor), energy)
    return np.where(energy >= 0, charge, discharge)


def battery_charge(
    energy: np.ndarray,
    soc_prev: np.ndarray,
    booked: np.ndarray,
    battery: dict[str, np.ndarray],
    state: dict[str, np.ndarray],
    *,
    compat: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One battery step. Returns (soc, balance [kWh], efficiency [-], degraded capacity [kWh]).

    ``battery`` holds the per-building parameters (capacity, nominal_power, inverse_nominal_power (0 where
    the nominal power is 0), loss_coefficient, capacity_loss_coefficient, depth_of_discharge, curve points
    pe_x/pe_y and cp_x/cp_y with their segment slopes pe_slope/cp_slope); ``state`` the
    previous round-trip ``efficiency`` and degraded ``capacity``. The efficiency of the step comes from the
    power-efficiency curve at |clipped energy| / nominal power.
    """
    capacity = battery["capacity"]
    e = battery_limit(energy, soc_prev, booked, battery, state, compat=compat)
    x = np.abs(e) * battery["inverse_nominal_power"]
    efficiency = interpolate_curve(x, battery["pe_x"], battery["pe_y"], battery["pe_slope"], compat=compat)
    soc, balance = storage_charge(soc_prev, e, capacity, battery["loss_coefficient"], np.sqrt(efficiency))
    degraded = state["capacity"]
    fade = np.divide(battery["capacity_loss_coefficient"] * capacity * np.abs(balance), 2.0 * degraded,
                     out=np.zeros_like(balance), where=degraded > 0)
    return soc, balance, efficiency, np.maximum(degraded - fade, 0.0)
