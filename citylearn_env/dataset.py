"""The CityLearn dataset contract: column tables, CSV reading/writing, calendar, periodic encodings, LSTM block.

Every writer and reader of CityLearn data files in districtgen goes through this module.

Layouts
    * ``"v2.1"`` (CityLearn 2.1.x, behind the SimBuild 2024 results): human-readable header texts. CityLearn
      2.1 reads these files **by position**; we match them **by header text** (every real spelling of the
      upstream data sets is accepted, see :data:`V21_HEADERS`) and then require the columns to stand where
      CityLearn 2.1 expects them, so a dropped, extra, renamed or swapped column is an error instead of a
      silent shift of every later column.
    * ``"v2.2"`` (CityLearn 2.2 and later): snake_case names, read by name in any order. The later aliases
      ``*_predicted_1/2/3`` (the 6/12/24 h slots) are accepted too; the v2.2+ building columns
      ``indoor_dry_bulb_temperature_cooling_set_point`` / ``..._heating_set_point`` and ``comfort_band`` are
      read (see :func:`_set_points`); ``minutes`` is accepted and ignored.

Each column table maps our internal name (the v2.2 header) to the canonical v2.1 header text, in file order.

Units: energies in kWh per time step (``non_shiftable_load``, ``dhw_demand``, ``cooling_demand``,
``heating_demand``); temperatures in degC; relative humidity in %; irradiance in W/m2; ``solar_generation``
in W of AC output per kW of installed PV; ``occupant_count`` in people; prices in $/kWh; carbon intensity in
kg CO2e/kWh. Calendar: ``month`` 1..12; ``hour`` 1..24, hour-ending (row 0 is hour 1, the hour that ends at
01:00); ``day_type`` 1 = Monday ... 7 = Sunday, 8 = holiday; ``daylight_savings_status`` 0/1;
``hvac_mode`` 0 off, 1 cooling, 2 heating, 3 auto (CityLearn 2.4+: both devices available, see
:mod:`citylearn_env.thermal`); ``power_outage`` 0/1.

Reading returns float64 arrays rounded through float32 (as CityLearn 2.1 holds its data series).
"""

from __future__ import annotations

import datetime as dt
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from citylearn_env import ranges
from citylearn_env.errors import SchemaError
from citylearn_env.registry import resolve_type

if TYPE_CHECKING:  # pandas is imported where a table is built (importing citylearn_env stays light)
    import pandas as pd

LAYOUTS = ("v2.1", "v2.2")
KINDS = ("building", "weather", "pricing", "carbon")

# ------------------------------------------------------------------------------------------ column tables
#: building ``energy_simulation`` file: internal name -> canonical v2.1 header
BUILDING_COLUMNS: dict[str, str] = {
    "month": "Month",
    "hour": "Hour",
    "day_type": "Day Type",
    "daylight_savings_status": "Daylight Savings Status",
    "indoor_dry_bulb_temperature": "Indoor Temperature (C)",
    "average_unmet_cooling_setpoint_difference": "Average Unmet Cooling Setpoint Difference (C)",
    "indoor_relative_humidity": "Indoor Relative Humidity (%)",
    "non_shiftable_load": "Equipment Electric Power (kWh)",
    "dhw_demand": "DHW Heating (kWh)",
    "cooling_demand": "Cooling Load (kWh)",
    "heating_demand": "Heating Load (kWh)",
    "solar_generation": "Solar Generation (W/kW)",
    "occupant_count": "Occupant Count (people)",
    "indoor_dry_bulb_temperature_set_point": "Temperature Set Point (C)",
    "hvac_mode": "HVAC Mode (Off/Cooling/Heating)",
    "power_outage": "Power Outage",
    # v2.2+ only (no CityLearn 2.1 file has them; the texts name them if a v2.1-layout file is written)
    "indoor_dry_bulb_temperature_cooling_set_point": "Cooling Set Point (C)",
    "indoor_dry_bulb_temperature_heating_set_point": "Heating Set Point (C)",
    "comfort_band": "Comfort Band (C)",
}
#: the first 12 building columns are required; the rest default (occupants 0, set point 0, hvac_mode see
#: :func:`parse_table`, power_outage 0)
BUILDING_REQUIRED = 12

WEATHER_COLUMNS: dict[str, str] = {
    "outdoor_dry_bulb_temperature": "Outdoor Drybulb Temperature (C)",
    "outdoor_relative_humidity": "Outdoor Relative Humidity (%)",
    "diffuse_solar_irradiance": "Diffuse Solar Radiation (W/m2)",
    "direct_solar_irradiance": "Direct Solar Radiation (W/m2)",
    "outdoor_dry_bulb_temperature_predicted_6h": "6h Outdoor Drybulb Temperature (C)",
    "outdoor_dry_bulb_temperature_predicted_12h": "12h Outdoor Drybulb Temperature (C)",
    "outdoor_dry_bulb_temperature_predicted_24h": "24h Outdoor Drybulb Temperature (C)",
    "outdoor_relative_humidity_predicted_6h": "6h Outdoor Relative Humidity (%)",
    "outdoor_relative_humidity_predicted_12h": "12h Outdoor Relative Humidity (%)",
    "outdoor_relative_humidity_predicted_24h": "24h Outdoor Relative Humidity (%)",
    "diffuse_solar_irradiance_predicted_6h": "6h Diffuse Solar Radiation (W/m2)",
    "diffuse_solar_irradiance_predicted_12h": "12h Diffuse Solar Radiation (W/m2)",
    "diffuse_solar_irradiance_predicted_24h": "24h Diffuse Solar Radiation (W/m2)",
    "direct_solar_irradiance_predicted_6h": "6h Direct Solar Radiation (W/m2)",
    "direct_solar_irradiance_predicted_12h": "12h Direct Solar Radiation (W/m2)",
    "direct_solar_irradiance_predicted_24h": "24h Direct Solar Radiation (W/m2)",
}

PRICING_COLUMNS: dict[str, str] = {
    "electricity_pricing": "Electricity Pricing [$/kWh]",
    "electricity_pricing_predicted_6h": "6h Prediction Electricity Pricing [$/kWh]",
    "electricity_pricing_predicted_12h": "12h Prediction Electricity Pricing [$/kWh]",
    "electricity_pricing_predicted_24h": "24h Prediction Electricity Pricing [$/kWh]",
}

CARBON_COLUMNS: dict[str, str] = {"carbon_intensity": "kg_CO2/kWh"}

TABLES: dict[str, dict[str, str]] = {
    "building": BUILDING_COLUMNS,
    "weather": WEATHER_COLUMNS,
    "pricing": PRICING_COLUMNS,
    "carbon": CARBON_COLUMNS,
}


def _v21_spellings() -> dict[str, str]:
    """Every v2.1 header text found in the upstream data sets -> internal name.

    Collected from all building, weather, pricing and carbon CSVs of the 16 CityLearn 2.1.2 data sets and of
    the golden-trace data set: the canonical texts of the tables above, their square-bracket spellings
    (``"Indoor Temperature [C]"``), the ``"6h Prediction ..."`` weather spellings, ``"Relative Humidity [%]"``
    and the ``1h/2h/3h`` price forecasts of ``baeda_3dem`` (which CityLearn 2.1 reads into the 6/12/24 h
    slots by position).
    """
    table: dict[str, str] = {}
    for columns in TABLES.values():
        for name, text in columns.items():
            table[text] = name
            table[text.replace("(", "[").replace(")", "]")] = name
    for base, text in (("outdoor_dry_bulb_temperature", "Outdoor Drybulb Temperature [C]"),
                       ("outdoor_relative_humidity", "Outdoor Relative Humidity [%]"),
                       ("outdoor_relative_humidity", "Relative Humidity [%]"),
                       ("diffuse_solar_irradiance", "Diffuse Solar Radiation [W/m2]"),
                       ("direct_solar_irradiance", "Direct Solar Radiation [W/m2]")):
        table.update({h + " Prediction " + text: base + "_predicted_" + h for h in ("6h", "12h", "24h")})
    table["Relative Humidity [%]"] = "outdoor_relative_humidity"
    # baeda_3dem's 1h/2h/3h price forecasts stand in the 6h/12h/24h slots (CityLearn 2.1 reads by position)
    table.update({slot + " Prediction Electricity Pricing [$/kWh]": "electricity_pricing_predicted_" + h
                  for slot, h in (("1h", "6h"), ("2h", "12h"), ("3h", "24h"))})
    return table


#: THE table of accepted v2.1 header texts (all real spellings) -> internal name
V21_HEADERS: dict[str, str] = _v21_spellings()

#: later-version (v2.2+) header names accepted as aliases of an internal name
NAME_ALIASES: dict[str, str] = {
    **{
        f"{base}_predicted_{i}": f"{base}_predicted_{h}"
        for base in (
            "outdoor_dry_bulb_temperature",
            "outdoor_relative_humidity",
            "diffuse_solar_irradiance",
            "direct_solar_irradiance",
            "electricity_pricing",
        )
        for i, h in ((1, "6h"), (2, "12h"), (3, "24h"))
    },
}
#: later-version building columns that are accepted and ignored (v2.2 layout only)
IGNORED_NAMED_COLUMNS = ("minutes",)
#: building columns a v2.2 file may leave out besides the optional tail (they default to 0)
NAMED_OPTIONAL = ("daylight_savings_status", "average_unmet_cooling_setpoint_difference",
                  "indoor_relative_humidity")
#: building columns whose cells may be empty: measured values only observed (and, for the indoor temperature,
#: compared with the set point in the comfort KPIs), never used by the device physics of a building without
#: LSTM dynamics. An empty cell is NaN ("not available"), as CityLearn 2.1.2 reads it (its 2022 data sets leave
#: all three empty); see docs/environment.md "Empty and missing optional columns".
MAY_BE_EMPTY = ("indoor_dry_bulb_temperature", "average_unmet_cooling_setpoint_difference",
                "indoor_relative_humidity")
#: the accepted ``hvac_mode`` values: 0 off, 1 cooling, 2 heating, 3 auto (CityLearn 2.4+)
HVAC_MODES = (0, 1, 2, 3)
#: columns (internal names) that must not be negative
NON_NEGATIVE = ("non_shiftable_load", "dhw_demand", "cooling_demand", "heating_demand", "solar_generation",
                "occupant_count")


def header(columns: Mapping[str, str], layout: str) -> list[str]:
    """The header row to write for ``columns`` (internal name -> v2.1 text) in ``layout``."""
    _check_layout(layout)
    return list(columns.values()) if layout == "v2.1" else list(columns)


def _check_layout(layout: str) -> None:
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; known: {', '.join(LAYOUTS)}")


def _check_kind(kind: str) -> dict[str, str]:
    if kind not in TABLES:
        raise ValueError(f"unknown table kind {kind!r}; known: {', '.join(KINDS)}")
    return TABLES[kind]


def _required(kind: str) -> list[str]:
    table = list(TABLES[kind])
    return table[:BUILDING_REQUIRED] if kind == "building" else table


# ------------------------------------------------------------------------------------------------ reading
def read_table(path: str | Path, kind: str, n_rows: int | None = None, *,
               missing_hvac_mode_is_off: bool = False) -> dict[str, np.ndarray]:
    """Read and validate one CityLearn CSV of ``kind`` ("building", "weather", "pricing" or "carbon").

    Returns float64 arrays (float32-rounded values) by internal v2.2 name, of the first ``n_rows`` rows
    (``None``: all rows). Building files get their optional columns defaulted (see :func:`parse_table`).
    Every problem is a :class:`SchemaError` naming the file, the column and the first bad row.
    """
    path = Path(path)
    _check_kind(kind)
    return parse_table(_read_csv(path, numbers=True), kind, path, n_rows,
                       missing_hvac_mode_is_off=missing_hvac_mode_is_off)


def read_frame(path: str | Path) -> pd.DataFrame:
    """The CSV at ``path`` as a pandas DataFrame of strings (no NA conversion); SchemaError if unreadable."""
    return _read_csv(Path(path))


def _read_csv(path: Path, *, numbers: bool = False) -> pd.DataFrame:
    """The CSV's cells as strings; with ``numbers``, columns whose every cell is a number parsed as int64 or
    float64 by pandas' C parser (4-6 x faster than strings then floats; an empty cell keeps its column as
    strings, no NA conversion) and the other columns as strings, or the whole file as strings when pandas
    read a column as anything else (e.g. booleans), so :func:`parse_table` names the cell."""
    import pandas as pd  # lazy: importing citylearn_env does not import pandas (package docstring)

    try:
        if numbers:
            frame = pd.read_csv(path, na_filter=False)
            if all(frame[c].dtype.kind in "iufO" or frame[c].dtype == "str" for c in frame.columns):
                return frame
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except FileNotFoundError as error:
        raise SchemaError("data file not found", file=path) from error
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
        raise SchemaError(f"cannot parse as CSV: {error}", file=path) from error


def columns_of(headers: Iterable[str], kind: str, path: object) -> dict[str, str]:
    """Map internal names to the file's header texts, checking the layout rules of the module docstring.

    The layout is detected from the headers (v2.1 texts or v2.2 names). v2.1 files must hold the table's
    columns in table order (a leading run of at least the required ones), as CityLearn 2.1 reads them by
    position. One :class:`SchemaError` names the file and the first offending column.
    """
    table = _check_kind(kind)
    headers = list(headers)
    pairs = [_header_name(h, kind, table) for h in headers]
    names, layouts = [name for name, _ in pairs], [lay for _, lay in pairs]
    layout = _detected_layout(layouts, kind)
    for i in range(len(headers)):
        _check_header(i, headers, names, layouts, layout, kind, path)
    mapping = {name: h for h, name in zip(headers, names, strict=True) if name is not None}
    if layout == "v2.1":
        _check_positions(names, headers, mapping, kind, path)
        for want in _required(kind):
            if want not in mapping:
                raise SchemaError(f"missing column ({want!r})", file=path, column=table[want])
        return mapping
    for want in _required(kind):
        if want not in mapping and not (kind == "building" and want in NAMED_OPTIONAL):
            raise SchemaError("missing column", file=path, column=want)
    return mapping


def _header_name(h: str, kind: str, table: Mapping[str, str]) -> tuple[str | None, str | None]:
    """(internal name, layout) of header text ``h``: a v2.1 text, a v2.2 name (or alias), an ignored v2.2
    building column (name None) or unknown (both None)."""
    if h in V21_HEADERS and V21_HEADERS[h] in table:
        return V21_HEADERS[h], "v2.1"
    if NAME_ALIASES.get(h, h) in table:
        return NAME_ALIASES.get(h, h), "v2.2"
    if kind == "building" and h in IGNORED_NAMED_COLUMNS:
        return None, "v2.2"
    return None, None


def _detected_layout(layouts: list[str | None], kind: str) -> str:
    """The file's layout: v2.1 when at least half of the known headers are v2.1 texts (carbon: always v2.2,
    one column cannot disagree in position and spelling)."""
    known = [lay for lay in layouts if lay is not None]
    if kind == "carbon":
        return "v2.2"
    return "v2.1" if known and known.count("v2.1") * 2 >= len(known) else "v2.2"


def _check_header(i: int, headers: list[str], names: list[str | None], layouts: list[str | None], layout: str,
                  kind: str, path: object) -> None:
    """Header ``i``: known, of the file's layout, not a second spelling of an earlier column."""
    table, h, name, lay = TABLES[kind], headers[i], names[i], layouts[i]
    if lay is None:
        expected = list(table)
        if layout == "v2.2":
            hint = f"; expected names from: {', '.join(table)}"
        elif i < len(expected) and expected[i] not in names:
            hint = f" (renamed? CityLearn 2.1 expects {table[expected[i]]!r} in column {i + 1})"
        else:
            hint = f"; the v2.1 {kind} layout has {len(table)} columns: {', '.join(table.values())}"
        raise SchemaError(f"unexpected column {i + 1} of {len(headers)}{hint}", file=path, column=h)
    if kind != "carbon" and lay != layout:
        raise SchemaError(f"mixes the v2.1 header texts and v2.2 names; this file is {layout}", file=path, column=h)
    if name is not None and name in names[:i]:
        raise SchemaError(f"duplicate column: {headers[names.index(name)]!r} is {name!r} as well",
                          file=path, column=h)


def _check_positions(names: list[str | None], headers: list[str], mapping: Mapping[str, str], kind: str,
                     path: object) -> None:
    """A v2.1 file's columns stand where CityLearn 2.1 (which reads by position) expects them."""
    table = TABLES[kind]
    expected = list(table)
    for i, name in enumerate(n for n in names if n is not None):
        if name == expected[i]:
            continue
        want = expected[i]
        if want in mapping:
            raise SchemaError(f"stands in column {i + 1}, where CityLearn 2.1 (which reads by "
                              f"position) expects {table[want]!r}: columns swapped or out of order",
                              file=path, column=headers[i])
        raise SchemaError(f"missing column ({want!r}); CityLearn 2.1 reads by position, so every "
                          "later column would shift", file=path, column=table[want])


def parse_table(frame: pd.DataFrame, kind: str, path: object, n_rows: int | None, *,
                missing_hvac_mode_is_off: bool = False) -> dict[str, np.ndarray]:
    """Validate one already-read data frame (all cells as strings) of ``kind``; float arrays by internal name.

    Checks: the column rules of :func:`columns_of`; at least ``n_rows`` data rows (``None``: all rows);
    every cell a number, no NaN; loads, PV and occupants not negative; cooling and heating demand never both
    > 0 in a row; ``hvac_mode`` in {0, 1, 2, 3}; ``power_outage`` in {0, 1}; outdoor relative humidity within
    0..100 %. Building defaults: ``daylight_savings_status``, ``average_unmet_cooling_setpoint_difference``,
    ``indoor_relative_humidity``, ``occupant_count``, ``indoor_dry_bulb_temperature_set_point`` and
    ``power_outage`` 0; ``hvac_mode`` 1 (cooling; the documented meaning), or 0 (off) with
    ``missing_hvac_mode_is_off=True`` (what CityLearn 2.1 does).
    """
    _check_kind(kind)
    mapping = columns_of(frame.columns, kind, path)
    n = len(frame) if n_rows is None else int(n_rows)
    if len(frame) < n:
        raise SchemaError(f"has {len(frame)} data rows; the schema's simulation range (simulation_end_time_step)"
                          f" needs {n}", file=path, row=len(frame))
    out = {name: _column_values(frame[col].to_numpy()[:n], name, kind == "building" and name in MAY_BE_EMPTY,
                                path, col) for name, col in mapping.items()}
    if kind == "building":
        _building_defaults(out, mapping, n, path, missing_hvac_mode_is_off)
    if kind == "weather" and "outdoor_relative_humidity" in out:
        rh = out["outdoor_relative_humidity"]
        if ((rh < 0) | (rh > 100)).any():
            i = int(((rh < 0) | (rh > 100)).argmax())
            raise SchemaError(f"relative humidity {rh[i]:g} outside 0..100 %", file=path,
                              column=mapping["outdoor_relative_humidity"], row=row_label(i))
    return out


def _column_values(text: np.ndarray, name: str, may_be_empty: bool, path: object, col: str) -> np.ndarray:
    """The cells of column ``name`` (header text ``col``) as float64 rounded through float32: every cell a
    number (an empty one NaN where ``may_be_empty``), no NaN otherwise, not negative where it must not be,
    within the range of :mod:`citylearn_env.ranges`."""
    if text.dtype.kind in "iuf":  # parsed as numbers by pandas (_read_csv): every cell was one
        values = text.astype(np.float64)
    else:
        values = _text_values(text, may_be_empty, path, col)
    if np.isnan(values).any() and not may_be_empty:
        raise SchemaError("missing value (NaN)", file=path, column=col, row=row_label(int(np.isnan(values).argmax())))
    if name in NON_NEGATIVE and (values < 0).any():
        i = int((values < 0).argmax())
        raise SchemaError(f"negative value {values[i]:g}", file=path, column=col, row=row_label(i))
    outside = ranges.first_outside(name, values)  # finite and in range: citylearn_env.ranges
    if outside is not None:
        raise SchemaError(outside[1], file=path, column=col, row=row_label(outside[0]))
    return values.astype(np.float32).astype(np.float64)


def _text_values(text: np.ndarray, may_be_empty: bool, path: object, col: str) -> np.ndarray:
    """Cells given as text -> float64 (an empty one NaN where ``may_be_empty``); the first cell that is not a
    number is a :class:`SchemaError` naming it."""
    if may_be_empty:
        if not any(text.tolist()):  # every cell empty (upstream's 2022 files): skip the string work
            return np.full(len(text), np.nan)
        text = np.where(np.char.strip(text.astype(str)) == "", "nan", text)
    try:
        return np.asarray(text, dtype=np.float64)
    except ValueError:
        bad = first_non_number(text)
        raise SchemaError(f"not a number: {text[bad]!r}", file=path, column=col, row=row_label(bad)) from None


def _building_defaults(out: dict[str, np.ndarray], mapping: Mapping[str, str], n: int, path: object,
                       missing_hvac_mode_is_off: bool) -> None:
    """A building table's checks across columns and its defaulted columns (see :func:`parse_table`)."""
    both = (out["cooling_demand"] > 0) & (out["heating_demand"] > 0)
    if both.any():
        i = int(both.argmax())
        raise SchemaError("cooling_demand and heating_demand are both > 0", file=path,
                          column=f"{mapping['cooling_demand']} / {mapping['heating_demand']}", row=row_label(i))
    for name in ("daylight_savings_status", "average_unmet_cooling_setpoint_difference",
                 "indoor_relative_humidity", "occupant_count", "indoor_dry_bulb_temperature_set_point",
                 "power_outage"):
        out.setdefault(name, np.zeros(n))
    # CityLearn 2.1 treats a missing hvac_mode column as 0 (off); its docs and later versions mean cooling.
    out.setdefault("hvac_mode", np.full(n, 0.0 if missing_hvac_mode_is_off else 1.0))
    _set_points(out, n, given="indoor_dry_bulb_temperature_set_point" in mapping)
    for name in ("hvac_mode", "power_outage"):
        bad = ~np.isin(out[name], HVAC_MODES if name == "hvac_mode" else (0, 1))
        if bad.any():
            i = int(bad.argmax())
            raise SchemaError(f"invalid value {out[name][i]:g}", file=path, column=mapping.get(name, name),
                              row=row_label(i))


def _set_points(out: dict[str, np.ndarray], n: int, *, given: bool) -> None:
    """The three set-point columns of a building [degC]. A v2.1 file has one set point, which then serves as
    cooling and heating set point too. A v2.2+ file has ``..._cooling_set_point`` and
    ``..._heating_set_point``; the single ``indoor_dry_bulb_temperature_set_point`` that comfort is measured
    against is then the heating set point in heating mode (hvac_mode 2) and the cooling one otherwise, auto mode
    3 included (unless the file gives it, ``given``). A missing one defaults to the other. ``comfort_band`` defaults to 2 degC."""
    single = out["indoor_dry_bulb_temperature_set_point"]
    cooling = out.get("indoor_dry_bulb_temperature_cooling_set_point")
    heating = out.get("indoor_dry_bulb_temperature_heating_set_point")
    if cooling is None and heating is None:
        cooling = heating = single
    cooling = heating if cooling is None else cooling
    heating = cooling if heating is None else heating
    out["indoor_dry_bulb_temperature_cooling_set_point"] = cooling
    out["indoor_dry_bulb_temperature_heating_set_point"] = heating
    if not given:
        out["indoor_dry_bulb_temperature_set_point"] = np.where(out["hvac_mode"] == 2, heating, cooling)
    out.setdefault("comfort_band", np.full(n, 2.0))


def first_non_number(cells: Iterable[Any]) -> int:
    """Index of the first of ``cells`` that ``float`` cannot read (0 when every cell is a number)."""
    for i, cell in enumerate(cells):
        try:
            float(cell)
        except ValueError:
            return i
    return 0


def row_label(i: int) -> str:
    """Data row ``i`` (0-based, after the header) as error messages name it: ``"i (file line i + 2)"``."""
    return f"{i} (file line {i + 2})"


# ------------------------------------------------------------------------------------------------ writing
def table_columns(kind: str, names: Iterable[str], layout: str = "v2.2", *, file: object = None) -> list[str]:
    """The internal names of ``names`` in file order, checked for ``layout``.

    Unknown names and missing required columns are a :class:`SchemaError`; in the v2.1 layout the columns
    must also be a leading run of the table (CityLearn 2.1 reads by position).
    """
    table = _check_kind(kind)
    _check_layout(layout)
    names = set(names)
    unknown = sorted(names - set(table))
    if unknown:
        raise SchemaError(f"not a CityLearn {kind} column; known: {', '.join(table)}", file=file,
                          column=unknown[0])
    ordered = [n for n in table if n in names]
    for want in _required(kind):
        if want not in names:
            raise SchemaError(f"missing column (the first {len(_required(kind))} {kind} columns are required)",
                              file=file, column=want)
    if layout == "v2.1" and ordered != list(table)[: len(ordered)]:
        gap = next(n for n, m in zip(table, ordered, strict=False) if n != m)
        raise SchemaError(f"column(s) after {gap!r} present but {gap!r} is missing: the v2.1 layout is "
                          "positional", file=file, column=gap)
    return ordered


def write_table(path: str | Path, kind: str, data: Mapping[str, np.ndarray], layout: str = "v2.2") -> Path:
    """Write ``data`` (internal name -> 1-D array, all of one length) as a CityLearn CSV of ``kind``.

    Columns in file (table) order, header per ``layout`` ("v2.1" texts or "v2.2" names), values as
    ``"%.10g"`` (integers such as hour 1 print as ``1``). Atomic: a temporary file in the same folder,
    mode 0o644, then ``os.replace``. Unknown/missing columns, unequal lengths and NaN/inf values are a
    :class:`SchemaError` naming the file and column (a writer bug). Returns ``path``.
    """
    path = Path(path)
    names = table_columns(kind, data, layout, file=path)
    arrays = [np.asarray(data[n], dtype=np.float64).reshape(-1) for n in names]
    rows = len(arrays[0])
    for name, values in zip(names, arrays, strict=True):
        if len(values) != rows:
            raise SchemaError(f"has {len(values)} values, {names[0]!r} has {rows}", file=path, column=name)
        finite = np.isfinite(values)
        if not finite.all():
            i = int(np.argmin(finite))
            raise SchemaError(f"NaN or infinite value {values[i]}", file=path, column=name, row=row_label(i))
    head = header({n: TABLES[kind][n] for n in names}, layout)
    matrix = np.column_stack(arrays) if rows else np.zeros((0, len(names)))
    return write_atomically(path, lambda stream: np.savetxt(stream, matrix, fmt="%.10g", delimiter=",",
                                                           header=",".join(head), comments=""))


def write_atomically(path: str | Path, write: Callable[[TextIO], object]) -> Path:
    """Create ``path`` with ``write(stream)`` (a text stream) atomically: a temporary file in the same folder,
    mode 0o644, then ``os.replace``; nothing is left behind if ``write`` fails. Returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "w", newline="") as stream:
            write(stream)
        os.chmod(temp, 0o644)
        os.replace(temp, path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise
    return path


# ----------------------------------------------------------------------------------------------- calendar
HOLIDAY_DAY_TYPE = 8


def calendar(start: np.datetime64 | str | dt.date, hours: int, holidays: Iterable[Any] = ()) -> dict[str, np.ndarray]:
    """Calendar columns of ``hours`` consecutive hourly rows from ``start`` (local standard time).

    Row i is the hour that begins at ``start + i h``: ``month`` 1-12 and ``day_type`` 1 = Monday ..
    7 = Sunday (8 for a date in ``holidays``) of that beginning, ``hour`` 1-24 hour-ending (the row
    beginning at 00:00 is hour 1), ``daylight_savings_status`` 0 (data in standard time). Float64 arrays.
    """
    begin = np.datetime64(start, "h")
    return calendar_of(begin + np.arange(int(hours)).astype("timedelta64[h]"), holidays)


def calendar_of(stamps: Any, holidays: Iterable[Any] = ()) -> dict[str, np.ndarray]:
    """:func:`calendar` for any interval-beginning timestamps (datetime64 array-like, local standard time, not
    necessarily contiguous): the one calendar of the package (the pipeline's and the surrogates' call it)."""
    stamps = np.asarray(stamps, dtype="datetime64[h]")
    days = stamps.astype("datetime64[D]")
    weekday = (days.astype(np.int64) + 3) % 7  # 1970-01-01 was a Thursday (weekday 3, 0 = Monday)
    day_type = weekday + 1.0
    holidays = list(holidays)
    if holidays:
        dates = np.array([_as_day(d) for d in holidays], dtype="datetime64[D]")
        day_type = np.where(np.isin(days, dates), float(HOLIDAY_DAY_TYPE), day_type)
    return {
        "month": (stamps.astype("datetime64[M]").astype(np.int64) % 12 + 1).astype(np.float64),
        "hour": (stamps - days).astype(np.int64).astype(np.float64) + 1.0,
        "day_type": day_type.astype(np.float64),
        "daylight_savings_status": np.zeros(len(stamps)),
    }


def _as_day(value: Any) -> np.datetime64:
    """A date, datetime, pandas Timestamp, numpy datetime64 or ISO string -> its day."""
    if hasattr(value, "date") and callable(value.date):
        value = value.date()
    return np.datetime64(str(value)[:10], "D")


# -------------------------------------------------------------------------------------- periodic encodings
#: periods of the periodic observations: hour 1..24, month 1..12, day_type 1..7 (8 = holiday wraps onto 1).
#: CityLearn 2.1 ran day_type with period 8 (see citylearn_env.settings ``lstm_day_type_period``).
PERIODS: dict[str, float] = {"hour": 24.0, "month": 12.0, "day_type": 7.0}


def periodic_encoding(values: Any, period: float) -> tuple[np.ndarray, np.ndarray]:
    """``(sin, cos)`` of the angle ``2 * pi * values / period`` (computed in that order, float64)."""
    angle = 2.0 * np.pi * np.asarray(values, dtype=np.float64) / period
    return np.sin(angle), np.cos(angle)


def split_periodic_name(name: str, periods: Mapping[str, float] = PERIODS) -> tuple[str, str | None]:
    """``"hour_sin"`` -> ``("hour", "sin")``, ``"hour_cos"`` -> ``("hour", "cos")``; any other name (or a
    base not in ``periods``) -> ``(name, None)``."""
    base, _, kind = name.rpartition("_")
    if kind in ("sin", "cos") and base in periods:
        return base, kind
    return name, None


# ------------------------------------------------------------------------------------- LSTM dynamics block
DYNAMICS_TYPE = "citylearn.dynamics.LSTMDynamics"


@dataclass(frozen=True)
class DynamicsBlock:
    """One exported LSTM indoor-temperature model as a schema describes it.

    ``filename``: the ``.pth`` weights (as written in the schema, or resolved against the schema root by
    :func:`parse_dynamics`); ``input_observation_names`` in model input order (``*_sin``/``*_cos`` are
    periodic encodings, see :data:`PERIODS`; the indoor temperature is one of them); min-max bounds in the
    inputs' own units; ``lookback`` in time steps. ``input_size`` is the number of names.
    """

    filename: str
    input_observation_names: tuple[str, ...]
    input_normalization_minimum: tuple[float, ...]
    input_normalization_maximum: tuple[float, ...]
    hidden_size: int
    num_layers: int
    lookback: int

    @property
    def input_size(self) -> int:
        return len(self.input_observation_names)

    @property
    def filepath(self) -> str:
        """Alias of :attr:`filename` (the resolved weights path after :func:`parse_dynamics`)."""
        return self.filename

    def to_schema(self) -> dict[str, Any]:
        """The v2.2 schema ``dynamics`` object (plain JSON types)."""
        return {"type": DYNAMICS_TYPE, "attributes": {
            "input_size": self.input_size, "hidden_size": int(self.hidden_size),
            "num_layers": int(self.num_layers), "lookback": int(self.lookback), "filename": str(self.filename),
            "input_observation_names": list(self.input_observation_names),
            "input_normalization_minimum": [float(v) for v in self.input_normalization_minimum],
            "input_normalization_maximum": [float(v) for v in self.input_normalization_maximum]}}

    @classmethod
    def from_schema(cls, entry: Mapping[str, Any], *, root: str | Path | None = None,
                    where: str = "dynamics") -> DynamicsBlock:
        """Parse one LSTM entry (``{"type": ..., "attributes": {...}}``; a bare attributes dict is accepted).

        ``filename`` is joined to ``root`` when given (``filepath``, an older spelling, is taken as is).
        Missing attributes and disagreeing lengths are a :class:`SchemaError` naming ``where``.
        """
        if not isinstance(entry, Mapping):
            raise SchemaError(f"expected an object, got {type(entry).__name__}", column=where)
        if "type" in entry:
            resolve_type("dynamics", entry.get("type"), where=f"{where}.type")
        a = entry.get("attributes", entry) or {}
        _refuse_nulls(a, where)
        try:
            names = tuple(str(n) for n in a["input_observation_names"])
            lo = tuple(float(x) for x in a["input_normalization_minimum"])
            hi = tuple(float(x) for x in a["input_normalization_maximum"])
            if "filename" in a:
                filename = str(Path(root) / a["filename"]) if root is not None else str(a["filename"])
            else:
                filename = str(a["filepath"])
            block = cls(filename, names, lo, hi, int(a["hidden_size"]), int(a["num_layers"]), int(a["lookback"]))
        except KeyError as error:
            raise SchemaError("missing attribute", column=f"{where}.attributes.{error.args[0]}") from error
        except (TypeError, ValueError) as error:
            raise SchemaError(f"bad attribute value: {error}", column=f"{where}.attributes") from error
        size = a.get("input_size")
        if not (len(names) == len(lo) == len(hi)) or (size is not None and len(names) != size):
            raise SchemaError("input names, bounds and input_size disagree in length", column=f"{where}.attributes")
        return block


#: LSTM attributes that must be given (not null): the sizes the weights cannot tell and the input contract
#: (``input_size`` may be null: it is the number of input names; ``hidden_size`` and ``num_layers`` null are
#: read from the weights by the schema loader before this parse)
_REQUIRED_DYNAMICS = {
    "input_observation_names": "the model's input names, in input order",
    "input_normalization_minimum": "one minimum per input name",
    "input_normalization_maximum": "one maximum per input name",
    "hidden_size": "the LSTM hidden size (read from the weights when the schema loader can)",
    "num_layers": "the number of LSTM layers (read from the weights when the schema loader can)",
    "lookback": "the number of past time steps the model was trained on (upstream's data sets: 13); the "
                "weights do not tell it",
}


def _refuse_nulls(attributes: Mapping[str, Any], where: str) -> None:
    """One SchemaError naming the first required LSTM attribute that is null."""
    for key, what in _REQUIRED_DYNAMICS.items():
        if key in attributes and attributes[key] is None:
            raise SchemaError(f"is null; expected {what}", column=f"{where}.attributes.{key}")


def parse_dynamics(spec: Mapping[str, Any] | None, root: str | Path | None = None, *,
                   where: str = "dynamics", check_files: bool = True
                   ) -> tuple[DynamicsBlock | None, DynamicsBlock | None]:
    """``(cooling, heating)`` blocks of a building's ``dynamics`` entry.

    v2.2+: one object with a ``type`` serves both modes (the same block twice); v2.1: ``{"cooling": ...,
    "heating": ...}`` (either may be null). ``None``/empty -> ``(None, None)``. With ``check_files`` a
    weights file that does not exist is a :class:`SchemaError`.
    """
    if not spec:
        return None, None
    if "type" in spec:
        block = _checked(DynamicsBlock.from_schema(spec, root=root, where=where), where, check_files)
        return block, block
    out = []
    for mode in ("cooling", "heating"):
        entry = spec.get(mode)
        out.append(None if entry is None else _checked(
            DynamicsBlock.from_schema(entry, root=root, where=f"{where}.{mode}"), f"{where}.{mode}", check_files))
    return out[0], out[1]


def _checked(block: DynamicsBlock, where: str, check_files: bool) -> DynamicsBlock:
    if check_files and not Path(block.filename).is_file():
        raise SchemaError("LSTM weights file not found", file=block.filename, column=f"{where}.attributes.filename")
    return block


def dynamics_entry(block: DynamicsBlock, layout: str = "v2.2", heating: DynamicsBlock | None = None) -> dict:
    """The schema ``dynamics`` value for ``layout``: the v2.2 single object, or the v2.1
    ``{"cooling": ..., "heating": ...}`` pair (``heating`` defaults to the same block)."""
    _check_layout(layout)
    if layout == "v2.2":
        return block.to_schema()
    return {"cooling": block.to_schema(), "heating": (heating or block).to_schema()}


__all__ = [
    "BUILDING_COLUMNS", "BUILDING_REQUIRED", "CARBON_COLUMNS", "DYNAMICS_TYPE", "DynamicsBlock",
    "KINDS", "LAYOUTS", "NAME_ALIASES", "PERIODS", "PRICING_COLUMNS", "TABLES", "V21_HEADERS", "WEATHER_COLUMNS",
    "calendar", "columns_of", "dynamics_entry", "first_non_number", "header", "parse_dynamics", "parse_table",
    "periodic_encoding", "read_frame", "read_table", "row_label", "split_periodic_name", "table_columns",
    "write_table",
]
