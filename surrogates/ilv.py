"""The ideal-load-variation (ILV) table: the training contract for the LSTM surrogates.

One row per (reference run, hour). Columns (units):

===============================================  ==========================================================
``reference``                                    int; 0 = ideal-load replay, 1 = free float, >= 2 = partial-load
``timestamp``                                    interval-beginning, local standard time, tz-naive, hourly
``month``                                        1..12, month of ``timestamp``
``hour``                                         1..24, hour-ending (the row at 00:00 is hour 1)
``day_type``                                     1 = Monday ... 7 = Sunday, 8 = holiday
``direct_solar_irradiance``                      W/m2, >= 0
``diffuse_solar_irradiance``                     W/m2, >= 0
``outdoor_dry_bulb_temperature``                 degC
``occupant_count``                               people, >= 0
``indoor_dry_bulb_temperature_set_point``        degC, optional column
``non_shiftable_load``                           kWh of electricity of lights and appliances in the hour (their
                                                 heat is an internal gain), >= 0, optional column
``cooling_demand``                               kWh of heat removed from the zone in the hour, >= 0
``heating_demand``                               kWh of heat added to the zone in the hour, >= 0
``indoor_dry_bulb_temperature``                  degC, zone air temperature at the end of the hour
===============================================  ==========================================================

Within a reference run the timestamps are consecutive hours (no gaps, no duplicates); runs may cover
different periods. Training needs at least two reference runs.

Bad input raises :class:`citylearn_env.errors.InputError` (also ``pipeline.errors.InputError``) naming
the file (``source``), the column and the first bad row; ``row`` is the 0-based data row of the table as given (header excluded; CSV line = row + 2).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.dataset import calendar_of
from citylearn_env.errors import InputError

REQUIRED_COLUMNS: tuple[str, ...] = (
    "reference",
    "timestamp",
    "month",
    "hour",
    "day_type",
    "direct_solar_irradiance",
    "diffuse_solar_irradiance",
    "outdoor_dry_bulb_temperature",
    "occupant_count",
    "cooling_demand",
    "heating_demand",
    "indoor_dry_bulb_temperature",
)
OPTIONAL_COLUMNS: tuple[str, ...] = ("indoor_dry_bulb_temperature_set_point", "non_shiftable_load")
INTEGER_COLUMNS: tuple[str, ...] = ("reference", "month", "hour", "day_type")
#: float column -> (lowest, highest) plausible value
FLOAT_RANGES: dict[str, tuple[float, float]] = {
    "direct_solar_irradiance": (0.0, 1500.0),
    "diffuse_solar_irradiance": (0.0, 1500.0),
    "outdoor_dry_bulb_temperature": (-70.0, 60.0),
    "occupant_count": (0.0, 1e6),
    "indoor_dry_bulb_temperature_set_point": (-70.0, 60.0),
    "non_shiftable_load": (0.0, 1e7),
    "cooling_demand": (0.0, 1e7),
    "heating_demand": (0.0, 1e7),
    "indoor_dry_bulb_temperature": (-70.0, 90.0),
}
REFERENCE_NAMES = {0: "ideal", 1: "free_float"}


def _fail(message: str, source: object, column: str | None = None, row: int | None = None) -> None:
    raise InputError(message, file=source, column=column, row=row)


def _first(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def _parse_timestamps(values: pd.Series, source: object) -> pd.Series:
    if pd.api.types.is_datetime64_any_dtype(values):
        stamps = values
    else:
        stamps = pd.to_datetime(values, errors="coerce", format="mixed")
        bad = stamps.isna().to_numpy() & values.notna().to_numpy()
        if bad.any():
            row = _first(bad)
            _fail(f"cannot parse timestamp {values.iloc[row]!r}", source, "timestamp", row)
    if getattr(stamps.dt, "tz", None) is not None:
        _fail("timestamps must be tz-naive local standard time", source, "timestamp", 0)
    return stamps.astype("datetime64[ns]")


def _check_numeric(frame: pd.DataFrame, column: str, source: object) -> np.ndarray:
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float, na_value=np.nan)
    original_missing = frame[column].isna().to_numpy()
    not_number = np.isnan(values) & ~original_missing
    if not_number.any():
        row = _first(not_number)
        _fail(f"not a number: {frame[column].iloc[row]!r}", source, column, row)
    return values


def validate_ilv(frame: pd.DataFrame, source: object = "<ILV table>", min_references: int = 2) -> pd.DataFrame:
    """Check an ILV table against the contract and return a clean copy.

    Parameters
    ----------
    frame : the table as read (any column order; extra columns are dropped).
    source : file name (or description) used in error messages.
    min_references : fewest distinct reference runs accepted (training needs 2).

    Returns
    -------
    A new DataFrame with the contract columns, sorted by (reference, timestamp), integer columns as int64,
    ``timestamp`` as datetime64[ns], the rest float64, and a fresh RangeIndex.
    """
    columns = _contract_columns(frame, source)
    out = pd.DataFrame(index=pd.RangeIndex(len(frame)))
    out["timestamp"] = _parse_timestamps(frame["timestamp"].reset_index(drop=True), source).to_numpy()
    for column in columns:
        if column != "timestamp":
            out[column] = _clean_numbers(frame, column, source)
    _check_calendar(out, source)
    _check_runs(out, source, min_references)
    order = np.lexsort((out["timestamp"].to_numpy(), out["reference"].to_numpy()))
    return out.iloc[order][columns].reset_index(drop=True)


def _contract_columns(frame: pd.DataFrame, source: object) -> list[str]:
    """The contract columns of ``frame`` (the required ones, then the optional ones it has), after checking
    that it is a non-empty DataFrame with every required column and no missing value in them."""
    if not isinstance(frame, pd.DataFrame):
        _fail(f"expected a pandas DataFrame, got {type(frame).__name__}", source)
    missing = [c for c in REQUIRED_COLUMNS if c not in frame.columns]
    if missing:
        _fail(f"missing required column(s) {missing}; an ILV table needs {list(REQUIRED_COLUMNS)}",
              source, missing[0])
    if len(frame) == 0:
        _fail("the table has no rows", source)
    columns = list(REQUIRED_COLUMNS) + [c for c in OPTIONAL_COLUMNS if c in frame.columns]
    for column in columns:
        nan = frame[column].isna().to_numpy()
        if nan.any():
            _fail("missing value (NaN/empty)", source, column, _first(nan))
    return columns


def _clean_numbers(frame: pd.DataFrame, column: str, source: object) -> np.ndarray:
    """A numeric contract column checked: int64 for :data:`INTEGER_COLUMNS` (no fractional values), else
    finite float64 inside its :data:`FLOAT_RANGES`."""
    values = _check_numeric(frame, column, source)
    if column in INTEGER_COLUMNS:
        fractional = values != np.round(values)
        if fractional.any():
            _fail(f"must be an integer, got {values[_first(fractional)]}", source, column, _first(fractional))
        return values.astype(np.int64)
    finite = np.isfinite(values)
    if not finite.all():
        _fail(f"not finite: {values[_first(~finite)]}", source, column, _first(~finite))
    low, high = FLOAT_RANGES[column]
    outside = (values < low) | (values > high)
    if outside.any():
        row = _first(outside)
        _fail(f"value {values[row]} outside the plausible range [{low}, {high}]", source, column, row)
    return values


def _check_calendar(out: pd.DataFrame, source: object) -> None:
    stamps = out["timestamp"]
    checks = {
        "reference": (out["reference"].to_numpy() < 0, "must be >= 0"),
        "month": (out["month"].to_numpy() != stamps.dt.month.to_numpy(), "must equal the timestamp's month"),
        "hour": (out["hour"].to_numpy() != stamps.dt.hour.to_numpy() + 1,
                 "must be the hour-ending hour 1..24 of the interval-beginning timestamp (timestamp hour + 1)"),
        "day_type": ((out["day_type"].to_numpy() != stamps.dt.dayofweek.to_numpy() + 1)
                     & (out["day_type"].to_numpy() != 8),
                     "must be the timestamp's weekday 1 = Monday ... 7 = Sunday, or 8 = holiday"),
    }
    for column, (bad, message) in checks.items():
        if bad.any():
            row = _first(bad)
            _fail(f"{message}; got {out[column].iloc[row]} at {stamps.iloc[row]}", source, column, row)


def _check_runs(out: pd.DataFrame, source: object, min_references: int) -> None:
    references = out["reference"].to_numpy()
    unique = np.unique(references)
    if len(unique) < min_references:
        _fail(f"found {len(unique)} reference run(s) {unique.tolist()}; at least {min_references} are needed "
              "(e.g. 0 = ideal loads plus partial-load runs >= 2)", source, "reference")
    stamps = out["timestamp"].to_numpy().astype("datetime64[ns]").astype(np.int64)
    order = np.lexsort((stamps, references))
    same_run = references[order][1:] == references[order][:-1]
    step = np.diff(stamps[order])
    hour = np.int64(3_600_000_000_000)
    bad = same_run & (step != hour)
    if bad.any():
        k = _first(bad)
        row = int(order[k + 1])
        kind = "duplicated timestamp" if step[k] == 0 else f"gap of {step[k] / hour:g} h"
        _fail(f"reference run {references[row]} is not consecutive hourly: {kind} before "
              f"{out['timestamp'].iloc[row]}", source, "timestamp", row)
    aligned = (stamps % hour) != 0
    if aligned.any():
        _fail("timestamps must fall on the hour", source, "timestamp", _first(aligned))


def read_ilv(path: str | os.PathLike, min_references: int = 2) -> pd.DataFrame:
    """Read and validate an ILV table from ``.csv`` or ``.parquet`` (see the module docstring)."""
    path = Path(path)
    if not path.is_file():
        _fail("ILV table not found", path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".csv":
            frame = pd.read_csv(path)
        elif suffix in (".parquet", ".pq"):
            frame = pd.read_parquet(path)
        else:
            _fail(f"unknown ILV table format {suffix!r}; use .csv or .parquet", path)
    except (OSError, ValueError, pd.errors.ParserError) as error:
        if isinstance(error, InputError):
            raise
        _fail(f"cannot read the table: {error}", path)
    return validate_ilv(frame, source=path, min_references=min_references)


def write_ilv(frame: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Validate ``frame`` and write it atomically to ``.csv`` or ``.parquet``; returns the path."""
    path = Path(path)
    clean = validate_ilv(frame, source=path, min_references=1)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        _fail(f"unknown ILV table format {suffix!r}; use .csv or .parquet", path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    os.close(handle)
    try:
        if suffix == ".csv":
            clean.to_csv(temp, index=False, date_format="%Y-%m-%d %H:%M:%S")
        else:
            clean.to_parquet(temp, index=False)
        os.replace(temp, path)
    finally:
        if os.path.exists(temp):
            os.remove(temp)
    return path


def calendar_columns(timestamps: pd.DatetimeIndex | pd.Series, holidays: set | None = None) -> pd.DataFrame:
    """``month``, ``hour`` (1..24, hour-ending) and ``day_type`` (1 = Monday ... 8 = holiday) of
    interval-beginning timestamps; ``holidays`` is a set of ``datetime.date``."""
    cal = calendar_of(pd.DatetimeIndex(timestamps).to_numpy(), holidays or ())
    return pd.DataFrame({name: cal[name].astype(np.int64) for name in ("month", "hour", "day_type")})


def table_digest(frame: pd.DataFrame) -> str:
    """sha256 of a table's content: column names, order and values (not of its file's bytes).

    Integers hash as int64, floats as float64, datetimes as int64 nanoseconds, anything else as its text;
    so the same table read from a .csv or a .parquet file hashes alike.
    """
    digest = hashlib.sha256()
    digest.update(f"rows={len(frame)};".encode())
    for name in frame.columns:
        column = frame[name]
        if pd.api.types.is_datetime64_any_dtype(column):
            values = column.to_numpy().astype("datetime64[ns]").view(np.int64)
            kind = "datetime64[ns]"
        elif pd.api.types.is_bool_dtype(column) or pd.api.types.is_integer_dtype(column):
            values, kind = column.to_numpy().astype(np.int64), "int64"
        elif pd.api.types.is_float_dtype(column):
            values, kind = column.to_numpy().astype(np.float64), "float64"
        else:
            values, kind = None, "text"
        digest.update(f"column={name};{kind};".encode())
        if values is None:
            digest.update("\x1f".join(map(str, column.tolist())).encode())
        else:
            digest.update(np.ascontiguousarray(values).tobytes())
    return digest.hexdigest()
