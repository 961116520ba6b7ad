"""Upstream CityLearn 2.1's device ``autosize``, as pure sizing functions.

A schema device with ``"autosize": true`` is sized from the building's data over the **simulation range**
(``simulation_start_time_step`` .. ``simulation_end_time_step``, not the episode) after its ``attributes``
are applied; ``autosize_attributes`` may hold ``safety_factor`` (SF, default 1.0; null means 1.0), the only
keyword CityLearn 2.1's autosizers take. Units: energies kWh per 1-h step (so peak kWh per step = kW),
temperatures degC, ``solar_generation`` W of AC output per kW of PV.

Rules of CityLearn 2.1.2 (``Building.autosize_*`` and the devices' ``autosize``), one function each:

* heat pump (:func:`citylearn_env.sizing.heat_pump_power`, the pipeline's rule, with :func:`heat_pump_rules`
  of the device): ``nominal_power = max_t(Q_c[t] / COP_c[t] + Q_h[t] / COP_h[t]) * SF`` [kW electric] with
  the Carnot COPs of :mod:`citylearn_env.devices` at the outdoor dry-bulb temperature. As ``cooling_device``
  it sees only ``cooling_demand`` (Q_h = 0); as ``heating_device`` only ``heating_demand``; as ``dhw_device``
  only ``dhw_demand`` (Q_c = 0, the heating COP).
* electric heater (:func:`heater_power`): ``nominal_power = max_t(Q[t] / efficiency) * SF`` [kW] with Q the
  demand of its slot (``heating_demand`` or ``dhw_demand``; a heater as ``cooling_device`` sees
  ``cooling_demand``) -- :func:`citylearn_env.sizing.dhw_heater_power`, the pipeline's DHW heater rule.
* storage tank (:func:`tank_capacity`): ``capacity = max_t(Q[t]) * SF`` [kWh] with Q the demand of its end use
  (``cooling_demand`` / ``heating_demand`` / ``dhw_demand``); not divided by an efficiency.
* battery (:func:`battery_capacity`): ``capacity = max_t(PV generation[t]) * SF`` [kWh], PV generation =
  ``pv_kw * solar_generation / 1000``. Only the capacity is sized (``nominal_power`` stays as given).
  CityLearn 2.1 sizes the battery *before* the PV and from the PV the building holds at that moment, which
  is always the zero-size placeholder (the schema's PV is attached after the battery), so an autosized
  battery gets capacity 0. :func:`autosize_device` reproduces that (``pv_kw`` = 0); no shared data set
  autosizes a battery.
* PV (:func:`pv_peak_power`): ``nominal_power = max_t(P0 * solar_generation[t] / 1000 / efficiency) * SF`` [kW]
  with P0 the schema's own ``nominal_power`` (0 when absent, giving 0) and the PV's ``efficiency``
  (default 1.0): upstream sizes the PV to its own peak generation.

Randomness: none. CityLearn 2.1's autosizers and device defaults are deterministic (fixed default
efficiencies and temperatures), so the result does not depend on the schema's ``random_seed``; the random
draws of later versions (catalogue batteries, U(a, b) default attributes) are not part of these rules.
Upstream computes in float32; these functions compute in float64 on the float32-rounded data, so sizes agree
to about 1e-7 relative.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from citylearn_env.config import Battery, ConversionDevice, Tank
from citylearn_env.errors import SchemaError
from citylearn_env.sizing import SizingRules, dhw_heater_power, heat_pump_power

#: the demand column each thermal slot is sized on
SLOT_DEMAND = {
    "cooling_device": "cooling_demand", "heating_device": "heating_demand", "dhw_device": "dhw_demand",
    "cooling_storage": "cooling_demand", "heating_storage": "heating_demand", "dhw_storage": "dhw_demand",
}
#: the keys ``autosize_attributes`` may hold (CityLearn 2.1's autosizers take only this keyword)
AUTOSIZE_KEYS = ("safety_factor",)


def heat_pump_rules(device: ConversionDevice, safety_factor: float = 1.0) -> SizingRules:
    """The sizing rules of heat pump ``device``: its Carnot fraction ``efficiency`` [-] and target supply
    temperatures [degC], the safety factor [-] on its peak electric input."""
    return SizingRules(heat_pump_efficiency=device.efficiency,
                       target_cooling_temperature=device.target_cooling_temperature,
                       target_heating_temperature=device.target_heating_temperature,
                       heat_pump_safety_factor=safety_factor)


def heater_power(demand_kwh: np.ndarray, *, efficiency: float, safety_factor: float = 1.0) -> float:
    """Electric-heater nominal power [kW] = max_t(demand / efficiency) x SF (the pipeline's DHW heater rule)."""
    rules = SizingRules(dhw_heater_efficiency=efficiency, dhw_heater_safety_factor=safety_factor)
    return dhw_heater_power(np.asarray(demand_kwh, dtype=np.float64), rules)


def tank_capacity(demand_kwh: np.ndarray, *, safety_factor: float = 1.0) -> float:
    """Storage-tank capacity [kWh] = max_t(demand) x SF: one peak hour of its end use, times SF."""
    return float(np.max(np.asarray(demand_kwh, dtype=np.float64)) * safety_factor)


def battery_capacity(pv_kw: float, solar_w_per_kw: np.ndarray, *, safety_factor: float = 1.0) -> float:
    """Battery capacity [kWh] = max_t(pv_kw x solar_generation / 1000) x SF: the peak hourly PV output."""
    return float(np.max(pv_kw * np.asarray(solar_w_per_kw, dtype=np.float64) / 1000.0) * safety_factor)


def pv_peak_power(pv_kw: float, solar_w_per_kw: np.ndarray, *, efficiency: float = 1.0,
                  safety_factor: float = 1.0) -> float:
    """PV nominal power [kW] = max_t(pv_kw x solar_generation / 1000 / efficiency) x SF (upstream 2.1's rule:
    the peak generation of the PV as given, so a PV given as 0 kW stays 0 kW). Not the pipeline's PV rule,
    :func:`citylearn_env.sizing.pv_power`, which covers a share of the building's consumption."""
    generation = pv_kw * np.asarray(solar_w_per_kw, dtype=np.float64) / 1000.0
    return float(np.max(generation / efficiency) * safety_factor)


def safety_factor(autosize_attributes: Mapping[str, Any] | None, where: str, extra_keys: tuple[str, ...] = ()
                  ) -> float:
    """The ``safety_factor`` of a device's ``autosize_attributes`` (1.0 when absent or null); a SchemaError
    for an unknown key or a value that is not a finite number >= 0. ``extra_keys``: further keys the device
    class accepts (CityLearn 2.2+'s PV and battery attributes, :mod:`citylearn_env.pv_battery_autosize`, which
    also reads a ``[low, high]`` safety factor)."""
    if autosize_attributes is not None and not isinstance(autosize_attributes, Mapping):
        raise SchemaError(f"expected an object or null, got {type(autosize_attributes).__name__}",
                          column=f"{where}.autosize_attributes")
    attrs = dict(autosize_attributes or {})
    known = (*AUTOSIZE_KEYS, *(k for k in extra_keys if k not in AUTOSIZE_KEYS))
    unknown = sorted(set(attrs) - set(known))
    if unknown:
        raise SchemaError(f"unknown autosize attribute(s) {unknown}; known: {', '.join(known)}",
                          column=f"{where}.autosize_attributes")
    value = attrs.get("safety_factor")
    if value is None or (extra_keys and isinstance(value, list)):
        return 1.0
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise SchemaError(f"expected a finite number >= 0, got {value!r}",
                          column=f"{where}.autosize_attributes.safety_factor")
    return float(value)


def autosize_device(slot: str, device: ConversionDevice | Tank | Battery, series: Mapping[str, np.ndarray],
                    sf: float) -> ConversionDevice | Tank | Battery:
    """``device`` (in building ``slot``) with its size replaced by CityLearn 2.1's autosize rule.

    ``series`` are the building's data columns over the simulation range (``cooling_demand``,
    ``heating_demand``, ``dhw_demand`` [kWh], ``outdoor_dry_bulb_temperature`` [degC], ``solar_generation``
    [W/kW]); ``sf`` is the safety factor. PV is sized by :func:`pv_peak_power` directly (its config is a number).
    """
    if isinstance(device, Battery):
        # upstream sizes the battery from the zero-size PV placeholder (see the module docstring)
        return dataclasses.replace(device, capacity=battery_capacity(0.0, series["solar_generation"],
                                                                     safety_factor=sf))
    demand = series[SLOT_DEMAND[slot]]
    if isinstance(device, Tank):
        return dataclasses.replace(device, capacity=tank_capacity(demand, safety_factor=sf))
    if device.kind == "ElectricHeater":
        power = heater_power(demand, efficiency=device.efficiency, safety_factor=sf)
    elif slot == "cooling_device":
        power = heat_pump_power(demand, series["outdoor_dry_bulb_temperature"], heat_pump_rules(device, sf))
    else:  # heating or DHW: the heating COP only (0 kWh of cooling adds exactly 0)
        power = heat_pump_power(np.zeros(len(demand)), series["outdoor_dry_bulb_temperature"],
                                heat_pump_rules(device, sf), demand)
    return dataclasses.replace(device, nominal_power=power)
