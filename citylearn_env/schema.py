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

from citylearn_env import layout
from citylearn_env.config import (
    ACTION_NAMES,
    Battery,
    BuildingConfig,
    ConversionDevice,
    DistrictConfig,
    LSTMModel,
    Outage,
    Tank,
    frozen_series,
)
from citylearn_env.errors import SchemaError
from citylearn_env.registry import SLOT_CLASSES, resolve_type

#: columns (internal names) that must not be negative
NON_NEGATIVE = ("non_shiftable_load", "dhw_demand", "cooling_demand", "heating_demand", "solar_generation",
                "occupant_count")
#: later-version building columns that are accepted and ignored
IGNORED_NAMED_COLUMNS = ("minutes", "comfort_band", "indoor_dry_bulb_temperature_heating_set_point")


def load_schema(schema: str | Path | Mapping[str, Any], *, compat: bool = False) -> DistrictConfig:
    """Validate ``schema`` (a schema.json path or an already parsed dict) and read its data files.

    ``compat=True`` keeps CityLearn 2.1 defaults that differ from the documented ones (a missing
    ``hvac_mode`` column means "off"). Relative file names resolve against ``root_directory``, or the schema
    file's folder when that is null.
    """
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
    return _parse(raw, root, source, compat)


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


def _parse(raw: dict[str, Any], root: Path, source: str, compat: bool) -> DistrictConfig:
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
            _building(name, spec, root, start, end, cache, active_obs, active_actions, compat)
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


def _dynamics(spec: Mapping[str, Any] | None, root: Path, where: str) -> tuple[LSTMModel | None, ...]:
    if not spec:
        return None, None
    if "type" in spec:  # v2.2+: one model serves both modes
        model = _lstm(spec, root, where)
        return model, model
    return tuple(_lstm(spec.get(mode), root, f"{where}.{mode}") for mode in ("cooling", "heating"))


def _lstm(spec: Mapping[str, Any] | None, root: Path, where: str) -> LSTMModel | None:
    if spec is None:
        return None
    resolve_type("dynamics", spec.get("type"), where=f"{where}.type")
    a = spec.get("attributes") or {}
    try:
        names = tuple(a["input_observation_names"])
        lo = tuple(float(x) for x in a["input_normalization_minimum"])
        hi = tuple(float(x) for x in a["input_normalization_maximum"])
        model = LSTMModel(
            filepath=str(root / a["filename"]) if "filename" in a else str(a["filepath"]),
            input_observation_names=names, input_normalization_minimum=lo, input_normalization_maximum=hi,
            hidden_size=int(a["hidden_size"]), num_layers=int(a["num_layers"]), lookback=int(a["lookback"]),
        )
    except KeyError as error:
        raise SchemaError("missing attribute", column=f"{where}.attributes.{error.args[0]}") from error
    if not (len(names) == len(lo) == len(hi)) or len(names) != int(a.get("input_size", len(names))):
        raise SchemaError("input names, bounds and input_size disagree in length", column=f"{where}.attributes")
    if not Path(model.filepath).is_file():
        raise SchemaError("LSTM weights file not found", file=model.filepath, column=f"{where}.attributes.filename")
    return model


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


def _building(name, spec, root, start, end, cache, active_obs, active_actions, compat) -> BuildingConfig:
    where = f"buildings.{name}"
    btype = resolve_type("building", spec.get("type", "citylearn.building.Building"), where=f"{where}.type")
    for key in ("energy_simulation", "weather"):
        if not spec.get(key):
            raise SchemaError("missing data file name", column=f"{where}.{key}")
    n = end + 1
    series: dict[str, np.ndarray] = {}
    series.update(_read(root / spec["energy_simulation"], "building", n, cache, compat))
    series.update(_read(root / spec["weather"], "weather", n, cache, compat))
    for key, kind, cols in (("pricing", "pricing", layout.PRICING_COLUMNS),
                            ("carbon_intensity", "carbon", layout.CARBON_COLUMNS)):
        if spec.get(key):
            series.update(_read(root / spec[key], kind, n, cache, compat))
        else:
            series.update({c: np.zeros(n) for c in cols})
    series = {k: v[start : end + 1] for k, v in series.items()}
    devices = {slot: _device(slot, spec.get(slot), f"{where}.{slot}") for slot in SLOT_CLASSES}
    cooling_model, heating_model = (None, None)
    if btype == "LSTMDynamicsBuilding":
        cooling_model, heating_model = _dynamics(spec.get("dynamics"), root, f"{where}.dynamics")
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


_TABLES = {
    "building": layout.BUILDING_COLUMNS,
    "weather": layout.WEATHER_COLUMNS,
    "pricing": layout.PRICING_COLUMNS,
    "carbon": layout.CARBON_COLUMNS,
}


def _read(path: Path, kind: str, n_rows: int, cache: dict, compat: bool) -> dict[str, np.ndarray]:
    key = (str(path), kind)
    if key not in cache:
        cache[key] = parse_data_frame(_read_csv(path), kind, path, n_rows, compat)
    return cache[key]


def _read_csv(path: Path):
    import pandas as pd

    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except FileNotFoundError as error:
        raise SchemaError("data file not found", file=path) from error
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
        raise SchemaError(f"cannot parse as CSV: {error}", file=path) from error


def _columns_of(frame, kind: str, path: Path) -> dict[str, str]:
    """Map internal names to the frame's columns: by header name (v2.2+) or by position (v2.1)."""
    table = _TABLES[kind]
    headers = list(frame.columns)
    named = [layout.ALIASES.get(h, h) for h in headers]
    if kind == "carbon":  # by name in both layouts
        for h in headers:
            if h in ("kg_CO2/kWh", "carbon_intensity"):
                return {"carbon_intensity": h}
        raise SchemaError("missing carbon column (expected 'kg_CO2/kWh' or 'carbon_intensity')", file=path,
                          column="carbon_intensity")
    if set(named) & set(table):  # named layout
        unknown = [h for h, m in zip(headers, named, strict=True)
                   if m not in table and m not in IGNORED_NAMED_COLUMNS]
        if unknown:
            raise SchemaError(f"unexpected column(s) {unknown}; expected names from: {', '.join(table)}",
                              file=path, column=unknown[0])
        mapping = {m: h for h, m in zip(headers, named, strict=True) if m in table}
        required = list(table)[: layout.BUILDING_REQUIRED] if kind == "building" else list(table)
        required = [c for c in required if c not in ("daylight_savings_status",
                                                     "average_unmet_cooling_setpoint_difference",
                                                     "indoor_relative_humidity")]
        for col in required:
            if col not in mapping:
                raise SchemaError("missing column", file=path, column=col)
        return mapping
    lo = layout.BUILDING_REQUIRED if kind == "building" else len(table)
    if not lo <= len(headers) <= len(table):
        expected = f"{lo} to {len(table)}" if lo != len(table) else f"{lo}"
        raise SchemaError(f"has {len(headers)} columns, the v2.1 layout has {expected} (by position: "
                          f"{', '.join(table.values())})", file=path,
                          column=headers[len(table)] if len(headers) > len(table) else list(table.values())[len(headers)])
    return dict(zip(table, headers, strict=False))


def parse_data_frame(frame, kind: str, path: Path, n_rows: int, compat: bool = False) -> dict[str, np.ndarray]:
    """Validate one data frame (all cells as strings) of ``kind`` and return float arrays by internal name."""
    mapping = _columns_of(frame, kind, path)
    if len(frame) < n_rows:
        raise SchemaError(f"has {len(frame)} data rows; the schema's simulation range needs {n_rows}",
                          file=path, row=len(frame))
    out: dict[str, np.ndarray] = {}
    for name, col in mapping.items():
        text = frame[col].to_numpy()[:n_rows]
        try:
            values = np.asarray(text, dtype=np.float64)
        except ValueError:
            bad = _first_bad_number(text)
            raise SchemaError(f"not a number: {text[bad]!r}", file=path, column=col, row=_row(bad)) from None
        if np.isnan(values).any():
            raise SchemaError("missing value (NaN)", file=path, column=col, row=_row(int(np.isnan(values).argmax())))
        if name in NON_NEGATIVE and (values < 0).any():
            i = int((values < 0).argmax())
            raise SchemaError(f"negative value {values[i]:g}", file=path, column=col, row=_row(i))
        out[name] = values.astype(np.float32).astype(np.float64)
    if kind == "building":
        both = (out["cooling_demand"] > 0) & (out["heating_demand"] > 0)
        if both.any():
            i = int(both.argmax())
            raise SchemaError("cooling_demand and heating_demand are both > 0", file=path,
                              column=f"{mapping['cooling_demand']} / {mapping['heating_demand']}", row=_row(i))
        _defaults(out, n_rows, compat)
        for name in ("hvac_mode", "power_outage"):
            bad = ~np.isin(out[name], (0, 1, 2) if name == "hvac_mode" else (0, 1))
            if bad.any():
                i = int(bad.argmax())
                raise SchemaError(f"invalid value {out[name][i]:g}", file=path, column=mapping.get(name, name),
                                  row=_row(i))
    if kind == "weather" and "outdoor_relative_humidity" in out:
        rh = out["outdoor_relative_humidity"]
        if ((rh < 0) | (rh > 100)).any():
            i = int(((rh < 0) | (rh > 100)).argmax())
            raise SchemaError(f"relative humidity {rh[i]:g} outside 0..100 %", file=path,
                              column=mapping["outdoor_relative_humidity"], row=_row(i))
    return out


def _defaults(out: dict[str, np.ndarray], n: int, compat: bool) -> None:
    for name in ("daylight_savings_status", "average_unmet_cooling_setpoint_difference",
                 "indoor_relative_humidity", "occupant_count", "indoor_dry_bulb_temperature_set_point",
                 "power_outage"):
        out.setdefault(name, np.zeros(n))
    # CityLearn 2.1 treats a missing hvac_mode column as 0 (off); its docs and later versions mean cooling.
    out.setdefault("hvac_mode", np.full(n, 0.0 if compat else 1.0))


def _first_bad_number(text) -> int:
    for i, cell in enumerate(text):
        try:
            float(cell)
        except ValueError:
            return i
    return 0


def _row(i: int) -> str:
    """Describe data row ``i`` (0-based, after the header) for messages."""
    return f"{i} (file line {i + 2})"
