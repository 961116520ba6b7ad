"""Load a CityLearn v2 schema (path or dict) and its data files into a frozen :class:`DistrictConfig`.

Validation happens here, once: every problem is a :class:`SchemaError` naming the file or schema key, the
column and the first bad row. The caller's dict is never modified (it is deep-copied before anything else).
Data values are rounded to float32 and held as float64, as CityLearn 2.1 holds its data series.
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import dataset
from citylearn_env.config import (
    ACTION_NAMES,
    Battery,
    BuildingConfig,
    ConversionDevice,
    DistrictConfig,
    Outage,
    Tank,
    frozen_series,
)
from citylearn_env.errors import SchemaError
from citylearn_env.registry import SLOT_CLASSES, resolve_type
from citylearn_env.settings import Behaviour, resolve


def load_schema(schema: str | Path | Mapping[str, Any], *,
                settings: Behaviour | str | None = None) -> DistrictConfig:
    """Validate ``schema`` (a schema.json path or an already parsed dict) and read its data files.

    ``settings`` (a :class:`~citylearn_env.settings.Behaviour` or a preset name such as "citylearn-2.1")
    decides the data-set defaults that differ between CityLearn 2.1 and its
    documentation: ``missing_hvac_mode_is_off`` (a building file without ``hvac_mode`` runs mode 0 "off"
    instead of 1 "cooling"). Relative file names resolve against ``root_directory``, or the schema file's
    folder when that is null.
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
        default_root, source = path.resolve().parent, str(path)
    elif isinstance(schema, Mapping):
        raw = copy.deepcopy(dict(schema))
        default_root, source = Path.cwd(), "<schema dict>"
    else:
        raise SchemaError(f"a schema must be a path or a dict, got {type(schema).__name__}")
    root = Path(raw.get("root_directory") or default_root)
    return _parse(raw, root, source, settings.missing_hvac_mode_is_off)


def _get(d: Mapping[str, Any], key: str, default: Any, kind: type | tuple[type, ...], where: str) -> Any:
    value = d.get(key, default)
    if value is None:
        return default
    if kind in (float, int) and isinstance(value, bool):
        raise SchemaError(f"expected a number, got {value!r}", column=f"{where}.{key}")
    if kind is float and isinstance(value, int):
        value = float(value)
    if not isinstance(value, kind):
        raise SchemaError(f"expected {getattr(kind, '__name__', kind)}, got {value!r}", column=f"{where}.{key}")
    return value


def _parse(raw: dict[str, Any], root: Path, source: str, missing_hvac_mode_is_off: bool) -> DistrictConfig:
    start = _get(raw, "simulation_start_time_step", 0, int, "schema")
    end = _get(raw, "simulation_end_time_step", None, int, "schema")
    if end is None or end < start:
        raise SchemaError("must be an integer >= simulation_start_time_step", column="simulation_end_time_step")
    observations = raw.get("observations")
    if not isinstance(observations, Mapping) or not observations:
        raise SchemaError("missing or empty", column="observations")
    actions = raw.get("actions", {})
    for name in actions:
        if name not in ACTION_NAMES:
            raise SchemaError(f"unknown action; known actions: {', '.join(ACTION_NAMES)}", column=f"actions.{name}")
    active_obs = [n for n, v in observations.items() if v.get("active", False)]
    active_actions = [n for n, v in actions.items() if v.get("active", False)]  # schema order
    buildings_raw = raw.get("buildings")
    if not isinstance(buildings_raw, Mapping) or not buildings_raw:
        raise SchemaError("missing or empty", column="buildings")
    cache: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    buildings = []
    for name, spec in buildings_raw.items():
        if not spec.get("include", True):
            continue
        buildings.append(
            _building(name, spec, root, start, end, cache, active_obs, active_actions, missing_hvac_mode_is_off)
        )
    if not buildings:
        raise SchemaError("no building has include = true", column="buildings")
    episode = raw.get("episode_time_steps")
    if isinstance(episode, list):
        episode = tuple((int(a), int(b)) for a, b in episode)
    elif episode is not None and not isinstance(episode, int):
        raise SchemaError("must be null, an int or a list of [start, end]", column="episode_time_steps")
    seconds = float(raw.get("seconds_per_time_step", 3600.0))
    if not seconds >= 1:
        raise SchemaError("must be >= 1", column="seconds_per_time_step")
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
    )


def _device(slot: str, spec: Mapping[str, Any] | None, where: str) -> Any:
    if spec is None:
        return None
    cls = resolve_type("device", spec.get("type"), where=f"{where}.type")
    if cls not in SLOT_CLASSES[slot]:
        raise SchemaError(f"a {cls} cannot be used as {slot}; allowed: {', '.join(SLOT_CLASSES[slot])}",
                          column=f"{where}.type")
    if spec.get("autosize", False):
        raise SchemaError("autosize is not supported: give the sizes (districtgen's pipeline sizes devices)",
                          column=f"{where}.autosize")
    attrs = dict(spec.get("attributes") or {})
    attrs.pop("seconds_per_time_step", None)
    for key, value in attrs.items():
        if key.endswith("_curve"):
            try:
                attrs[key] = tuple((float(x), float(y)) for x, y in value)
            except (TypeError, ValueError) as error:
                raise SchemaError("expected a list of [x, y] points", column=f"{where}.attributes.{key}") from error
        elif value is None:
            continue
        elif not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise SchemaError(f"expected a finite number, got {value!r}", column=f"{where}.attributes.{key}")
        elif value < 0:
            raise SchemaError(f"must not be negative, got {value!r}", column=f"{where}.attributes.{key}")
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
    return Outage(
        simulate=bool(spec.get("simulate_power_outage", False)), stochastic=stochastic,
        saifi=float(attrs.get("saifi", 1.436)), caidi=float(attrs.get("caidi", 331.2)),
        random_seed=attrs.get("random_seed"), start_time_steps=tuple(starts) if starts is not None else None,
    )


def _building(name, spec, root, start, end, cache, active_obs, active_actions,
              missing_hvac_mode_is_off: bool) -> BuildingConfig:
    where = f"buildings.{name}"
    btype = resolve_type("building", spec.get("type", "citylearn.building.Building"), where=f"{where}.type")
    for key in ("energy_simulation", "weather"):
        if not spec.get(key):
            raise SchemaError("missing data file name", column=f"{where}.{key}")
    n = end + 1
    series: dict[str, np.ndarray] = {}
    hvac_off = missing_hvac_mode_is_off
    series.update(_read(root / spec["energy_simulation"], "building", n, cache, hvac_off))
    series.update(_read(root / spec["weather"], "weather", n, cache, hvac_off))
    for key, kind, cols in (("pricing", "pricing", dataset.PRICING_COLUMNS),
                            ("carbon_intensity", "carbon", dataset.CARBON_COLUMNS)):
        if spec.get(key):
            series.update(_read(root / spec[key], kind, n, cache, hvac_off))
        else:
            series.update({c: np.zeros(n) for c in cols})
    series = {k: v[start : end + 1] for k, v in series.items()}
    devices = {slot: _device(slot, spec.get(slot), f"{where}.{slot}") for slot in SLOT_CLASSES}
    cooling_model, heating_model = (None, None)
    if btype == "LSTMDynamicsBuilding":
        cooling_model, heating_model = dataset.parse_dynamics(spec.get("dynamics"), root, where=f"{where}.dynamics")
    inactive_obs = set(spec.get("inactive_observations") or [])
    inactive_act = set(spec.get("inactive_actions") or [])
    kwargs = {slot: dev for slot, dev in devices.items() if dev is not None and slot != "pv"}
    return BuildingConfig(
        name=name, series=frozen_series(series), **kwargs,
        pv_nominal_power=devices["pv"] or 0.0,
        outage=_outage(spec.get("power_outage"), f"{where}.power_outage"),
        cooling_model=cooling_model, heating_model=heating_model,
        active_observations=tuple(o for o in active_obs if o not in inactive_obs),
        active_actions=tuple(a for a in active_actions if a not in inactive_act),
    )


def _read(path: Path, kind: str, n_rows: int, cache: dict, missing_hvac_mode_is_off: bool) -> dict[str, np.ndarray]:
    key = (str(path), kind)
    if key not in cache:
        cache[key] = dataset.read_table(path, kind, n_rows, missing_hvac_mode_is_off=missing_hvac_mode_is_off)
    return cache[key]
