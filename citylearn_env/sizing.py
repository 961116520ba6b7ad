"""Device sizing as pure functions (the SimBuild 2024 recipe; see reference/paper_application.md).

Used by the pipeline's build (``pipeline.builder.steps.size_buildings``) and by the synthetic example district, so
both size devices the same way. Inputs are hourly series over the sizing period (kWh per hour, degC);
outputs are CityLearn device attributes (kW electric, kWh, fractions).

* Heat pump and DHW heater: peak *electric input* = max over hours of thermal load / COP (or efficiency)
  x safety factor, rounded to 4 decimals (kW; heat pumps and space heaters rounded up, so the rounding never
  leaves an hour's demand undelivered). A heat pump that also heats is sized on the peak over hours
  of cooling / COP_c + heating / COP_h (Carnot COPs of the hour's outdoor temperature), so in no hour does
  either demand exceed what it delivers; a resistance heater on the peak of heating / efficiency.
* DHW tank: ``dhw_tank_fraction`` (one half) of the peak hourly DHW demand (kWh), charged and discharged at
  most at the heater's nominal power.
* Battery: a catalogue product of :data:`BATTERIES`.
* PV: sized so that its yield covers ``pv_zne_fraction`` of the building's estimated consumption
  (zero-net-energy fraction, 21.5 % in the paper), rounded to 0.01 kW.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from citylearn_env.devices import carnot_cop_cooling, carnot_cop_heating
from citylearn_env.errors import InputError

#: (capacity kWh, nominal power kW, round-trip efficiency, depth of discharge) of catalogue batteries
BATTERIES = {
    "BYD LVS": (4.0, 3.32, 0.95, 0.8),
    "PowerPlus LiFe2433P": (3.3, 1.61, 0.96, 0.8),
    "Tesla Powerwall 2": (13.5, 3.3, 0.90, 1.0),
    "Enphase IQ Battery 10": (10.5, 3.84, 0.96, 0.96),
    "SolarEdge Home Battery": (9.7, 5.0, 0.945, 1.0),
}


@dataclass(frozen=True, kw_only=True)
class SizingRules:
    """Sizing parameters, named on construction (the defaults are the paper's)."""

    heat_pump_efficiency: float = 0.25
    """Carnot fraction of the heat pump's COP [-]."""
    target_cooling_temperature: float = 8.0
    """Supply temperature of cooling [degC]."""
    target_heating_temperature: float = 45.0
    """Supply temperature of heating [degC]."""
    heat_pump_safety_factor: float = 1.0
    """Multiplier on the peak electric input [-]."""
    electric_heater_efficiency: float = 1.0
    """Thermal efficiency of a resistance space heater [-] (also sized with ``heat_pump_safety_factor``)."""
    dhw_heater_efficiency: float = 0.9
    """Thermal efficiency of the electric DHW heater [-]."""
    dhw_heater_safety_factor: float = 1.0
    """Multiplier on the heater's peak electric input [-]."""
    dhw_tank_fraction: float = 0.5
    """DHW tank capacity as a fraction of the peak hourly DHW demand [h]."""
    dhw_tank_loss_coefficient: float = 0.004
    """Standby loss of the DHW tank [fraction per step]."""
    battery: str = "BYD LVS"
    """Catalogue battery (a key of ``BATTERIES``)."""
    pv_zne_fraction: float = 0.215
    """Share of the estimated yearly consumption the PV covers [-]."""


#: what serves a building's space heating: nothing, the (cooling) heat pump, or a resistance heater
HEATING_DEVICES = (None, "heat_pump", "electric_heater")


def heat_pump_electricity(cooling_kwh: np.ndarray, outdoor_c: np.ndarray, rules: SizingRules,
                          heating_kwh: np.ndarray | None = None) -> np.ndarray:
    """Hourly electric input [kWh] of a heat pump serving ``cooling_kwh`` (and ``heating_kwh`` when given):
    cooling(t) / COP_c(t) + heating(t) / COP_h(t), Carnot COPs of :mod:`citylearn_env.devices`."""
    outdoor = np.asarray(outdoor_c, dtype=float)
    electric = np.asarray(cooling_kwh, dtype=float) / carnot_cop_cooling(
        outdoor, rules.target_cooling_temperature, rules.heat_pump_efficiency)
    if heating_kwh is not None:
        electric = electric + np.asarray(heating_kwh, dtype=float) / carnot_cop_heating(
            outdoor, rules.target_heating_temperature, rules.heat_pump_efficiency)
    return electric


def heat_pump_power(cooling_kwh: np.ndarray, outdoor_c: np.ndarray, rules: SizingRules,
                    heating_kwh: np.ndarray | None = None) -> float:
    """Nominal electric power [kW] = max_t [cooling(t) / COP_c(t) + heating(t) / COP_h(t)] x safety factor
    (the heating term only when ``heating_kwh`` is given: a heat pump that also heats)."""
    electric = heat_pump_electricity(cooling_kwh, outdoor_c, rules, heating_kwh)
    return float(np.max(electric, initial=0.0) * rules.heat_pump_safety_factor)


def electric_heater_power(heating_kwh: np.ndarray, rules: SizingRules) -> float:
    """Nominal electric power [kW] of a resistance space heater = max_t heating(t) / efficiency x safety factor."""
    return float(np.max(np.asarray(heating_kwh, dtype=float), initial=0.0) / rules.electric_heater_efficiency
                 * rules.heat_pump_safety_factor)


def dhw_heater_power(dhw_kwh: np.ndarray, rules: SizingRules) -> float:
    """Nominal electric power [kW] = max_t DHW demand(t) / efficiency x safety factor."""
    return float(np.max(dhw_kwh) / rules.dhw_heater_efficiency * rules.dhw_heater_safety_factor)


def dhw_tank(dhw_kwh: np.ndarray, heater_kw: float, rules: SizingRules) -> dict[str, float]:
    """DHW tank attributes: capacity [kWh] = fraction x peak hourly demand; rates capped at the heater power."""
    return {"capacity": float(np.max(dhw_kwh) * rules.dhw_tank_fraction),
            "loss_coefficient": rules.dhw_tank_loss_coefficient,
            "max_input_power": heater_kw, "max_output_power": heater_kw}


def battery(rules: SizingRules) -> dict[str, object]:
    """Battery attributes of the catalogue product ``rules.battery`` (CityLearn 2023-style curves)."""
    if rules.battery not in BATTERIES:
        raise InputError(f"unknown battery {rules.battery!r}; known: {', '.join(BATTERIES)}", column="battery")
    capacity, power, eff, dod = BATTERIES[rules.battery]
    curve = [[0.0, eff - 0.07], [0.3, eff - 0.07], [0.7, eff], [0.8, eff], [1.0, eff - 0.05]]
    return {"capacity": capacity, "nominal_power": power, "efficiency": eff, "depth_of_discharge": dod,
            "capacity_loss_coefficient": 1e-5, "loss_coefficient": 1e-4, "power_efficiency_curve": curve}


def pv_power(consumption_kwh: float | np.ndarray, solar_w_per_kw: np.ndarray, *, zne_proportion: float,
             safety_factor: float = 1.0, steps_per_year: int | None = None) -> float:
    """PV nominal power [kW] whose yield covers ``zne_proportion`` x ``safety_factor`` of the consumption:
    ZNE x SF x demand / yield, with demand = ``consumption_kwh`` [kWh per step, or its total] and yield =
    ``solar_w_per_kw`` [W AC per kW DC per 1-h step] / 1000 [kWh per kW], each summed per ``steps_per_year``
    steps and averaged over those years (None: the whole series is one period); a negative demand sizes 0 kW.
    No yield (sum <= 0) is an :class:`InputError` on ``solar_generation``. The paper's rule
    (:func:`size_devices`) and CityLearn 2.2+'s autosize
    (:func:`citylearn_env.pv_battery_autosize.autosize_pv`) both size with this function."""
    solar = np.nan_to_num(np.asarray(solar_w_per_kw, dtype=np.float64))
    consumption = np.atleast_1d(np.asarray(consumption_kwh, dtype=np.float64))
    yield_kwh_per_kw = float(np.mean(_per_period(solar / 1000.0, steps_per_year or max(solar.size, 1))))
    if not yield_kwh_per_kw > 0.0:
        raise InputError("PV yield is zero over the sizing period", column="solar_generation")
    demand = float(np.mean(_per_period(consumption, steps_per_year or max(consumption.size, 1))))
    return float(zne_proportion * safety_factor * max(demand, 0.0) / yield_kwh_per_kw)


def _per_period(values: np.ndarray, steps: int) -> np.ndarray:
    """Sums of consecutive blocks of ``steps`` values (the last one partial)."""
    edges = np.arange(0, len(values), steps)
    return np.add.reduceat(values, edges) if len(values) else np.zeros(0)


def round_up(power_kw: float, decimals: int = 4) -> float:
    """``power_kw`` rounded UP to ``decimals`` (a device sized at a peak must not lose it to rounding)."""
    scale = 10.0 ** decimals
    return math.ceil(round(power_kw * scale, 6)) / scale


def size_devices(series: Mapping[str, Any], outdoor_c: np.ndarray, rules: SizingRules, *,
                 heating_device: str | None = None) -> dict[str, dict]:
    """All device attributes of one building, by schema slot, from its building columns.

    ``series`` maps ``cooling_demand``, ``dhw_demand``, ``non_shiftable_load`` [kWh per hour],
    ``solar_generation`` [W/kW] (and ``heating_demand`` [kWh per hour] when ``heating_device`` is given) to
    hourly arrays (a dict of arrays or a DataFrame); ``outdoor_c`` is the outdoor dry-bulb temperature [degC]
    of the same hours. ``heating_device``: None (heating not served), ``"heat_pump"`` (the heat pump heats
    too: one device, sized on cooling and heating, in both slots) or ``"electric_heater"`` (a resistance
    heater in ``heating_device``). Returns ``{"cooling_device": ..., ["heating_device": ...,] "dhw_device": ...,
    "dhw_storage": ..., "electrical_storage": ..., "pv": ...}`` attribute dicts.
    """
    if heating_device not in HEATING_DEVICES:
        raise InputError(f"heating_device must be one of {HEATING_DEVICES}, got {heating_device!r}",
                         column="heating_device")
    cooling = np.asarray(series["cooling_demand"], dtype=float)
    dhw = np.asarray(series["dhw_demand"], dtype=float)
    heating = np.asarray(series["heating_demand"], dtype=float) if heating_device else np.zeros_like(cooling)
    hp_heating = heating if heating_device == "heat_pump" else None
    hp = heat_pump_power(cooling, outdoor_c, rules, hp_heating)
    heater = dhw_heater_power(dhw, rules)
    space = np.sum(heat_pump_electricity(cooling, outdoor_c, rules, hp_heating))
    if heating_device == "electric_heater":
        space += np.sum(heating) / rules.electric_heater_efficiency
    consumption = float(space + np.sum(dhw) / rules.dhw_heater_efficiency
                        + np.sum(np.asarray(series["non_shiftable_load"], dtype=float)))
    heat_pump = {"nominal_power": round_up(hp), "efficiency": rules.heat_pump_efficiency,
                 "target_cooling_temperature": rules.target_cooling_temperature,
                 "target_heating_temperature": rules.target_heating_temperature}
    heating_slot = {}
    if heating_device == "heat_pump":
        heating_slot = {"heating_device": dict(heat_pump)}
    elif heating_device == "electric_heater":
        heating_slot = {"heating_device": {"nominal_power": round_up(electric_heater_power(heating, rules)),
                                           "efficiency": rules.electric_heater_efficiency}}
    return {
        "cooling_device": heat_pump, **heating_slot,
        "dhw_device": {"nominal_power": round(heater, 4), "efficiency": rules.dhw_heater_efficiency},
        "dhw_storage": dhw_tank(dhw, round(heater, 4), rules),
        "electrical_storage": battery(rules),
        "pv": {"nominal_power": round(pv_power(consumption, np.asarray(series["solar_generation"], dtype=float),
                                               zne_proportion=rules.pv_zne_fraction), 2)},
    }
