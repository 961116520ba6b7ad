"""THE table of accepted values: every number a schema or data file gives, with its physical range and unit.

Readers call in here once per value (a CSV column, a device attribute, a schema key): a number that is not
finite (``nan``, ``inf``, ``1e400``) or lies outside its documented range is a
:class:`~citylearn_env.errors.SchemaError` naming the file or key, the column and the first bad row. The
ranges are physical or definitional limits with a margin, wide enough for every upstream CityLearn data set
(v2.1.2 and v2.4.2) and every pipeline build; they are not plausibility checks. docs/bad_input.md prints
the same table (:func:`markdown_table`).

Also here: the JSON shape of a schema (:data:`SCHEMA_KEYS`, :data:`BUILDING_KEYS`, :func:`check_schema_shape`):
an unknown top-level key is an error that names the closest known key; a wrong JSON type is an error naming
the key. New dataset vocabulary (a top-level key, a building key, a device attribute) is added to these
tables.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from citylearn_env.errors import SchemaError


@dataclass(frozen=True)
class Range:
    """Accepted values ``low <= x <= high`` (``<`` where ``low_open``), in ``unit``; ``integer``: whole numbers
    only. Every accepted value is finite."""

    low: float
    high: float
    unit: str = ""
    low_open: bool = False
    integer: bool = False
    note: str = ""

    def outside(self, values: Any) -> np.ndarray:
        """Boolean mask of the values this range refuses (NaN and +-inf included)."""
        x = np.asarray(values, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(x) | (x > self.high) | ((x <= self.low) if self.low_open else (x < self.low))
            if self.integer:
                bad |= np.isfinite(x) & (x != np.round(x))
        return bad

    def text(self) -> str:
        """``"0 < x <= 1"``, ``"1 <= x <= 12 (integer)"``; the unit after the range."""
        low = f"{self.low:g} {'<' if self.low_open else '<='} x <= {self.high:g}"
        return low + (" (integer)" if self.integer else "") + (f" {self.unit}" if self.unit else "")


def _same(names: tuple[str, ...], r: Range) -> dict[str, Range]:
    return dict.fromkeys(names, r)


_PREDICTED = ("", "_predicted_6h", "_predicted_12h", "_predicted_24h")
_LOAD = Range(0.0, 1e6, "kWh per time step")
_FRACTION = Range(0.0, 1.0)
_EFFICIENCY = Range(0.0, 1.0, low_open=True, note="0 would divide by zero; above 1 creates energy")
_POWER = Range(0.0, 1e6, "kW")
_CAPACITY = Range(0.0, 1e6, "kWh")

#: data-file columns (internal v2.2 names; every column of citylearn_env.dataset.TABLES) -> accepted range
COLUMN_RANGES: dict[str, Range] = {
    "month": Range(1, 12, integer=True),
    "hour": Range(1, 24, "hour-ending", integer=True),
    "day_type": Range(1, 8, "1 = Monday .. 7 = Sunday, 8 = holiday", integer=True),
    "daylight_savings_status": Range(0, 1, integer=True),
    "indoor_dry_bulb_temperature": Range(-50.0, 80.0, "degC"),
    "average_unmet_cooling_setpoint_difference": Range(-100.0, 100.0, "K"),
    "indoor_relative_humidity": Range(0.0, 100.0, "%"),
    **_same(("non_shiftable_load", "dhw_demand", "cooling_demand", "heating_demand"), _LOAD),
    "solar_generation": Range(0.0, 2000.0, "W per kW of PV", note="AC yield; about 1000 at most in sunlight"),
    "occupant_count": Range(0.0, 1e5, "people"),
    "indoor_dry_bulb_temperature_set_point": Range(-50.0, 80.0, "degC", note="0 where a data set has none"),
    "hvac_mode": Range(0, 3, "0 off, 1 cooling, 2 heating, 3 auto (CityLearn 2.4+)", integer=True),
    "power_outage": Range(0, 1, integer=True),
    **_same(("indoor_dry_bulb_temperature_cooling_set_point", "indoor_dry_bulb_temperature_heating_set_point"),
            Range(-50.0, 80.0, "degC")),
    "comfort_band": Range(0.0, 50.0, "K"),
    **_same(tuple("outdoor_dry_bulb_temperature" + p for p in _PREDICTED),
            Range(-100.0, 80.0, "degC", note="records -89.2 / 56.7 degC, with a margin for forecast noise")),
    "outdoor_relative_humidity": Range(0.0, 100.0, "%"),
    **_same(tuple("outdoor_relative_humidity" + p for p in _PREDICTED[1:]),
            Range(0.0, 150.0, "%", note="noisy forecasts exceed 100 (upstream 2021 data: 110)")),
    **_same(tuple(base + p for base in ("diffuse_solar_irradiance", "direct_solar_irradiance") for p in _PREDICTED),
            Range(0.0, 2000.0, "W/m2", note="the solar constant is 1361 W/m2")),
    **_same(tuple("electricity_pricing" + p for p in _PREDICTED),
            Range(-100.0, 100.0, "$/kWh", note="negative prices occur; ERCOT's cap is 5 $/kWh")),
    "carbon_intensity": Range(0.0, 5.0, "kg CO2e/kWh", note="coal plants emit about 1"),
}

#: device attributes: (device class, attribute) -> accepted range. Units as in citylearn_env.config.
ATTRIBUTE_RANGES: dict[tuple[str, str], Range] = {
    ("HeatPump", "nominal_power"): _POWER,
    ("HeatPump", "efficiency"): Range(0.0, 1.0, "Carnot fraction", low_open=True,
                                      note="0 gives COP 0 (division by zero)"),
    ("HeatPump", "target_cooling_temperature"): Range(-50.0, 50.0, "degC"),
    ("HeatPump", "target_heating_temperature"): Range(0.0, 100.0, "degC"),
    ("ElectricHeater", "nominal_power"): _POWER,
    ("ElectricHeater", "efficiency"): _EFFICIENCY,
    ("StorageTank", "capacity"): _CAPACITY,
    ("StorageTank", "efficiency"): _EFFICIENCY,
    ("StorageTank", "loss_coefficient"): Range(0.0, 1.0, "fraction per time step"),
    ("StorageTank", "initial_soc"): _FRACTION,
    ("StorageTank", "max_input_power"): _POWER,
    ("StorageTank", "max_output_power"): _POWER,
    ("Battery", "capacity"): _CAPACITY,
    ("Battery", "nominal_power"): _POWER,
    ("Battery", "efficiency"): _EFFICIENCY,
    ("Battery", "loss_coefficient"): Range(0.0, 1.0, "fraction per time step"),
    ("Battery", "capacity_loss_coefficient"): Range(0.0, 1.0, "fraction per kWh cycled"),
    ("Battery", "depth_of_discharge"): Range(0.0, 1.0, note="above 1 lets the state of charge go negative"),
    ("Battery", "initial_soc"): _FRACTION,
    ("PV", "nominal_power"): _POWER,
}
#: points of the battery curves ``[[x, y], ...]``: x (power fraction or state of charge) and y (a fraction)
CURVE_RANGE = _FRACTION

#: single numbers of a schema, by key (top level, power outage model, LSTM dynamics attributes)
KEY_RANGES: dict[str, Range] = {
    "simulation_start_time_step": Range(0, 1e8, "time steps", integer=True),
    "simulation_end_time_step": Range(0, 1e8, "time steps", integer=True),
    "seconds_per_time_step": Range(1.0, 86400.0, "s"),
    "random_seed": Range(0, 2**32 - 1, integer=True),
    "saifi": Range(0.0, 1000.0, "interruptions per year"),
    "caidi": Range(0.0, 525600.0, "minutes per interruption"),
    "hidden_size": Range(1, 4096, integer=True),
    "num_layers": Range(1, 64, integer=True),
    "lookback": Range(1, 8760, "time steps", integer=True),
    "input_size": Range(1, 1000, integer=True),
}

# ------------------------------------------------------------------------------------------ checks
_NUMBER = (int, float)


def first_outside(name: str, values: Any) -> tuple[int, str] | None:
    """``(row, message)`` of the first value of data column ``name`` outside its range, or None.

    A column without a listed range must still be finite. NaN (a missing value) is left to the reader,
    which knows the columns that may be empty.
    """
    r = COLUMN_RANGES.get(name, Range(-math.inf, math.inf))
    bad = r.outside(values) & ~np.isnan(np.asarray(values, dtype=np.float64))
    if not bad.any():
        return None
    i = int(bad.argmax())
    return i, _describe(float(np.asarray(values, dtype=np.float64)[i]), r)


def _describe(value: float, r: Range) -> str:
    if not math.isfinite(value):
        return f"not a finite number: {value!r}"
    return f"{value:g} is outside the accepted range {r.text()}"


def check_number(value: Any, r: Range | None, *, where: str, file: object = None) -> float:
    """``value`` as a float, checked: a JSON number (not a bool), finite, within ``r`` (when given)."""
    if isinstance(value, bool) or not isinstance(value, _NUMBER):
        raise SchemaError(f"expected a number, got {_short(value)}", file=file, column=where)
    if not math.isfinite(value) or (r is not None and r.outside(value)):
        raise SchemaError(_describe(float(value), r or Range(-math.inf, math.inf)), file=file, column=where)
    return float(value)


def check_key(raw: Mapping[str, Any], key: str, default: Any, *, where: str, file: object = None) -> Any:
    """The number at ``raw[key]`` (``default`` when absent or null) checked against :data:`KEY_RANGES`;
    an int for integer ranges."""
    value = raw.get(key)
    if value is None:
        return default
    r = KEY_RANGES[key]
    number = check_number(value, r, where=where, file=file)
    return int(number) if r.integer else number


def check_attribute(device: str, key: str, value: Any, *, where: str) -> None:
    """One device attribute: a finite number within :data:`ATTRIBUTE_RANGES` (unlisted: finite, >= 0)."""
    check_number(value, ATTRIBUTE_RANGES.get((device, key), Range(0.0, math.inf)), where=where)


def check_curve(points: Any, *, where: str) -> tuple[tuple[float, float], ...]:
    """A battery curve ``[[x, y], ...]`` (at least one point, x increasing) as float pairs within 0..1."""
    if not isinstance(points, list | tuple) or not points or not all(
            isinstance(p, list | tuple) and len(p) == 2 for p in points):
        raise SchemaError(f"expected a list of [x, y] points, got {_short(points)}", column=where)
    out = tuple((check_number(x, CURVE_RANGE, where=f"{where}[{i}][0]"),
                 check_number(y, CURVE_RANGE, where=f"{where}[{i}][1]")) for i, (x, y) in enumerate(points))
    if any(b[0] <= a[0] for a, b in zip(out, out[1:], strict=False)):
        raise SchemaError("x values must increase from point to point", column=where)
    return out


def _short(value: Any) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text[:40] + '...' if len(text) > 40 else text}"


# ------------------------------------------------------------------------------------------ schema shape
_DICT, _LIST, _STR, _BOOL, _INT, _NONE = Mapping, list, str, bool, int, type(None)

#: top-level schema keys -> accepted JSON types (CityLearn 2.1 and 2.2-2.5 vocabulary)
SCHEMA_KEYS: dict[str, tuple[type, ...]] = {
    "root_directory": (_STR, _NONE), "central_agent": (_BOOL, _NONE),
    "simulation_start_time_step": (_INT, _NONE), "simulation_end_time_step": (_INT,),
    "episode_time_steps": (_INT, _LIST, _NONE), "rolling_episode_split": (_BOOL, _NONE),
    "random_episode_split": (_BOOL, _NONE), "seconds_per_time_step": (_INT, float, _NONE),
    "observations": (_DICT,), "actions": (_DICT,), "agent": (_DICT, _NONE),
    "reward_function": (_DICT, _NONE), "buildings": (_DICT,), "random_seed": (_INT, _NONE),
    "electric_vehicles_def": (_DICT, _NONE),
}
#: building keys that are type-checked (others are left to the loader)
BUILDING_KEYS: dict[str, tuple[type, ...]] = {
    "type": (_STR,), "include": (_BOOL, _NONE), "energy_simulation": (_STR,), "weather": (_STR,),
    "pricing": (_STR, _NONE), "carbon_intensity": (_STR, _NONE), "inactive_observations": (_LIST, _NONE),
    "inactive_actions": (_LIST, _NONE), "dynamics": (_DICT, _NONE), "power_outage": (_DICT, _NONE),
    **dict.fromkeys(("cooling_device", "heating_device", "dhw_device", "cooling_storage", "heating_storage",
                     "dhw_storage", "electrical_storage", "pv"), (_DICT, _NONE)),
}
_ENTRY_KEYS = {"active": (_BOOL, _NONE), "shared_in_central_agent": (_BOOL, _NONE)}
_DEVICE_KEYS = {"type": (_STR,), "autosize": (_BOOL, _NONE), "attributes": (_DICT, _NONE)}
_OUTAGE_KEYS = {"simulate_power_outage": (_BOOL, _NONE), "stochastic_power_outage": (_BOOL, _NONE),
                "stochastic_power_outage_model": (_DICT, _NONE)}
_OUTAGE_MODEL_KEYS = {"type": (_STR, _NONE), "attributes": (_DICT, _NONE)}


def closest_key(key: str, known: Any) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``known`` (difflib), or ``""``."""
    match = difflib.get_close_matches(str(key), list(known), n=1, cutoff=0.6)
    return f"; did you mean {match[0]!r}?" if match else ""


def _types(value: Any, kinds: tuple[type, ...], where: str) -> None:
    if isinstance(value, bool) and _BOOL not in kinds:
        ok = False
    else:
        ok = isinstance(value, kinds) and not (isinstance(value, float) and not math.isfinite(value))
    if not ok:
        names = " or ".join("null" if k is _NONE else "object" if k is _DICT else k.__name__ for k in kinds)
        raise SchemaError(f"expected {names}, got {_short(value)}", column=where)


def _check_keys(d: Mapping[str, Any], table: Mapping[str, tuple[type, ...]], where: str) -> None:
    for key, kinds in table.items():
        if key in d:
            _types(d[key], kinds, f"{where}{key}")


def check_schema_shape(raw: Any) -> None:
    """The JSON shape of a whole schema: known top-level keys (an unknown one names the closest known key),
    the JSON types of :data:`SCHEMA_KEYS`, each observation/action an object with boolean flags, each building
    an object with the types of :data:`BUILDING_KEYS`, each device an object. One SchemaError naming the key."""
    if not isinstance(raw, Mapping):
        raise SchemaError(f"a schema must be a JSON object, got {_short(raw)}")
    for key in raw:
        if key not in SCHEMA_KEYS:
            raise SchemaError(f"unknown top-level key{closest_key(key, SCHEMA_KEYS)}", column=str(key))
    _check_keys(raw, SCHEMA_KEYS, "")
    for group in ("observations", "actions"):
        for name, entry in (raw.get(group) or {}).items():
            _types(entry, (_DICT,), f"{group}.{name}")
            _check_keys(entry, _ENTRY_KEYS, f"{group}.{name}.")
    for name, spec in raw.get("buildings", {}).items():
        _check_building_shape(spec, f"buildings.{name}")


def _check_building_shape(spec: Any, where: str) -> None:
    """One building entry: an object with the types of :data:`BUILDING_KEYS`, string lists of inactive
    names, each device an object with the types of its keys, the power outage and its model."""
    _types(spec, (_DICT,), where)
    _check_keys(spec, BUILDING_KEYS, f"{where}.")
    for key in ("inactive_observations", "inactive_actions"):
        for i, item in enumerate(spec.get(key) or []):
            _types(item, (_STR,), f"{where}.{key}[{i}]")
    for slot, kinds in BUILDING_KEYS.items():
        if kinds == (_DICT, _NONE) and isinstance(spec.get(slot), Mapping) and slot not in (
                "dynamics", "power_outage"):
            _check_keys(spec[slot], _DEVICE_KEYS, f"{where}.{slot}.")
    outage = spec.get("power_outage") or {}
    _check_keys(outage, _OUTAGE_KEYS, f"{where}.power_outage.")
    _check_keys(outage.get("stochastic_power_outage_model") or {}, _OUTAGE_MODEL_KEYS,
                f"{where}.power_outage.stochastic_power_outage_model.")


def check_dynamics_attributes(attributes: Any, *, where: str) -> None:
    """One LSTM ``dynamics`` attributes object: the integer sizes of :data:`KEY_RANGES`, the input names a list
    of strings, the normalization bounds lists of finite numbers, the file name a string."""
    _types(attributes, (_DICT,), where)
    for key in ("hidden_size", "num_layers", "lookback", "input_size"):
        if key in attributes:
            check_key(attributes, key, None, where=f"{where}.{key}")
    for key in ("filename", "filepath"):
        if key in attributes:
            _types(attributes[key], (_STR,), f"{where}.{key}")
    for key in ("input_observation_names", "input_normalization_minimum", "input_normalization_maximum"):
        values = attributes.get(key)
        if values is None:
            continue
        _types(values, (_LIST,), f"{where}.{key}")
        for i, item in enumerate(values):
            if key == "input_observation_names":
                _types(item, (_STR,), f"{where}.{key}[{i}]")
            else:
                check_number(item, None, where=f"{where}.{key}[{i}]")


def markdown_table() -> str:
    """All ranges as markdown tables (data columns, device attributes, schema keys), for docs/bad_input.md."""
    lines = ["| data column | accepted | note |", "|---|---|---|"]
    lines += [f"| `{name}` | {r.text()} | {r.note} |" for name, r in COLUMN_RANGES.items()]
    lines += ["", "| device attribute | accepted | note |", "|---|---|---|"]
    lines += [f"| `{dev}.{key}` | {r.text()} | {r.note} |" for (dev, key), r in ATTRIBUTE_RANGES.items()]
    lines += [f"| battery curve points `[x, y]` | x and y: {CURVE_RANGE.text()} | x increasing |"]
    lines += ["", "| schema key | accepted | note |", "|---|---|---|"]
    lines += [f"| `{key}` | {r.text()} | {r.note} |" for key, r in KEY_RANGES.items()]
    return "\n".join(lines) + "\n"


__all__ = ["ATTRIBUTE_RANGES", "BUILDING_KEYS", "COLUMN_RANGES", "CURVE_RANGE", "KEY_RANGES", "Range",
           "SCHEMA_KEYS", "check_attribute", "check_curve", "check_dynamics_attributes", "check_key",
           "check_number", "check_schema_shape", "closest_key", "first_outside", "markdown_table"]
