"""A schema's device entries as typed devices: attributes checked against their physical ranges, CityLearn
2.5's drawn defaults for what an entry leaves out, and autosizing from the building's data (CityLearn 2.1's
rules, :mod:`citylearn_env.autosize`; 2.2+'s PV and battery rules, :mod:`citylearn_env.pv_battery_autosize`).
Called by :mod:`citylearn_env.schema` once per building and device slot.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from citylearn_env import autosize, paths, pvwatts, ranges
from citylearn_env import pv_battery_autosize as pvb
from citylearn_env.config import Battery, ConversionDevice, Tank
from citylearn_env.errors import SchemaError
from citylearn_env.ev import upstream_battery_curves, upstream_device_seed, upstream_uniform
from citylearn_env.registry import SLOT_CLASSES, resolve_type


def drawn_battery_defaults(battery: Battery, building: str, spec: Mapping[str, Any], random_seed: int) -> Battery:
    """``battery`` with CityLearn 2.5's drawn defaults for what the building's schema entry ``spec`` leaves
    out of its ``electrical_storage`` attributes: round-trip efficiency 0.90..0.98, standby loss
    0.001..0.009 per step, capacity loss coefficient 1e-5..1e-4 and both curves (:func:`ev.upstream_battery_curves`),
    each ``low + (high - low) u`` with ``u`` the first uniform number of the device's seed
    (:func:`ev.upstream_device_seed`)."""
    given = (spec["electrical_storage"].get("attributes") or {})
    seed = upstream_device_seed(building, spec.get("type") or "citylearn.citylearn.Building", "electrical_storage",
                                spec["electrical_storage"].get("type", ""), random_seed)
    u = upstream_uniform(seed)
    drawn = {"efficiency": 0.90 + 0.08 * u, "loss_coefficient": 0.001 + 0.008 * u,
             "capacity_loss_coefficient": 1e-5 + 9e-5 * u}
    changes = {k: v for k, v in drawn.items() if given.get(k) is None}
    efficiency = changes.get("efficiency", battery.efficiency)
    power_efficiency, capacity_power = upstream_battery_curves(efficiency, u)
    if given.get("power_efficiency_curve") is None:
        changes["power_efficiency_curve"] = power_efficiency
    if given.get("capacity_power_curve") is None:
        changes["capacity_power_curve"] = capacity_power
    return replace(battery, **changes)


#: CityLearn 2.5's drawn defaults of the tank, heat-pump and heater attributes a schema leaves out:
#: class -> attribute -> (low, high) (efficiencies [-], standby loss [1/step], temperatures [degC])
DRAWN_DEFAULTS: dict[str, dict[str, tuple[float, float]]] = {
    "StorageTank": {"efficiency": (0.9, 0.98), "loss_coefficient": (0.001, 0.009)},
    "HeatPump": {"efficiency": (0.2, 0.3), "target_heating_temperature": (45.0, 50.0),
                 "target_cooling_temperature": (7.0, 10.0)},
    "ElectricHeater": {"efficiency": (0.9, 0.99)},
}


def drawn_thermal_defaults(device: Any, cls: str, given: Mapping[str, Any], u: float) -> Any:
    """``device`` (a :class:`Tank` or :class:`ConversionDevice` of class ``cls``) with ``low + (high - low) u``
    for each attribute of :data:`DRAWN_DEFAULTS` that ``given`` (the schema's attributes) leaves out or nulls;
    ``u`` in [0, 1) is the device's one uniform number (:meth:`Sizing.uniform`)."""
    drawn = {k: low + (high - low) * u for k, (low, high) in DRAWN_DEFAULTS[cls].items() if given.get(k) is None}
    return replace(device, **drawn) if drawn else device


@dataclass(frozen=True)
class Sizing:
    """What autosizing a building's devices needs besides its data: names and the schema's random seed for
    upstream's device seed (:func:`ev.upstream_device_seed`), the battery rule
    (``settings.battery_autosize_from_placeholder_pv``), the step length [h] and the dataset folder (EPW files)."""

    building: str
    building_type: str
    random_seed: int
    battery_2_1_rule: bool
    step_hours: float
    root: paths.DatasetFolder
    #: ``settings.thermal_device_defaults_drawn``: draw what a tank, heat pump or heater leaves out
    thermal_defaults_drawn: bool = False
    #: first data row of the simulation range (aligns an EPW's PV yield, :mod:`citylearn_env.pvwatts`)
    simulation_start: int = 0

    def uniform(self, slot: str, device_type: str) -> float:
        """The first uniform number of the device's upstream seed (its drawn attributes' ``u``)."""
        return upstream_uniform(upstream_device_seed(self.building, self.building_type, slot, device_type,
                                                     self.random_seed))


def parse_device(slot: str, spec: Mapping[str, Any] | None, where: str, series: Mapping[str, np.ndarray],
            sized: Mapping[str, Any], sizing: Sizing) -> Any:
    """The typed device of ``slot`` (None if absent), autosized from ``series`` (the building's data over the
    simulation range) when the spec asks for it (:mod:`citylearn_env.autosize`; PV and battery with CityLearn
    2.2+'s attributes: :mod:`citylearn_env.pv_battery_autosize`). ``sized``: the building's devices so far."""
    if spec is None:
        return None
    cls = resolve_type("device", spec.get("type"), where=f"{where}.type")
    if cls not in SLOT_CLASSES[slot]:
        raise SchemaError(f"a {cls} cannot be used as {slot}; allowed: {', '.join(SLOT_CLASSES[slot])}",
                          column=f"{where}.type")
    device = _device_attributes(cls, spec, where)
    if sizing.thermal_defaults_drawn and cls in DRAWN_DEFAULTS:
        device = drawn_thermal_defaults(device, cls, spec.get("attributes") or {},
                                        sizing.uniform(slot, str(spec.get("type"))))
    if not spec.get("autosize", False):
        return device
    attributes = spec.get("autosize_attributes")
    later = {"PV": pvb.PV_KEYS, "Battery": pvb.BATTERY_KEYS}.get(cls, ())
    sf = autosize.safety_factor(attributes, where, extra_keys=later)
    given = attributes if isinstance(attributes, Mapping) else {}
    if cls == "PV" and (set(given) - {"safety_factor"} or isinstance(given.get("safety_factor"), list)):
        return _pv_2_2(attributes, where, series, sized, sizing, str(spec.get("type")))
    if cls == "PV":
        efficiency = (spec.get("attributes") or {}).get("efficiency") or 1.0
        return autosize.pv_peak_power(device, series["solar_generation"], efficiency=efficiency, safety_factor=sf)
    if cls == "Battery" and not sizing.battery_2_1_rule:
        return _battery_2_2(device, attributes, where, series, sized, sizing, str(spec.get("type")))
    return autosize.autosize_device(slot, device, series, sf)


def _consumption(series: Mapping[str, np.ndarray], sized: Mapping[str, Any]) -> np.ndarray:
    """The building's baseline consumption [kWh per step] with its (already sized) conversion devices."""
    return pvb.baseline_consumption(series, *(sized.get(s) or ConversionDevice()
                                              for s in ("cooling_device", "heating_device", "dhw_device")))


def _pv_2_2(attributes: Mapping[str, Any], where: str, series: Mapping[str, np.ndarray], sized: Mapping[str, Any],
            sizing: Sizing, device_type: str) -> float:
    """PV nominal power [kW] by CityLearn 2.2+'s rule, offline (:func:`pv_battery_autosize.autosize_pv`)."""
    at = f"{where}.autosize_attributes"
    epw = attributes.get("epw_filepath")
    if epw is not None:
        path = sizing.root.file(epw, where=f"{at}.epw_filepath")  # upstream reads it: inside the folder, present
        solar = series["solar_generation"]
        if not np.any(np.nan_to_num(solar) > 0):  # no profile in the data: PVWatts on the EPW, as upstream
            series["solar_generation"] = pvwatts.aligned(pvwatts.epw_yield(path), sizing.simulation_start,
                                                         len(solar))  # type: ignore[index]
    if attributes.get("use_sample_target"):
        raise SchemaError("sizes the PV as a system drawn from upstream's downloaded PV sizing table "
                          f"'{pvb.PV_SIZING_TABLE}', which is not available offline; set it false to size for "
                          "zero_net_energy_proportion", column=f"{at}.use_sample_target")
    u = sizing.uniform("pv", device_type)
    zne = pvb.draw_attribute(attributes.get("zero_net_energy_proportion"), (0.7, 1.0),
                             f"{at}.zero_net_energy_proportion").value(u)
    sf = pvb.draw_attribute(attributes.get("safety_factor"), 1.0, f"{at}.safety_factor").value(u)
    roof = attributes.get("roof_area")
    if roof is not None:
        roof = pvb.draw_attribute(roof, 0.0, f"{at}.roof_area").low
    return pvb.autosize_pv(_consumption(series, sized), series["solar_generation"], zne_proportion=zne,
                           safety_factor=sf, roof_area_m2=roof, steps_per_year=8760, where=f"{where}.autosize")


def _battery_2_2(device: Battery, attributes: Mapping[str, Any] | None, where: str, series: Mapping[str, np.ndarray],
                 sized: Mapping[str, Any], sizing: Sizing, device_type: str) -> Battery:
    """The battery with capacity and nominal power by CityLearn 2.2+'s rule, offline
    (:func:`pv_battery_autosize.battery_size`)."""
    attributes, at = attributes or {}, f"{where}.autosize_attributes"
    u = sizing.uniform("electrical_storage", device_type)
    duration = pvb.draw_attribute(attributes.get("duration"), (1.5, 3.5), f"{at}.duration").value(u)
    sf = pvb.draw_attribute(attributes.get("safety_factor"), 1.0, f"{at}.safety_factor").value(u)
    if not isinstance(attributes.get("parallel", False), bool | type(None)):
        raise SchemaError(f"expected true, false or null, got {attributes['parallel']!r}", column=f"{at}.parallel")
    capacity, power = pvb.battery_size(_consumption(series, sized), duration_h=duration, safety_factor=sf,
                                       step_hours=sizing.step_hours)
    return replace(device, capacity=capacity, nominal_power=power)


def _device_attributes(cls: str, spec: Mapping[str, Any], where: str) -> Any:
    attrs = dict(spec.get("attributes") or {})
    attrs.pop("seconds_per_time_step", None)
    for key, value in attrs.items():
        if key.endswith("_curve"):  # ranges: citylearn_env.ranges (finite, physical)
            attrs[key] = ranges.check_curve(value, where=f"{where}.attributes.{key}")
        elif value is not None:
            ranges.check_attribute(cls, key, value, where=f"{where}.attributes.{key}")
    attrs = {k: v for k, v in attrs.items() if v is not None}
    target = {"HeatPump": ConversionDevice, "ElectricHeater": ConversionDevice, "StorageTank": Tank,
              "Battery": Battery, "PV": dict}[cls]
    if cls == "PV":
        return float(attrs.get("nominal_power", 0.0))
    if cls == "ElectricHeater":
        attrs.setdefault("efficiency", 0.9)
        attrs["kind"] = "ElectricHeater"
    if cls == "Battery" and "initial_soc" not in attrs:
        attrs["initial_soc"] = 1.0 - attrs.get("depth_of_discharge", 1.0)
    known = set(target.__dataclass_fields__)
    unknown = sorted(set(attrs) - known)
    if unknown:
        raise SchemaError(f"unknown attribute(s) {unknown}; known: {sorted(known - {'kind'})}",
                          column=f"{where}.attributes")
    return target(**attrs)
