"""Load a CityLearn v2 schema (path or dict) and its data files into a frozen :class:`DistrictConfig`.

Validation happens here, once: every problem is a :class:`SchemaError` naming the file or schema key, the
column and the first bad row. The caller's dict is never modified (it is deep-copied before anything else).
Data values are rounded to float32 and held as float64, as CityLearn 2.1 holds its data series.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import autosize, dataset, paths, ranges
from citylearn_env import pv_battery_autosize as pvb
from citylearn_env.config import (
    ACTION_NAMES,
    Battery,
    BuildingConfig,
    ConversionDevice,
    DistrictConfig,
    Outage,
    Tank,
    expand_actions,
    frozen_series,
)
from citylearn_env.dynamics import lstm_sizes, read_pth_state_dict
from citylearn_env.errors import SchemaError
from citylearn_env.ev import (
    EVSection,
    parse_ev_section,
    seeded_initial_soc_draws,
    upstream_battery_curves,
    upstream_device_seed,
    upstream_uniform,
)
from citylearn_env.occupant import OccupantConfig, parse_occupant
from citylearn_env.registry import DYNAMICS_BUILDINGS, OCCUPANT_BUILDING, SLOT_CLASSES, resolve_type
from citylearn_env.settings import Behaviour, resolve
from citylearn_env.state import COP_OBSERVATIONS, DYNAMIC, STATIC_ALIASES
from citylearn_env.washing_machine import WashingMachines, parse_washing_machines


def load_schema(schema: str | Path | Mapping[str, Any], *,
                settings: Behaviour | str | None = None, allow_outside_paths: bool = False) -> DistrictConfig:
    """Validate ``schema`` (a schema.json path or an already parsed dict) and read its data files.

    ``settings`` (a :class:`~citylearn_env.settings.Behaviour` or a preset name such as "citylearn-2.1")
    decides the data-set defaults that differ between CityLearn 2.1 and its
    documentation: ``missing_hvac_mode_is_off`` (a building file without ``hvac_mode`` runs mode 0 "off"
    instead of 1 "cooling"). Relative file names resolve against ``root_directory``, or the schema file's
    folder when that is null. Every file must lie inside the dataset folder (:mod:`citylearn_env.paths`)
    unless ``allow_outside_paths``; every number within its range (:mod:`citylearn_env.ranges`).
    """
    settings = resolve(settings)
    if isinstance(schema, (str, Path)):
        path = Path(schema)
        try:
            raw = json.loads(path.read_text())
        except FileNotFoundError as error:
            raise SchemaError("schema file not found", file=path) from error
        except json.JSONDecodeError as error:
            raise SchemaError(f"not valid JSON: {error.msg}", file=path, row=error.lineno) from error
        except (OSError, UnicodeDecodeError) as error:  # a folder, unreadable, not text
            raise SchemaError(f"cannot read the schema file: {getattr(error, 'strerror', None) or error}",
                              file=path) from None
        schema_folder, source = path.resolve().parent, str(path)
    elif isinstance(schema, Mapping):
        raw = copy.deepcopy(dict(schema))
        schema_folder, source = None, "<schema dict>"
    else:
        raise SchemaError(f"a schema must be a path or a dict, got {type(schema).__name__}")
    try:  # --- hardening hook (citylearn_env.ranges / citylearn_env.paths): shape, keys, confined root
        ranges.check_schema_shape(raw)
        root = paths.dataset_folder(raw.get("root_directory"), schema_folder, allow_outside=allow_outside_paths)
        return _parse(raw, root, source, settings)
    except SchemaError as error:  # name the schema file in key errors
        if error.file is None and schema_folder is not None:
            where = str(SchemaError("", column=error.column, row=error.row))   # "column/key 'x': "
            message = str(error)[len(where):] if str(error).startswith(where) else str(error)
            raise SchemaError(message, file=source, column=error.column, row=error.row) from None
        raise


def _parse(raw: dict[str, Any], root: paths.DatasetFolder, source: str, settings: Behaviour) -> DistrictConfig:
    start, end = _simulation_range(raw)
    observations, active_obs, active_actions = _active_names(raw)
    buildings_raw = raw.get("buildings")
    if not isinstance(buildings_raw, Mapping) or not buildings_raw:
        raise SchemaError("missing or empty", column="buildings")
    ev = parse_ev_section(raw, root.root, initial_soc_draws=seeded_initial_soc_draws(raw))
    machines = parse_washing_machines(raw, root.root)
    if any(spec.get("charging_constraints") for spec in buildings_raw.values() if isinstance(spec, Mapping)):
        raise SchemaError("charging constraints (CityLearn 2.5) are not supported", column="charging_constraints")
    drawn_seed = int(raw.get("random_seed") or 0) if settings.battery_defaults_drawn else None
    cache: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    buildings: list[BuildingConfig] = []
    for name, spec in buildings_raw.items():
        if spec.get("include", True):
            sizing = _Sizing(name, spec.get("type") or "citylearn.citylearn.Building", int(raw.get("random_seed") or 0),
                             settings.battery_autosize_from_placeholder_pv, ranges.check_key(
                                 raw, "seconds_per_time_step", 3600.0, where="seconds_per_time_step") / 3600.0, root,
                             settings.thermal_device_defaults_drawn)
            building = _building(name, spec, root, (start, end), cache, (active_obs, active_actions),
                                 settings.missing_hvac_mode_is_off, sizing)
            buildings.append(_with_devices(building, spec, len(buildings), ev, machines, drawn_seed))
    if not buildings:
        raise SchemaError("no building has include = true", column="buildings")
    episode = _episode_splits(raw.get("episode_time_steps"))
    seconds = ranges.check_key(raw, "seconds_per_time_step", 3600.0, where="seconds_per_time_step")
    ranges.check_key(raw, "random_seed", None, where="random_seed")
    return DistrictConfig(
        buildings=tuple(buildings),
        observations=tuple((n, bool(v.get("shared_in_central_agent", False))) for n, v in observations.items()),
        central_agent=bool(raw.get("central_agent", False)),
        simulation_start_time_step=start,
        simulation_end_time_step=end,
        episode_time_steps=episode,
        rolling_episode_split=bool(raw.get("rolling_episode_split", False)),
        random_episode_split=bool(raw.get("random_episode_split", False)),
        seconds_per_time_step=seconds,
        reward_function=raw.get("reward_function"),
        random_seed=raw.get("random_seed"),
        source=source,
        electric_vehicles=ev,
        washing_machines=machines,
    )


def _simulation_range(raw: Mapping[str, Any]) -> tuple[int, int]:
    """``(simulation_start_time_step, simulation_end_time_step)`` [time steps], the end not before the start."""
    start = ranges.check_key(raw, "simulation_start_time_step", 0, where="simulation_start_time_step")
    end = ranges.check_key(raw, "simulation_end_time_step", None, where="simulation_end_time_step")
    if end is None or end < start:
        raise SchemaError("must be an integer >= simulation_start_time_step", column="simulation_end_time_step")
    return start, end


def _active_names(raw: Mapping[str, Any]) -> tuple[Mapping[str, Any], list[str], list[str]]:
    """The schema's ``observations`` (non-empty) and its active observation and action names (schema order);
    every action name must be a known one."""
    observations = raw.get("observations")
    if not isinstance(observations, Mapping) or not observations:
        raise SchemaError("missing or empty", column="observations")
    actions = raw.get("actions", {})
    for name in actions:
        if name not in ACTION_NAMES:
            raise SchemaError(f"unknown action; known actions: {', '.join(ACTION_NAMES)}", column=f"actions.{name}")
    active_obs = [n for n, v in observations.items() if v.get("active", False)]
    active_actions = [n for n, v in actions.items() if v.get("active", False)]  # schema order
    return observations, active_obs, active_actions


def _with_devices(building: BuildingConfig, spec: Mapping[str, Any], index: int, ev: EVSection | None,
                  machines: WashingMachines | None, drawn_seed: int | None) -> BuildingConfig:
    """``building`` (the ``index``-th included one) with its per-device actions expanded, less its inactive
    actions, and with CityLearn 2.5's drawn battery defaults from the schema's ``random_seed`` when
    ``drawn_seed`` is given (``settings.battery_defaults_drawn``)."""
    inactive = set(spec.get("inactive_actions") or [])
    expanded = expand_actions(building.active_actions, index, ev, machines)
    building = replace(building, active_actions=tuple(a for a in expanded if a not in inactive))
    if drawn_seed is not None and spec.get("electrical_storage"):
        building = replace(building, electrical_storage=drawn_battery_defaults(
            building.electrical_storage, building.name, spec, drawn_seed))
    return building


def _episode_splits(episode: Any) -> Any:
    """``episode_time_steps``: null, an int, or a list of [start, end] integer pairs (-> a tuple of pairs)."""
    if not isinstance(episode, list):
        return episode
    if not all(isinstance(p, list) and len(p) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                                            for v in p) for p in episode):
        raise SchemaError("must be null, an int or a list of [start, end] integer pairs",
                          column="episode_time_steps")
    return tuple((int(a), int(b)) for a, b in episode)


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
    ``u`` in [0, 1) is the device's one uniform number (:meth:`_Sizing.uniform`)."""
    drawn = {k: low + (high - low) * u for k, (low, high) in DRAWN_DEFAULTS[cls].items() if given.get(k) is None}
    return replace(device, **drawn) if drawn else device


@dataclass(frozen=True)
class _Sizing:
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

    def uniform(self, slot: str, device_type: str) -> float:
        """The first uniform number of the device's upstream seed (its drawn attributes' ``u``)."""
        return upstream_uniform(upstream_device_seed(self.building, self.building_type, slot, device_type,
                                                     self.random_seed))


def _device(slot: str, spec: Mapping[str, Any] | None, where: str, series: Mapping[str, np.ndarray],
            sized: Mapping[str, Any], sizing: _Sizing) -> Any:
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
            sizing: _Sizing, device_type: str) -> float:
    """PV nominal power [kW] by CityLearn 2.2+'s rule, offline (:func:`pv_battery_autosize.pv_power`)."""
    at = f"{where}.autosize_attributes"
    epw = attributes.get("epw_filepath")
    if epw is not None:
        sizing.root.file(epw, where=f"{at}.epw_filepath")  # upstream reads it: inside the folder, present
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
    return pvb.pv_power(_consumption(series, sized), series["solar_generation"], zne_proportion=zne,
                        safety_factor=sf, roof_area_m2=roof, steps_per_year=8760, where=f"{where}.autosize")


def _battery_2_2(device: Battery, attributes: Mapping[str, Any] | None, where: str, series: Mapping[str, np.ndarray],
                 sized: Mapping[str, Any], sizing: _Sizing, device_type: str) -> Battery:
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


def _outage(spec: Mapping[str, Any] | None, where: str) -> Outage:
    if not spec:
        return Outage()
    stochastic = bool(spec.get("stochastic_power_outage", False))
    model = spec.get("stochastic_power_outage_model") or {}
    attrs = dict(model.get("attributes") or {})
    if stochastic and model:
        resolve_type("power_outage", model.get("type"), where=f"{where}.stochastic_power_outage_model.type")
    starts = attrs.get("start_time_steps")
    if starts is not None and not (isinstance(starts, list) and all(
            isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in starts)):
        raise SchemaError("expected a list of time steps (integers >= 0)",
                          column=f"{where}.stochastic_power_outage_model.attributes.start_time_steps")
    model_where = f"{where}.stochastic_power_outage_model.attributes"
    return Outage(
        simulate=bool(spec.get("simulate_power_outage", False)), stochastic=stochastic,
        saifi=ranges.check_key(attrs, "saifi", 1.436, where=f"{model_where}.saifi"),
        caidi=ranges.check_key(attrs, "caidi", 331.2, where=f"{model_where}.caidi"),
        random_seed=attrs.get("random_seed"), start_time_steps=tuple(starts) if starts is not None else None,
    )


def _building_series(spec: Mapping[str, Any], root: paths.DatasetFolder, where: str, span: tuple[int, int],
                     cache: dict, hvac_off: bool) -> dict[str, np.ndarray]:
    """The building's data columns (building file, weather, prices, carbon intensity) over the simulation range
    ``span`` (start, end) [time steps]."""
    start, end = span
    for key in ("energy_simulation", "weather"):
        if not spec.get(key):
            raise SchemaError("missing data file name", column=f"{where}.{key}")
    n = end + 1
    series: dict[str, np.ndarray] = {}
    series.update(_read(root.file(spec["energy_simulation"], where=f"{where}.energy_simulation"), "building", n,
                        cache, hvac_off))
    series.update(_read(root.file(spec["weather"], where=f"{where}.weather"), "weather", n, cache, hvac_off))
    for key, kind, cols in (("pricing", "pricing", dataset.PRICING_COLUMNS),
                            ("carbon_intensity", "carbon", dataset.CARBON_COLUMNS)):
        if spec.get(key):
            series.update(_read(root.file(spec[key], where=f"{where}.{key}"), kind, n, cache, hvac_off))
        else:
            series.update({c: np.zeros(n) for c in cols})
    return {k: v[start : end + 1] for k, v in series.items()}


def _building(name: str, spec: Mapping[str, Any], root: paths.DatasetFolder, span: tuple[int, int], cache: dict,
              active: tuple[list[str], list[str]], missing_hvac_mode_is_off: bool, sizing: _Sizing) -> BuildingConfig:
    """One building of the schema: its data over the simulation range ``span``, devices (autosized where asked),
    LSTM models, occupant model, and its active observations and actions (``active``: the schema's)."""
    where = f"buildings.{name}"
    btype = resolve_type("building", spec.get("type", "citylearn.building.Building"), where=f"{where}.type")
    series = _building_series(spec, root, where, span, cache, missing_hvac_mode_is_off)
    devices: dict[str, Any] = {}
    for slot in SLOT_CLASSES:  # conversion devices first: the PV and battery rules read them
        devices[slot] = _device(slot, spec.get(slot), f"{where}.{slot}", series, devices, sizing)
    cooling_model, heating_model = (None, None)
    if btype in DYNAMICS_BUILDINGS:
        cooling_model, heating_model = _dynamics(spec.get("dynamics"), root, series, f"{where}.dynamics")
    active_obs, active_actions = active
    inactive_obs = set(spec.get("inactive_observations") or [])
    inactive_act = set(spec.get("inactive_actions") or [])
    _refuse_used_empty_columns(series, [o for o in active_obs if o not in inactive_obs],
                               btype in DYNAMICS_BUILDINGS, root.root / spec["energy_simulation"], span[0])
    kwargs = {slot: dev for slot, dev in devices.items() if dev is not None and slot != "pv"}
    return BuildingConfig(
        name=name, series=frozen_series(series), **kwargs,
        pv_nominal_power=devices["pv"] or 0.0,
        outage=_outage(spec.get("power_outage"), f"{where}.power_outage"),
        cooling_model=cooling_model, heating_model=heating_model,
        occupant=_occupant(spec, btype, root, span, where),
        active_observations=tuple(o for o in active_obs if o not in inactive_obs),
        active_actions=tuple(a for a in active_actions if a not in inactive_act),
    )


def _occupant(spec: Mapping[str, Any], btype: str, root: paths.DatasetFolder, span: tuple[int, int],
              where: str) -> OccupantConfig | None:
    """The building's occupant (:mod:`citylearn_env.occupant`): required by, and only allowed on, the occupant
    interaction building type."""
    entry = spec.get("occupant")
    if btype != OCCUPANT_BUILDING:
        if entry is not None:
            raise SchemaError(f"an occupant needs building type {OCCUPANT_BUILDING} (this one is {btype})",
                              column=f"{where}.occupant")
        return None
    if entry is None:
        raise SchemaError(f"missing: a {OCCUPANT_BUILDING} needs an occupant (type, parameters_filename, attributes)",
                          column=f"{where}.occupant")
    return parse_occupant(entry, root, span, f"{where}.occupant", hold=spec.get("set_point_hold_time_steps"))


# --- hardening hook (citylearn_env.ranges / citylearn_env.paths): LSTM attributes, weights file, input names
def _dynamics(spec: Any, root: paths.DatasetFolder, series: Mapping[str, np.ndarray], where: str) -> tuple:
    """``(cooling, heating)`` LSTM blocks: attributes typed and in range, weights inside the dataset folder and
    present, every input name an observation the building has."""
    single = isinstance(spec, Mapping) and "type" in spec
    entries = {where: spec} if single else {f"{where}.{mode}": entry for mode, entry in (spec or {}).items()
                                              if mode in ("cooling", "heating") and entry is not None}
    for at, entry in entries.items():
        if isinstance(entry, Mapping):
            ranges.check_dynamics_attributes(entry.get("attributes", entry), where=f"{at}.attributes")
            _sizes_from_weights(entry.get("attributes", entry), root, at)
    blocks = dataset.parse_dynamics(spec, root.root, where=where, check_files=False)
    for at, block in zip((where,) if single else (f"{where}.cooling", f"{where}.heating"), blocks, strict=False):
        if block is None:
            continue
        if not root.check(block.filename, where=f"{at}.attributes.filename").is_file():
            raise SchemaError("LSTM weights file not found", file=block.filename, column=f"{at}.attributes.filename")
        known = {*series, *DYNAMIC, *STATIC_ALIASES, *COP_OBSERVATIONS, *dataset.NAME_ALIASES}
        for i, name in enumerate(block.input_observation_names):
            if dataset.split_periodic_name(name)[0] not in known:
                raise SchemaError(f"unknown LSTM input {name!r}{ranges.closest_key(name, known)}",
                                  column=f"{at}.attributes.input_observation_names[{i}]")
    return blocks


def _sizes_from_weights(attributes: Any, root: paths.DatasetFolder, where: str) -> None:
    """Fill a null or missing ``hidden_size`` / ``num_layers`` of an LSTM entry (this loader's own copy of the
    schema) from its weights file, as upstream's neighbourhood builder leaves them to the ``.pth``; an
    ``input_size`` of null is the number of input names (:meth:`DynamicsBlock.from_schema`)."""
    if not isinstance(attributes, dict) or all(attributes.get(k) is not None for k in ("hidden_size", "num_layers")):
        return
    name = attributes.get("filename")
    if not isinstance(name, str):
        return  # the block parse names the missing file name
    path = root.check(str(root.root / name), where=f"{where}.attributes.filename")
    if not path.is_file():
        raise SchemaError("LSTM weights file not found", file=path, column=f"{where}.attributes.filename")
    sizes = lstm_sizes(read_pth_state_dict(path))
    for key in ("hidden_size", "num_layers"):
        if attributes.get(key) is None and key in sizes:
            attributes[key] = sizes[key]


def _refuse_used_empty_columns(series: Mapping[str, np.ndarray], observed: list[str], dynamics: bool,
                               path: Path, start: int) -> None:
    """Empty cells (NaN, :data:`citylearn_env.dataset.MAY_BE_EMPTY`) are allowed only in columns nothing
    uses: not an active observation, and not the indoor temperature of a building with LSTM dynamics."""
    used = [c for c in dataset.MAY_BE_EMPTY if c in observed
            or (dynamics and c == "indoor_dry_bulb_temperature")]
    for column in used:
        empty = np.isnan(series[column])
        if empty.any():
            i = start + int(empty.argmax())
            why = "an active observation" if column in observed else "the LSTM dynamics' start temperature"
            raise SchemaError(f"empty cell in a column used as {why}", file=path, column=column,
                              row=f"{i} (file line {i + 2})")


def _read(path: Path, kind: str, n_rows: int, cache: dict, missing_hvac_mode_is_off: bool) -> dict[str, np.ndarray]:
    key = (str(path), kind)
    if key not in cache:
        cache[key] = dataset.read_table(path, kind, n_rows, missing_hvac_mode_is_off=missing_hvac_mode_is_off)
    return cache[key]
