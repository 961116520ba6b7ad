"""ERCOT generation by fuel: the Fuel Mix Report workbook and a plain long CSV -> hourly MWh per fuel.

The life-cycle emission factor of each fuel (``pipeline/data/emission_factors.csv``, the fuels a reader
accepts) is read here too (:func:`read_emission_factors`).

Output of every fuel-mix reader: an hourly DataFrame, index = interval-beginning **local standard time** (tz-naive),
one column per fuel, values in MWh generated in that hour.

Workbook (``IntGenbyFuel<year>.xlsx``): one sheet per month (``Jan`` .. ``Dec``), header ``Date, Fuel,
Settlement Type, Total, 0:15 .. 23:45, 0:00``; each cell is the MWh of the 15 minutes *ending* at the label,
Central *prevailing* time. On the spring-forward day the four labels 2:15-3:00 do not exist (empty cells);
on the fall-back day the ``Nov`` sheet has four more columns ``01:15 (DST)`` .. ``02:00 (DST)``. In the 2017
workbook the regular 1:15-2:00 columns hold the first (daylight-time) pass through 01:00-02:00 and the
``(DST)`` columns the second (standard-time) pass: the values run on smoothly in that order (e.g. coal
2,741 -> 2,645 .. 2,458 -> 2,385 .. 2,300 -> 2,286 MWh on 2017-11-05).
"""

from __future__ import annotations

import datetime as dt
import functools
import re
from importlib import resources
from pathlib import Path
from typing import NamedTuple
from zoneinfo import ZoneInfo

import numpy as np
import pandas as pd

from pipeline.errors import InputError
from pipeline.ingest.messages import one_line

TIMEZONE = "America/Chicago"
MONTH_SHEETS = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")
KEY_COLUMNS = ("Date", "Fuel", "Total")
_LABEL = re.compile(r"^(\d{1,2}):(\d{2})( \(DST\))?$")
STEP = pd.Timedelta(minutes=15)
#: columns of the emission factor table (:func:`read_emission_factors`)
FACTOR_COLUMNS = ("fuel", "g_co2e_per_kwh", "srren_technology", "negative_allowed", "note")


def read_emission_factors(path: str | Path | None = None) -> pd.DataFrame:
    """Emission factor table indexed by ERCOT fuel name.

    Returns columns ``g_co2e_per_kwh`` (float, NaN = excluded), ``srren_technology``, ``negative_allowed``
    (bool: the fuel may report net negative energy) and ``note`` (the source of the number).
    """
    if path is None:
        source = resources.files("pipeline") / "data" / "emission_factors.csv"
        with resources.as_file(source) as file:
            return read_emission_factors(file)
    frame = pd.read_csv(path, dtype={"fuel": str, "srren_technology": str, "note": str})
    for column in FACTOR_COLUMNS:
        if column not in frame.columns:
            raise InputError("missing column", file=path, column=column, row=1)
    factors = pd.to_numeric(frame["g_co2e_per_kwh"], errors="coerce")
    bad = frame["g_co2e_per_kwh"].notna() & factors.isna()
    if bad.any() or (factors < 0).any():
        first = int(np.argmax(bad.to_numpy() | (factors < 0).to_numpy()))
        raise InputError("factor must be a non-negative number or empty", file=path,
                         column="g_co2e_per_kwh", row=first + 2)
    frame["g_co2e_per_kwh"] = factors
    frame["negative_allowed"] = frame["negative_allowed"].astype(str).str.lower().eq("true")
    return frame.set_index("fuel")


def read_fuel_mix_workbook(path: str | Path, timezone: str = TIMEZONE) -> tuple[pd.DataFrame, dict]:
    """Read an ERCOT ``IntGenbyFuel<year>.xlsx`` into hourly MWh per fuel (local standard time).

    Returns ``(hourly, metadata)``; metadata holds the file, the sheets read and the fuels.
    """
    import openpyxl  # lazy: openpyxl comes with the optional `pipeline` extra

    path = Path(path)
    try:
        book = openpyxl.load_workbook(path, read_only=True, data_only=True)
    except Exception as error:  # openpyxl raises several types for a non-workbook
        raise InputError(f"not a readable .xlsx workbook ({one_line(error)})", file=path) from error
    sheets = [name for name in book.sheetnames if name in MONTH_SHEETS]
    if not sheets:
        raise InputError(f"no month sheets ({', '.join(MONTH_SHEETS)}); found {book.sheetnames}", file=path)
    known = read_emission_factors()
    parts = []
    for name in sheets:
        sheet = book[name]
        sheet.reset_dimensions()  # the stored dimension is wrong in ERCOT files
        rows = list(sheet.iter_rows(values_only=True))
        parts.append(parse_fuel_mix_sheet(rows, file=f"{path} [sheet {name}]", known_fuels=known,
                                          timezone=timezone))
    book.close()
    long = pd.concat(parts, ignore_index=True)
    hourly = hourly_generation(long, file=path)
    return hourly, {"file": str(path), "sheets": sheets, "fuels": list(hourly.columns), "timezone": timezone}


def parse_fuel_mix_sheet(rows: list[tuple], *, file: str, known_fuels: pd.DataFrame,
                         timezone: str = TIMEZONE) -> pd.DataFrame:
    """Parse one month sheet (rows of cell values, header first) into a long 15-min frame.

    Returns columns ``begin`` (interval start, local standard time), ``fuel``, ``mwh``, ``where`` (the
    file/sheet and row, for later error messages).
    """
    if not rows:
        raise InputError("empty sheet", file=file)
    layout = _sheet_layout(rows[0], file)
    chunks: dict[tuple[dt.date, str], _SheetRow] = {}
    for number, row in enumerate(rows[1:], start=2):
        if _is_blank_row(row):
            continue
        parsed = _parse_sheet_row(row, number, layout, file=file, known_fuels=known_fuels, timezone=timezone)
        key = (parsed.day, parsed.fuel)
        if _supersedes(parsed, chunks.get(key), file):
            chunks[key] = parsed
    return _sheet_frame(list(chunks.values()), file)


def hourly_generation(long: pd.DataFrame, *, file: object) -> pd.DataFrame:
    """Sum a long frame (``begin``, ``fuel``, ``mwh``[, ``where``]) into complete hours, one column per fuel.

    Each fuel's intervals must be regular (no gap, no duplicate); hours at the ends of the data that are
    not fully covered are dropped; a fuel absent from some whole hours at the edges counts as 0 there.
    """
    if long.empty:
        raise InputError("no data rows", file=file)
    long = long.sort_values(["fuel", "begin"], kind="stable")
    steps = []
    for fuel, part in long.groupby("fuel", sort=False):
        begins = pd.DatetimeIndex(part["begin"])
        diffs = begins[1:] - begins[:-1]
        step = pd.Series(diffs).mode().iloc[0] if len(diffs) else pd.Timedelta(hours=1)
        if step <= pd.Timedelta(0) or pd.Timedelta(hours=1) % step != pd.Timedelta(0):
            raise InputError(f"time step {step} does not divide one hour", file=file, column=fuel)
        bad = (diffs != step).nonzero()[0]
        if len(bad):
            i = int(bad[0])
            where = part["where"].iloc[i + 1] if "where" in part else file
            kind = "duplicate" if diffs[i] == pd.Timedelta(0) else "gap"
            raise InputError(f"{kind} in timestamps: {begins[i]} then {begins[i + 1]} (local standard time, "
                             f"interval-beginning; expected steps of {step})", file=where, column=fuel)
        steps.append(step)
    if len(set(steps)) > 1:
        raise InputError(f"fuels use different time steps {sorted(set(steps))}", file=file)
    per_hour = int(pd.Timedelta(hours=1) / steps[0])
    hours = pd.DatetimeIndex(long["begin"]).floor("h")
    grouped = long.assign(hour=hours).groupby(["hour", "fuel"])["mwh"].agg(["sum", "count"])
    energy = grouped["sum"].unstack("fuel")
    count = grouped["count"].unstack("fuel").fillna(0)
    complete = ((count == per_hour) | (count == 0)).all(axis=1) & (count > 0).any(axis=1)
    partial = count.index[~complete]
    inner = partial[(partial > count.index[complete].min()) & (partial < count.index[complete].max())] \
        if complete.any() else partial
    if len(inner):
        raise InputError(f"hour {inner[0]} is only partly covered", file=file)
    energy = energy.loc[complete].fillna(0.0)
    full = pd.date_range(energy.index[0], energy.index[-1], freq="h")
    missing = full.difference(energy.index)
    if len(missing):
        raise InputError(f"gap in timestamps: no data for hour {missing[0]} (local standard time)", file=file)
    energy.index = pd.DatetimeIndex(energy.index, name=None)
    energy.columns.name = None
    return energy


def read_fuel_mix_csv(path: str | Path, clock: str = "prevailing",
                      timezone: str = TIMEZONE) -> tuple[pd.DataFrame, dict]:
    """Read a long CSV ``timestamp, fuel, mwh`` (interval-ending timestamps) into hourly MWh per fuel.

    Timestamps with a UTC offset (``2018-06-01T00:15:00-05:00``) are exact. Naive timestamps are read in
    ``clock``: ``"prevailing"`` (local clock time of ``timezone``; the repeated fall-back hour is told apart
    by its order in the file) or ``"standard"`` (local standard time all year). Any step that divides one
    hour works (15-min, hourly). Returns ``(hourly, metadata)``.
    """
    path = Path(path)
    if clock not in ("prevailing", "standard"):
        raise InputError(f"clock must be 'prevailing' or 'standard', got {clock!r}", column="clock")
    try:
        raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read CSV ({one_line(error)})", file=path) from error
    raw.columns = [c.strip().lower() for c in raw.columns]
    for key in ("timestamp", "fuel", "mwh"):
        if key not in raw.columns:
            raise InputError("missing column", file=path, column=key, row=1)
    known = read_emission_factors()
    fuels = raw["fuel"].str.strip()
    unknown = ~fuels.isin(known.index)
    if unknown.any():
        i = int(np.argmax(unknown.to_numpy()))
        raise InputError(f"unknown fuel {fuels.iloc[i]!r}; known: {', '.join(known.index)}",
                         file=path, column="fuel", row=i + 2)
    mwh = pd.to_numeric(raw["mwh"].str.strip(), errors="coerce")
    if mwh.isna().any():
        i = int(np.argmax(mwh.isna().to_numpy()))
        raise InputError(f"non-numeric value {raw['mwh'].iloc[i]!r}", file=path, column="mwh", row=i + 2)
    negative = (mwh < 0) & ~fuels.map(known["negative_allowed"]).astype(bool)
    if negative.any():
        i = int(np.argmax(negative.to_numpy()))
        raise InputError(f"negative energy {mwh.iloc[i]} MWh", file=path, column="mwh", row=i + 2)
    ends = _csv_interval_ends(raw["timestamp"], fuels, clock, ZoneInfo(timezone), path)
    steps = ends.groupby(fuels).transform(
        lambda s: s.diff().mode().iloc[0] if len(s) > 1 else pd.Timedelta("1h"))
    long = pd.DataFrame({"begin": ends - steps, "fuel": fuels, "mwh": mwh,
                         "where": [f"{path}, row {i + 2}" for i in range(len(raw))]})
    hourly = hourly_generation(long, file=path)
    return hourly, {"file": str(path), "clock": clock, "timezone": timezone, "fuels": list(hourly.columns)}


def _csv_interval_ends(text: pd.Series, fuels: pd.Series, clock: str, zone: ZoneInfo,
                       path: Path) -> pd.Series:
    """Interval-end timestamps in local standard time (naive) from the CSV ``timestamp`` strings."""
    text = text.str.strip()
    aware = text.str.contains(r"(?:Z|[+-]\d{2}:?\d{2})$", regex=True).to_numpy()
    if aware.any() and not aware.all():
        i = int(np.argmin(aware) if aware[0] else np.argmax(aware))
        raise InputError("mixes timestamps with and without UTC offset", file=path, column="timestamp",
                         row=i + 2)
    parsed = pd.to_datetime(text, errors="coerce", utc=bool(aware.all()), format="ISO8601")
    if parsed.isna().any():
        i = int(np.argmax(parsed.isna().to_numpy()))
        raise InputError(f"not a timestamp: {text.iloc[i]!r}", file=path, column="timestamp", row=i + 2)
    std = _standard_offset(zone, int(parsed.iloc[0].year))
    if aware.all():
        return pd.Series(pd.DatetimeIndex(parsed).tz_localize(None) + std, index=text.index)
    naive = pd.Series(pd.DatetimeIndex(parsed), index=text.index)
    if clock == "standard":
        return naive
    out = pd.Series(pd.NaT, index=text.index, dtype="datetime64[ns]")
    for _, part in naive.groupby(fuels, sort=False):
        try:
            local = pd.DatetimeIndex(part).tz_localize(zone, ambiguous="infer", nonexistent="raise")
        except Exception as error:  # pytz-style errors from pandas for ambiguous/nonexistent clock times
            raise InputError(f"cannot place prevailing-time labels on the clock ({one_line(error)})",
                             file=path, column="timestamp") from None
        out.loc[part.index] = local.tz_convert("UTC").tz_localize(None) + std
    return out


class _SheetLayout(NamedTuple):
    """Where things are in a month sheet: the header, key-column indexes and interval-label columns."""

    head: list[str]
    col: dict[str, int]
    regular: dict[int, int]
    extra: dict[int, int]


class _SheetRow(NamedTuple):
    """One parsed data row: its day and fuel, settlement type, sheet row number, 15-min interval
    beginnings (local standard time) and energies [MWh] in time order."""

    day: dt.date
    fuel: str
    settlement: str
    number: int
    begins: np.ndarray
    values: np.ndarray


def _sheet_layout(header: tuple, file: str) -> _SheetLayout:
    """The sheet's column layout from its header row; InputError if a key or interval column is missing."""
    head = [str(c).strip() if c is not None else "" for c in header]
    for key in KEY_COLUMNS:
        if key not in head:
            raise InputError("missing column", file=file, column=key, row=1)
    col = {key: head.index(key) for key in (*KEY_COLUMNS, "Settlement Type") if key in head}
    regular, extra = _interval_columns(head, file)
    return _SheetLayout(head, col, regular, extra)


def _is_blank_row(row: tuple | None) -> bool:
    """True for a missing row or one whose cells are all empty or whitespace."""
    return row is None or all(cell is None or str(cell).strip() == "" for cell in row)


def _parse_sheet_row(row: tuple, number: int, layout: _SheetLayout, *, file: str, known_fuels: pd.DataFrame,
                     timezone: str) -> _SheetRow:
    """Read and check one data row (sheet row ``number``): date, fuel, settlement, Total and intervals."""
    col = layout.col
    day = _cell_date(row[col["Date"]], file, number)
    fuel = _row_fuel(row[col["Fuel"]], known_fuels, file, number)
    settlement = str(row[col["Settlement Type"]]).strip() if "Settlement Type" in col else "FINAL"
    total = _number(row[col["Total"]], file, "Total", number)
    begins, columns = _day_columns(day, timezone, layout.regular, layout.extra, file, number)
    values = _row_values(row, columns, layout.head, file, number, day)
    negative_allowed = known_fuels.at[fuel, "negative_allowed"]
    _check_row_energy(values, total, negative_allowed, [layout.head[c] for c in columns], file, number)
    return _SheetRow(day, fuel, settlement, number, begins, values)


def _row_fuel(cell: object, known_fuels: pd.DataFrame, file: str, number: int) -> str:
    """The fuel name in a ``Fuel`` cell; InputError if it is not a fuel of ``known_fuels``."""
    fuel = str(cell).strip() if cell is not None else ""
    if fuel not in known_fuels.index:
        raise InputError(f"unknown fuel {fuel!r}; known: {', '.join(known_fuels.index)}",
                         file=file, column="Fuel", row=number)
    return fuel


def _check_row_energy(values: np.ndarray, total: float, negative_allowed: bool, labels: list[str], file: str,
                      number: int) -> None:
    """InputError on a negative interval energy [MWh] (unless the fuel allows it) or a ``Total`` [MWh]
    that differs from the sum of the intervals by more than 1e-3 MWh + 1e-6 of the total."""
    if not negative_allowed and (values < 0).any():
        k = int(np.argmax(values < 0))
        raise InputError(f"negative energy {values[k]} MWh", file=file, column=labels[k], row=number)
    if abs(values.sum() - total) > 1e-3 + 1e-6 * abs(total):
        raise InputError(f"Total {total} differs from the sum of the intervals {values.sum():.6f}",
                         file=file, column="Total", row=number)


def _supersedes(new: _SheetRow, old: _SheetRow | None, file: str) -> bool:
    """Whether ``new`` should be kept over ``old``, an earlier row for the same day and fuel.

    A FINAL row replaces a non-FINAL one and is kept over a later non-FINAL one; any other repeat is an
    InputError.
    """
    if old is None:
        return True
    if old.settlement == "FINAL" and new.settlement != "FINAL":
        return False
    if not (old.settlement != "FINAL" and new.settlement == "FINAL"):
        raise InputError(f"duplicate row for {new.day} {new.fuel} (also row {old.number})",
                         file=file, column="Date", row=new.number)
    return True


def _sheet_frame(rows: list[_SheetRow], file: str) -> pd.DataFrame:
    """The long frame (``begin``, ``fuel``, ``mwh`` [MWh], ``where``) of the kept rows, in order."""
    if not rows:
        return pd.DataFrame({"begin": pd.DatetimeIndex([]), "fuel": [], "mwh": [], "where": []})
    return pd.DataFrame({
        "begin": np.concatenate([r.begins for r in rows]),
        "fuel": np.concatenate([np.full(len(r.values), r.fuel, dtype=object) for r in rows]),
        "mwh": np.concatenate([r.values for r in rows]),
        "where": np.concatenate([np.full(len(r.values), f"{file}, row {r.number}", dtype=object)
                                 for r in rows]),
    })


@functools.lru_cache(maxsize=512)
def _day_layout(day: dt.date, timezone: str) -> tuple[np.ndarray, tuple[tuple[int, int], ...]]:
    """The real 15-min intervals of a local day: begins in standard time (read-only datetime64 array) and,
    for each, (label minutes, fold)."""
    zone = ZoneInfo(timezone)
    start = dt.datetime(day.year, day.month, day.day, tzinfo=zone).astimezone(dt.UTC)
    nxt = day + dt.timedelta(days=1)
    stop = dt.datetime(nxt.year, nxt.month, nxt.day, tzinfo=zone).astimezone(dt.UTC)
    std = _standard_offset(zone, day.year)
    begins, keys = [], []
    begin = start
    while begin < stop:
        local = begin.astimezone(zone)  # ERCOT labels = the begin's wall-clock time + 15 min
        keys.append((local.hour * 60 + local.minute + 15, local.fold))
        begins.append(np.datetime64(begin.replace(tzinfo=None) + std, "ns"))
        begin += STEP
    array = np.array(begins, dtype="datetime64[ns]")
    array.flags.writeable = False
    return array, tuple(keys)


def _interval_columns(head: list[str], file: str) -> tuple[dict[int, int], dict[int, int]]:
    """Map label minutes (15..1440) -> column index, for regular and ``(DST)`` columns."""
    regular: dict[int, int] = {}
    extra: dict[int, int] = {}
    for index, name in enumerate(head):
        match = _LABEL.match(name)
        if not match:
            continue
        minutes = int(match.group(1)) * 60 + int(match.group(2))
        minutes = 1440 if minutes == 0 else minutes
        (extra if match.group(3) else regular)[minutes] = index
    expected = list(range(15, 1441, 15))
    if sorted(regular) != expected:
        missing = next(m for m in expected if m not in regular)
        raise InputError(f"missing interval column {missing // 60 % 24}:{missing % 60:02d}", file=file, row=1)
    return regular, extra


def _day_columns(day: dt.date, timezone: str, regular: dict[int, int], extra: dict[int, int], file: str,
                 number: int) -> tuple[np.ndarray, list[int]]:
    """Interval beginnings (standard time) of a local day and the sheet column holding each interval."""
    begins, keys = _day_layout(day, timezone)
    columns = []
    for minutes, fold in keys:
        table = extra if fold else regular
        if minutes not in table:
            raise InputError(f"{day} has {len(keys)} intervals (DST change) but the sheet lacks a "
                             f"'(DST)' column for the repeated hour", file=file, row=number)
        columns.append(table[minutes])
    return begins, columns


def _row_values(row: tuple, columns: list[int], head: list[str], file: str, number: int,
                day: dt.date) -> np.ndarray:
    """The row's interval values in time order; InputError on empty, non-numeric or misplaced cells."""
    cells = [row[i] if i < len(row) else None for i in columns]
    try:
        values = np.array(cells, dtype=float)
    except (TypeError, ValueError):
        values = np.array([_number(c, file, head[i], number) if c is not None else np.nan
                           for c, i in zip(cells, columns, strict=True)])
    if np.isnan(values).any() or np.isinf(values).any():
        k = int(np.argmax(~np.isfinite(values)))
        cell = cells[k]
        if cell is None or (isinstance(cell, str) and not cell.strip()):
            raise InputError(f"empty cell: gap in the data of {day}", file=file, column=head[columns[k]],
                             row=number)
        raise InputError(f"non-numeric cell {cell!r}", file=file, column=head[columns[k]], row=number)
    if len(columns) != 96 or len(row) > 100:
        used = set(columns)
        for index, name in enumerate(head):
            if index in used or not _LABEL.match(name):
                continue
            if index < len(row) and row[index] not in (None, "", 0):
                raise InputError(f"value in an interval that does not exist on {day} (DST change)",
                                 file=file, column=name, row=number)
    return values


def _number(cell: object, file: object, column: str, row: int) -> float:
    """A cell as a finite float (numbers as they are, text parsed); InputError naming the cell otherwise."""
    if isinstance(cell, bool):
        cell = str(cell)
    if isinstance(cell, int | float):
        value = float(cell)
    else:
        try:
            value = float(str(cell).strip())
        except ValueError:
            raise InputError(f"non-numeric cell {cell!r}", file=file, column=column, row=row) from None
    if not np.isfinite(value):
        raise InputError(f"non-numeric cell {cell!r}", file=file, column=column, row=row)
    return value


def _cell_date(cell: object, file: object, row: int) -> dt.date:
    """A ``Date`` cell (date, datetime or date text) as a date; InputError naming the cell otherwise."""
    if isinstance(cell, dt.datetime):
        return cell.date()
    if isinstance(cell, dt.date):
        return cell
    try:
        return pd.Timestamp(str(cell).strip()).date()
    except (ValueError, TypeError):
        raise InputError(f"not a date: {cell!r}", file=file, column="Date", row=row) from None


def _standard_offset(zone: ZoneInfo, year: int) -> dt.timedelta:
    """UTC offset of the zone's standard time (offset minus DST) in ``year``."""
    probe = dt.datetime(year, 1, 15, 12, tzinfo=zone)
    return probe.utcoffset() - probe.dst()
