"""Device physics as small pure functions over numpy arrays (one element per building).

Energies are kWh per time step, powers kW, temperatures degC. One storage model serves both the thermal tanks
and the battery (:func:`storage_charge`); the battery adds power limits, efficiency curves and capacity fade
(:func:`battery_charge`). Formulas follow CityLearn 2.1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from citylearn_env.state import TankParams

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


def heater_efficiency(efficiency: np.ndarray, n_steps: int) -> np.ndarray:
    """Electric heater: a constant thermal efficiency [-] over ``n_steps`` steps (its "COP"), (B, n_steps)."""
    return np.repeat(np.asarray(efficiency, dtype=np.float64).reshape(-1, 1), n_steps, axis=1)


def conversion_table(kinds: Sequence[str], efficiency: Sequence[float], target_c: Sequence[float],
                     outdoor_c: np.ndarray, *, cooling: bool) -> np.ndarray:
    """COP of each building's heat pump (Carnot at ``outdoor_c`` [degC], (B, N), toward its ``target_c``
    [degC]) or efficiency of its electric heater (``kinds[b] == "ElectricHeater"``) [-], (B, N)."""
    rows = []
    for i, (kind, eff, target) in enumerate(zip(kinds, efficiency, target_c, strict=True)):
        if kind == "ElectricHeater":
            rows.append(heater_efficiency(np.array([eff]), outdoor_c.shape[1])[0])
        elif cooling:
            rows.append(carnot_cop_cooling(outdoor_c[i], target, eff))
        else:
            rows.append(carnot_cop_heating(outdoor_c[i], target, eff))
    return np.stack(rows)


def device_output(demand: np.ndarray, nominal_power: np.ndarray, cop: np.ndarray,
                  supply: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Serve a thermal ``demand`` [kWh] with a device of ``nominal_power`` [kW electric] and ``cop`` [-], drawing
    at most ``supply`` [kWh electric] (inf outside an outage). Returns (thermal energy delivered [kWh],
    electricity used [kWh]); the delivery is min(demand, min(supply, P) * COP) for a demand >= 0 and the
    electricity is never negative."""
    delivered = np.minimum(demand, np.minimum(supply, nominal_power) * cop)
    return delivered, np.maximum(0.0, delivered / cop)


def pv_generation(nominal_kw: np.ndarray, yield_w_per_kw: np.ndarray) -> np.ndarray:
    """PV AC energy [kWh per 1-h step] = nominal power [kW] * specific yield [W/kW] / 1000 (positive)."""
    return nominal_kw * yield_w_per_kw / 1000.0


@dataclass(frozen=True, eq=False)
class Curve:
    """Piecewise-linear curves of B buildings: points ``xs``/``ys`` (B, K), padded with each curve's last
    point, and the slopes of their K - 1 segments (0 for zero-width segments)."""

    xs: np.ndarray
    ys: np.ndarray
    slopes: np.ndarray
    #: 0 .. B - 1, for indexing one point per building (derived)
    rows: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "rows", np.arange(len(self.xs)))

    @classmethod
    def from_points(cls, curves: Sequence[Sequence[tuple[float, float]]]) -> Curve:
        """Stack one ((x, y), ...) point sequence per building."""
        width = max(len(c) for c in curves)
        padded = [list(c) + [c[-1]] * (width - len(c)) for c in curves]
        xs = np.array([[pt[0] for pt in c] for c in padded], dtype=np.float64)
        ys = np.array([[pt[1] for pt in c] for c in padded], dtype=np.float64)
        dx, dy = np.diff(xs, axis=1), np.diff(ys, axis=1)
        return cls(xs, ys, np.divide(dy, dx, out=np.zeros_like(dy), where=dx != 0))


def interpolate_curve(x: np.ndarray, curve: Curve, *, extrapolate_first_segment: bool = False) -> np.ndarray:
    """Piecewise-linear y(x) per building.

    The segment is the one ending at the first point with x_k >= x (segment 0 when x <= x_0). Beyond the last
    point the last y is held, or -- ``extrapolate_first_segment``, CityLearn 2.1's behaviour -- segment 0 is
    extrapolated.
    """
    above = curve.xs >= x[:, None]
    segment = above.argmax(axis=1)  # 0 when nothing is found: segment 0
    segment -= segment > 0
    rows = curve.rows if len(x) == len(curve.rows) else np.arange(len(x))
    y = curve.ys[rows, segment] + (x - curve.xs[rows, segment]) * curve.slopes[rows, segment]
    if not extrapolate_first_segment:
        y = np.where(x > curve.xs[:, -1], curve.ys[:, -1], y)
    return y


def storage_charge(
    soc_prev: np.ndarray, energy: np.ndarray, capacity: np.ndarray, loss: np.ndarray, one_way: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Charge (energy > 0) or discharge (< 0) a storage; return (new soc [-], energy balance [kWh]).

    Standby loss first: E0 = soc_prev * C * (1 - loss). Charging stores ``energy * one_way`` (capped at C),
    discharging removes ``energy / one_way`` (floored at 0). The balance is the device-side energy:
    equal to ``energy`` unless the storage limits clipped it. ``one_way`` is the one-way efficiency
    (the square root of the round-trip efficiency); ``loss`` the fraction of the content lost per step.
    """
    e0 = np.maximum(0.0, soc_prev * capacity * (1.0 - loss))
    e1 = np.where(energy >= 0, np.minimum(e0 + energy * one_way, capacity), np.maximum(0.0, e0 + energy / one_way))
    soc = e1 / np.maximum(capacity, 1e-6)
    delta = e1 - e0
    balance = np.where(delta >= 0, delta / one_way, delta * one_way)
    return soc, balance


@dataclass(frozen=True, eq=False)
class BatteryParams:
    """Batteries of B buildings, (B,) arrays: nominal ``capacity`` [kWh], ``nominal_power`` [kW], initial
    round-trip ``efficiency`` [-], standby ``loss_coefficient`` [fraction per step], ``capacity_loss_coefficient``
    [fraction of capacity per full cycle], ``depth_of_discharge`` [-], ``initial_soc`` [-]; the
    ``power_efficiency`` curve (x = |energy| / nominal power, y = round-trip efficiency) and the
    ``capacity_power`` curve (x = state of charge, y = fraction of nominal power available)."""

    capacity: np.ndarray
    nominal_power: np.ndarray
    efficiency: np.ndarray
    loss_coefficient: np.ndarray
    capacity_loss_coefficient: np.ndarray
    depth_of_discharge: np.ndarray
    initial_soc: np.ndarray
    power_efficiency: Curve
    capacity_power: Curve
    #: 1 / nominal power [1/kW], 0 where the nominal power is 0 (derived)
    inverse_nominal_power: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        p = self.nominal_power
        object.__setattr__(self, "inverse_nominal_power", np.divide(1.0, p, out=np.zeros_like(p), where=p > 0))


def battery_limit(energy: np.ndarray, soc_prev: np.ndarray, booked: np.ndarray, battery: BatteryParams,
                  efficiency_prev: np.ndarray, capacity_prev: np.ndarray, *,
                  extrapolate_first_segment: bool = False) -> np.ndarray:
    """Clip a battery request [kWh] to its capacity-power curve, nominal power (less ``booked`` energy), free
    (degraded) capacity ``capacity_prev`` [kWh] and depth of discharge (at the previous efficiency)."""
    capacity, nominal = battery.capacity, battery.nominal_power
    e0 = np.maximum(0.0, soc_prev * capacity * (1.0 - battery.loss_coefficient))
    soc0 = e0 / np.maximum(capacity, 1e-6)
    p_max = nominal * interpolate_curve(soc0, battery.capacity_power,
                                        extrapolate_first_segment=extrapolate_first_segment)
    charge = np.minimum(np.minimum(p_max, nominal - booked), np.minimum(capacity_prev - e0, energy))
    floor = -np.maximum((soc_prev - (1.0 - battery.depth_of_discharge)) * capacity * np.sqrt(efficiency_prev), 0.0)
    discharge = np.maximum(np.maximum(-p_max, floor), energy)
    return np.where(energy >= 0, charge, discharge)


def battery_charge(energy: np.ndarray, soc_prev: np.ndarray, booked: np.ndarray, battery: BatteryParams,
                   efficiency_prev: np.ndarray, capacity_prev: np.ndarray, *,
                   extrapolate_first_segment: bool = False,
                   efficiency_from_request: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One battery step. Returns (soc [-], balance [kWh], round-trip efficiency [-], degraded capacity [kWh]).

    The request is clipped by :func:`battery_limit`; the step's efficiency comes from the power-efficiency
    curve at |clipped energy| / nominal power (``efficiency_from_request``, CityLearn 2.5: at min(|request|,
    capacity-power-curve limit) / nominal power); the storage model is :func:`storage_charge` with one-way
    efficiency sqrt(efficiency); capacity fades by capacity_loss_coefficient * C * |balance| / (2 C_prev) [kWh].
    """
    e = battery_limit(energy, soc_prev, booked, battery, efficiency_prev, capacity_prev,
                      extrapolate_first_segment=extrapolate_first_segment)
    basis = np.abs(e)
    if efficiency_from_request:
        soc0 = np.maximum(0.0, soc_prev * (1.0 - battery.loss_coefficient))
        p_max = battery.nominal_power * interpolate_curve(soc0, battery.capacity_power,
                                                          extrapolate_first_segment=extrapolate_first_segment)
        basis = np.minimum(np.abs(energy), p_max)
    x = basis * battery.inverse_nominal_power
    efficiency = interpolate_curve(x, battery.power_efficiency, extrapolate_first_segment=extrapolate_first_segment)
    soc, balance = storage_charge(soc_prev, e, battery.capacity, battery.loss_coefficient, np.sqrt(efficiency))
    fade = np.divide(battery.capacity_loss_coefficient * battery.capacity * np.abs(balance), 2.0 * capacity_prev,
                     out=np.zeros_like(balance), where=capacity_prev > 0)
    return soc, balance, efficiency, np.maximum(capacity_prev - fade, 0.0)


class EndUseStep(NamedTuple):
    """What one end use did at one step, (B,) each [kWh]: the device's thermal output ``from_device`` and the
    electricity ``booked`` (device plus storage charging), the tank's new ``soc`` [-] and its ``balance``
    (device side: > 0 charging), the heat the tank gave (``from_storage``) and took (``to_storage``). The
    tank fields are None when no building has a tank."""

    from_device: np.ndarray
    booked: np.ndarray
    soc: np.ndarray | None = None
    balance: np.ndarray | None = None
    from_storage: np.ndarray | None = None
    to_storage: np.ndarray | None = None


def serve_end_use(demand: np.ndarray, nominal_power: np.ndarray, cop: np.ndarray, supply: np.ndarray,
                  action: np.ndarray, scale: np.ndarray, soc_prev: np.ndarray, tank: TankParams | None) -> EndUseStep:
    """Serve one end use's thermal ``demand`` [kWh] with its device (``nominal_power`` [kW electric], ``cop``
    [-], drawing at most ``supply`` [kWh electric]) and its storage ``tank`` (None: no building has one).

    The storage ``action`` [-] asks for ``action * scale`` [kWh]. Where it is negative the tank discharges first
    (at most the demand and its output limit) and the device serves the rest; otherwise the device serves the
    demand and the tank charges with the device's remaining power (at most its input limit). If any building
    discharges, every building's device output is computed again from the demand left after its tank's heat.
    """
    q_dev, booked = device_output(demand, nominal_power, cop, supply)
    if tank is None:
        return EndUseStep(q_dev, booked)
    request = action * scale
    discharge = action < 0
    room = np.where(supply == np.inf, np.inf, supply - booked)  # the supply left after the device [kWh]
    charge = np.minimum(np.minimum(room, nominal_power - booked) * cop, request)
    ask = np.where(discharge, np.maximum(-demand, request), np.minimum(charge, tank.max_input_power))
    ask = np.maximum(ask, -tank.max_output_power)
    soc, balance = storage_charge(soc_prev, ask, tank.capacity, tank.loss_coefficient, tank.one_way_efficiency)
    from_storage = -np.minimum(balance, 0.0)
    if discharge.any():
        q_dev, booked = device_output(demand - from_storage, nominal_power, cop, supply)
    to_storage = np.maximum(balance, 0.0)
    return EndUseStep(q_dev, booked + to_storage / cop, soc, balance, from_storage, to_storage)


def heat_pump_demand(action: np.ndarray, available: np.ndarray, nominal_power: np.ndarray, cop: np.ndarray,
                     use: np.ndarray) -> np.ndarray:
    """The thermal demand [kWh] a heat pump serves for a device ``action`` [-, fraction of the nominal power]:
    ``min(max(a, 0) * P, P) * COP`` where the hvac mode makes the device ``available`` (0 where it does not),
    NaN where the action is not used (``use`` False: the data set's demand stays). (B,) arrays; ``nominal_power``
    P [kW electric], ``cop`` [-] at the step."""
    q = np.minimum(np.maximum(action, 0.0) * nominal_power, nominal_power)
    return np.where(use, np.where(available, q, 0.0) * cop, np.nan)
