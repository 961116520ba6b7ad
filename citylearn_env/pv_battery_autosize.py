"""CityLearn 2.2+'s PV and battery autosizers, as offline pure functions (documented equivalents).

Upstream (intelligent-environments-lab/CityLearn, ``citylearn/energy_model.py`` ``PV.autosize`` and
``Battery.autosize``, called by ``Building.autosize_pv`` / ``autosize_electrical_storage``) sizes both from the
building's estimated baseline electricity consumption and from tables it downloads at every environment
construction (``citylearn/data/misc/lbl-tracking_the_sun-res-pv.csv`` for PV systems, ``battery_choices.yaml``
for battery models) -- and the PV additionally with PySAM's PVWatts run on an EPW weather file. None of that is
available offline, so this module applies the same sizing rules to what the data set itself holds:

* baseline consumption [kWh per step] (:func:`baseline_consumption`): cooling, heating and DHW demand divided
  by their device's COP (heater: efficiency) plus the non-shiftable load, over the simulation range
  (upstream's ``_estimate_baseline_electricity_consumption``);
* PV (:func:`autosize_pv`, through :func:`citylearn_env.sizing.pv_power`): ``nominal_power = ZNE x SF x
  demand / yield`` [kW], demand = the consumption summed per year of steps and averaged over years (upstream's grouping), yield = the building file's
  ``solar_generation`` column [W/kW] summed the same way / 1000 (upstream: the PVWatts output for the drawn
  system on the EPW); capped at ``roof_area / 5.263`` kW (upstream's module area per kW when the drawn system
  has none). The drawn module size and its flooring to whole modules are not reproduced. A building file
  without any solar generation (all 0) gets the EPW's PVWatts yield first (:mod:`citylearn_env.pvwatts`, called
  by :mod:`citylearn_env.schema_devices`); without an EPW that is one clear error naming the table upstream
  downloads. ``use_sample_target`` (the drawn system's own size) needs the table too: an error.
* battery (:func:`battery_size`): demand = the mean of the daily peaks of the baseline consumption [kW];
  ``capacity = demand x duration x SF`` [kWh] and ``nominal_power = demand`` [kW] (upstream: the drawn
  catalogue model with power <= demand, as many units as reach the capacity; its efficiency, depth of
  discharge and losses stay the schema's or the defaults here).

A ``[low, high]`` attribute (upstream's tuples: ``zero_net_energy_proportion`` default (0.7, 1.0),
``duration`` default (1.5, 3.5)) is drawn as ``low + (high - low) u`` with u the first uniform number of the
device's seed (:func:`citylearn_env.ev.upstream_device_seed`), as upstream draws it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from citylearn_env import devices
from citylearn_env.config import ConversionDevice
from citylearn_env.errors import InputError, SchemaError
from citylearn_env.sizing import pv_power

#: roof area one kW of PV takes [m2/kW] (upstream's ``5.263`` for a system without a module area)
PV_AREA_PER_KW = 5.263
#: the files upstream downloads to autosize (named in errors)
PV_SIZING_TABLE = "citylearn/data/misc/lbl-tracking_the_sun-res-pv.csv"
BATTERY_SIZING_TABLE = "citylearn/data/misc/battery_choices.yaml"
#: autosize attribute keys CityLearn 2.2+ reads, per device class (``sizing_data`` is upstream's own)
PV_KEYS = ("epw_filepath", "roof_area", "use_sample_target", "zero_net_energy_proportion", "safety_factor")
BATTERY_KEYS = ("duration", "parallel", "safety_factor")


@dataclass(frozen=True)
class Draw:
    """A number given in the schema, or a ``[low, high]`` range drawn with the device's uniform number."""

    low: float
    high: float

    def value(self, u: float) -> float:
        return self.low + (self.high - self.low) * u


def draw_attribute(value: Any, default: tuple[float, float] | float, where: str) -> Draw:
    """``value`` (a finite number >= 0, a ``[low, high]`` pair of them, or null for ``default``) as a Draw."""
    if value is None:
        value = default
    if isinstance(value, list | tuple) and len(value) == 2:
        low, high = (_number(v, where) for v in value)
        if high < low:
            raise SchemaError(f"expected [low, high] with low <= high, got {list(value)}", column=where)
        return Draw(low, high)
    number = _number(value, where)
    return Draw(number, number)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
        raise SchemaError(f"expected a finite number >= 0 or a [low, high] pair, got {value!r}", column=where)
    return float(value)


def baseline_consumption(series: Mapping[str, np.ndarray], cooling: ConversionDevice, heating: ConversionDevice,
                         dhw: ConversionDevice) -> np.ndarray:
    """Estimated consumption without storage or PV [kWh per step]: each thermal demand [kWh] over its device's
    COP (Carnot heat pump at the outdoor dry-bulb temperature [degC]) or heater efficiency, plus the
    non-shiftable load [kWh]."""
    t_out = np.asarray(series["outdoor_dry_bulb_temperature"], dtype=np.float64)
    total = np.asarray(series["non_shiftable_load"], dtype=np.float64).copy()
    for demand, device, heat in (("cooling_demand", cooling, False), ("heating_demand", heating, True),
                                 ("dhw_demand", dhw, True)):
        if device.kind == "ElectricHeater":
            cop = np.full(len(t_out), device.efficiency)
        elif heat:
            cop = devices.carnot_cop_heating(t_out, device.target_heating_temperature, device.efficiency)
        else:
            cop = devices.carnot_cop_cooling(t_out, device.target_cooling_temperature, device.efficiency)
        total += np.nan_to_num(np.asarray(series[demand], dtype=np.float64) / cop)
    return total


def autosize_pv(consumption_kwh: np.ndarray, solar_w_per_kw: np.ndarray, *, zne_proportion: float,
                safety_factor: float, roof_area_m2: float | None, steps_per_year: int, where: str) -> float:
    """PV nominal power [kW] = ZNE x SF x mean annual consumption / mean annual yield per kW
    (:func:`citylearn_env.sizing.pv_power`), capped by the roof (see the module docstring). ``consumption_kwh``
    [kWh per step]; ``solar_w_per_kw``: AC output per kW of PV [W/kW] per step. No yield is a
    :class:`SchemaError` at ``where`` naming the table upstream would download."""
    try:
        power = pv_power(consumption_kwh, solar_w_per_kw, zne_proportion=zne_proportion, safety_factor=safety_factor,
                         steps_per_year=steps_per_year)
    except InputError:
        raise SchemaError("PV autosize from the EPW file needs upstream's downloaded PV sizing table "
                          f"'{PV_SIZING_TABLE}' and PySAM's PVWatts; offline this environment sizes the PV on "
                          "the building file's solar_generation column [W/kW], which has no generation here: "
                          "give that column a PV profile, or the PV's nominal_power with autosize false",
                          column=where) from None
    if roof_area_m2 is not None:
        power = min(power, roof_area_m2 / PV_AREA_PER_KW)
    return float(power)


def battery_size(consumption_kwh: np.ndarray, *, duration_h: float, safety_factor: float, step_hours: float = 1.0,
                 steps_per_day: int = 24) -> tuple[float, float]:
    """``(capacity [kWh], nominal_power [kW])``: the mean of the peaks of each ``steps_per_day`` steps (upstream's
    "day" is 24 steps whatever their length) of the consumption [kWh per step of ``step_hours`` h], as power P
    [kW], served for ``duration_h`` hours times SF, with nominal power P (see the module docstring)."""
    values = np.asarray(consumption_kwh, dtype=np.float64)
    edges = np.arange(0, len(values), steps_per_day)
    peak = float(np.mean(np.maximum.reduceat(values, edges))) if len(values) else 0.0
    power = max(peak, 0.0) / step_hours
    return power * duration_h * safety_factor, power
