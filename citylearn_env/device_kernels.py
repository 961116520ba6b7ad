"""Compiled one-step device physics of :mod:`citylearn_env.devices`: the battery (:func:`battery_charge_into`),
an end use's device and tank (:func:`serve_end_use_into`) and a heat pump's demand from its action
(:func:`heat_pump_demand`), one loop over the buildings each, for :class:`citylearn_env.district.District`
(and its :class:`~citylearn_env.thermal.ThermalModel`) when numba is installed.

:mod:`citylearn_env.devices` is the reference: vectorised numpy functions, one array operation each, the
plain install's path. A district of a few buildings spends most of a step on the fixed cost of those small
operations (about 1 us each, some 40 per battery step), so with numba the district calls these kernels
instead: the same formulas in the same order, per building, in one compiled call. Results are identical to
the numpy functions' (no fused multiply-add, no reordering: numba compiles without fast-math; ``error_model
= "numpy"``: a division by zero gives inf or NaN as in numpy). ``min``/``max`` are NaN-propagating as
``np.minimum``/``np.maximum`` (:func:`_min`, :func:`_max`).

Units as in :mod:`citylearn_env.devices`: energies kWh per step, powers kW, states of charge and efficiencies
as fractions. numba is imported lazily by :func:`get_kernels`; this module itself needs numpy only.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from citylearn_env import devices
from citylearn_env.devices import BatteryParams
from citylearn_env.state import TankParams

_KERNELS: DeviceKernels | bool | None = None


def _min(a, b):  # pragma: no cover - compiled by numba
    """np.minimum of two floats: the smaller one, NaN if ``a`` is NaN, else ``b`` when ``b`` is NaN."""
    return a if (a <= b or a != a) else b


def _max(a, b):  # pragma: no cover - compiled by numba
    """np.maximum of two floats: the larger one, NaN if either is NaN (``a`` first)."""
    return a if (a >= b or a != a) else b


def _interpolate(x, xs, ys, slopes, b, extrapolate_first_segment):  # pragma: no cover - compiled by numba
    """:func:`citylearn_env.devices.interpolate_curve` of building ``b`` at ``x``: the segment ending at the
    first point with x_k >= x (segment 0 when x <= x_0 or when there is none), beyond the last point the last y
    unless ``extrapolate_first_segment``."""
    last = xs.shape[1] - 1
    segment = 0
    for k in range(last + 1):
        if xs[b, k] >= x:
            segment = k
            break
    if segment > 0:
        segment -= 1
    y = ys[b, segment] + (x - xs[b, segment]) * slopes[b, segment]
    if not extrapolate_first_segment and x > xs[b, last]:
        y = ys[b, last]
    return y


def _store(soc_prev, energy, capacity, loss, one_way):  # pragma: no cover - compiled by numba
    """:func:`citylearn_env.devices.storage_charge` of one storage: (soc [-], balance [kWh])."""
    e0 = _max(0.0, soc_prev * capacity * (1.0 - loss))
    if energy >= 0:
        e1 = _min(e0 + energy * one_way, capacity)
    else:
        e1 = _max(0.0, e0 + energy / one_way)
    soc = e1 / _max(capacity, 1e-6)
    delta = e1 - e0
    balance = delta / one_way if delta >= 0 else delta * one_way
    return soc, balance


def _device(demand, nominal_power, cop, supply):  # pragma: no cover - compiled by numba
    """:func:`citylearn_env.devices.device_output` of one device: (delivered [kWh], electricity [kWh])."""
    delivered = _min(demand, _min(supply, nominal_power) * cop)
    return delivered, _max(0.0, delivered / cop)


def _serve_end_use(demand, nominal_power, cop, supply, action, scale, soc_prev, capacity, loss, one_way,
                   max_input, max_output, has_tank, q_dev, booked, soc, balance, from_storage,
                   to_storage):  # pragma: no cover - compiled by numba
    """:func:`citylearn_env.devices.serve_end_use` over (B,) arrays (the tank's parameters unpacked; with
    ``has_tank`` False neither they nor the tank outputs are touched), written into the (B,) outputs
    ``q_dev`` (from_device), ``booked``, ``soc``, ``balance``, ``from_storage`` and ``to_storage``. An output
    may be the same memory as ``soc_prev`` (each building's inputs are read before its outputs are written)."""
    n = demand.shape[0]
    discharging = False
    for b in range(n):
        d, p, k, s0 = demand[b], nominal_power[b], cop[b], supply[b]
        q, e = _device(d, p, k, s0)
        if has_tank:
            a = action[b]
            request = a * scale[b]
            room = math.inf if s0 == math.inf else s0 - e
            if a < 0:
                discharging = True
                ask = _max(-d, request)
            else:
                ask = _min(_min(_min(room, p - e) * k, request), max_input[b])
            ask = _max(ask, -max_output[b])
            new_soc, bal = _store(soc_prev[b], ask, capacity[b], loss[b], one_way[b])
            soc[b], balance[b] = new_soc, bal
            from_storage[b] = -_min(bal, 0.0)
            to_storage[b] = _max(bal, 0.0)
        q_dev[b], booked[b] = q, e
    if has_tank:
        for b in range(n):
            if discharging:  # as the numpy function: every building's device again once any tank discharges
                q_dev[b], booked[b] = _device(demand[b] - from_storage[b], nominal_power[b], cop[b], supply[b])
            booked[b] = booked[b] + to_storage[b] / cop[b]


def _battery_charge(energy, soc_prev, booked, efficiency_prev, capacity_prev, capacity, nominal,
                    inverse_nominal, loss, capacity_loss, depth_of_discharge, cp_xs, cp_ys, cp_slopes,
                    pe_xs, pe_ys, pe_slopes, extrapolate_first_segment, efficiency_from_request,
                    soc, balance, efficiency, degraded):  # pragma: no cover - compiled by numba
    """:func:`citylearn_env.devices.battery_charge` (with :func:`~citylearn_env.devices.battery_limit`) over
    (B,) arrays; the capacity-power (``cp_*``) and power-efficiency (``pe_*``) curves as the (B, K) points and
    slopes of :class:`~citylearn_env.devices.Curve`. Writes the (B,) outputs ``soc``, ``balance``,
    ``efficiency`` and ``degraded`` (capacity), which may be the same memory as the previous step's inputs
    (each building's inputs are read before its outputs are written)."""
    for b in range(energy.shape[0]):
        c, p, e_req, s_prev, lo = capacity[b], nominal[b], energy[b], soc_prev[b], loss[b]
        eff_prev, cap_prev = efficiency_prev[b], capacity_prev[b]
        # battery_limit
        e0 = _max(0.0, s_prev * c * (1.0 - lo))
        soc0 = e0 / _max(c, 1e-6)
        p_max = p * _interpolate(soc0, cp_xs, cp_ys, cp_slopes, b, extrapolate_first_segment)
        if e_req >= 0:
            e = _min(_min(p_max, p - booked[b]), _min(cap_prev - e0, e_req))
        else:
            floor = -_max((s_prev - (1.0 - depth_of_discharge[b])) * c * math.sqrt(eff_prev), 0.0)
            e = _max(_max(-p_max, floor), e_req)
        # the step's efficiency, the storage, the capacity fade
        basis = abs(e)
        if efficiency_from_request:
            soc0r = _max(0.0, s_prev * (1.0 - lo))
            p_max_r = p * _interpolate(soc0r, cp_xs, cp_ys, cp_slopes, b, extrapolate_first_segment)
            basis = _min(abs(e_req), p_max_r)
        eff = _interpolate(basis * inverse_nominal[b], pe_xs, pe_ys, pe_slopes, b, extrapolate_first_segment)
        new_soc, bal = _store(s_prev, e, c, lo, math.sqrt(eff))
        fade = capacity_loss[b] * c * abs(bal) / (2.0 * cap_prev) if cap_prev > 0 else 0.0
        soc[b], balance[b], efficiency[b] = new_soc, bal, eff
        degraded[b] = _max(cap_prev - fade, 0.0)


def _heat_pump_demand(action, available, nominal_power, cop, use, out):  # pragma: no cover - compiled by numba
    """:func:`citylearn_env.devices.heat_pump_demand` over (B,) arrays, written into ``out``."""
    for b in range(action.shape[0]):
        if use[b]:
            p = nominal_power[b]
            q = _min(_max(action[b], 0.0) * p, p)
            out[b] = (q if available[b] else 0.0) * cop[b]
        else:
            out[b] = math.nan


#: helpers the kernels resolve as module globals when numba compiles them: swapped for jitted, inlined ones
_HELPERS = ("_min", "_max", "_interpolate", "_store", "_device")


class DeviceKernels(NamedTuple):
    """The compiled kernels (numba dispatchers) over (B,) float64 arrays."""

    serve_end_use: object
    battery_charge: object
    heat_pump_demand: object


def get_kernels() -> DeviceKernels | None:
    """The numba-compiled device kernels, or None when numba is not installed (compiled on first use, then
    loaded from numba's disk cache)."""
    global _KERNELS
    if _KERNELS is None:
        try:
            from numba import njit  # lazy: numba is an optional dependency
        except ImportError:  # pragma: no cover - numba is optional
            _KERNELS = False
        else:
            for name in _HELPERS:
                globals()[name] = njit(cache=True, nogil=True, inline="always", error_model="numpy")(globals()[name])
            jit = njit(cache=True, nogil=True, error_model="numpy")
            _KERNELS = DeviceKernels(serve_end_use=jit(_serve_end_use), battery_charge=jit(_battery_charge),
                                     heat_pump_demand=jit(_heat_pump_demand))
    return _KERNELS or None


def battery_charge_into(out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], energy: np.ndarray,
                        soc_prev: np.ndarray, booked: np.ndarray, battery: BatteryParams,
                        efficiency_prev: np.ndarray, capacity_prev: np.ndarray, *, kernels: DeviceKernels | None,
                        extrapolate_first_segment: bool = False, efficiency_from_request: bool = False) -> None:
    """:func:`citylearn_env.devices.battery_charge` written into ``out`` = (soc [-], balance [kWh], round-trip
    efficiency [-], degraded capacity [kWh]), (B,) arrays (e.g. record columns; they may be the inputs' own
    memory): through the compiled kernel, or with ``kernels`` None the numpy function."""
    if kernels is None:
        values = devices.battery_charge(energy, soc_prev, booked, battery, efficiency_prev, capacity_prev,
                                        extrapolate_first_segment=extrapolate_first_segment,
                                        efficiency_from_request=efficiency_from_request)
        for target, value in zip(out, values, strict=True):
            target[:] = value
        return
    cp, pe = battery.capacity_power, battery.power_efficiency
    kernels.battery_charge(
        energy, soc_prev, booked, efficiency_prev, capacity_prev, battery.capacity, battery.nominal_power,
        battery.inverse_nominal_power, battery.loss_coefficient, battery.capacity_loss_coefficient,
        battery.depth_of_discharge, cp.xs, cp.ys, cp.slopes, pe.xs, pe.ys, pe.slopes,
        bool(extrapolate_first_segment), bool(efficiency_from_request), *out)


def serve_end_use_into(out: tuple[np.ndarray, ...], demand: np.ndarray, nominal_power: np.ndarray,
                       cop: np.ndarray, supply: np.ndarray, action: np.ndarray, scale: np.ndarray,
                       soc_prev: np.ndarray, tank: TankParams | None, *, kernels: DeviceKernels | None) -> None:
    """:func:`citylearn_env.devices.serve_end_use` written into ``out``, six (B,) arrays in
    :class:`~citylearn_env.devices.EndUseStep` field order (the tank's four untouched when ``tank`` is None;
    ``out`` may hold ``soc_prev``'s memory): through the compiled kernel, or with ``kernels`` None the numpy
    function."""
    if kernels is None:
        step = devices.serve_end_use(demand, nominal_power, cop, supply, action, scale, soc_prev, tank)
        for target, value in zip(out, step, strict=True):
            if value is not None:
                target[:] = value
        return
    if tank is None:
        kernels.serve_end_use(demand, nominal_power, cop, supply, action, scale, soc_prev, demand, demand, demand,
                              demand, demand, False, *out)
        return
    kernels.serve_end_use(demand, nominal_power, cop, supply, action, scale, soc_prev, tank.capacity,
                          tank.loss_coefficient, tank.one_way_efficiency, tank.max_input_power,
                          tank.max_output_power, True, *out)


def heat_pump_demand(action: np.ndarray, available: np.ndarray, nominal_power: np.ndarray, cop: np.ndarray,
                     use: np.ndarray, *, kernels: DeviceKernels | None) -> np.ndarray:
    """:func:`citylearn_env.devices.heat_pump_demand` (a new (B,) array [kWh], NaN where not ``use``): through
    the compiled kernel, or with ``kernels`` None the numpy function."""
    if kernels is None:
        return devices.heat_pump_demand(action, available, nominal_power, cop, use)
    out = np.empty(action.shape[0])
    kernels.heat_pump_demand(action, available, nominal_power, cop, use, out)
    return out
