"""Weather files (EPW, ResStock county CSV) -> canonical hourly frame -> CityLearn ``weather.csv`` columns.

Canonical frame: index = interval-beginning local standard time (tz-naive), hourly; columns (units in the
name) ``outdoor_dry_bulb_temperature_c``, ``outdoor_relative_humidity_pct``, ``ghi_w_m2``, ``dni_w_m2``,
``dhi_w_m2`` (hourly means = Wh/m2 over the hour), ``wind_speed_m_s``. Both sources label rows hour-ending
(EPW hour 1..24; the ResStock ``date_time`` is the end of the hour), so a row labelled H describes the hour
starting at H-1.

Forecast columns (``*_predicted_6h/12h/24h``): see :class:`ForecastSpec`.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.dataset import WEATHER_COLUMNS
from pipeline.errors import InputError
from pipeline.ingest.messages import one_line
from pipeline.ingest.timeindex import HOUR, check_regular, select_period

#: EPW 0-based field index -> canonical column (irradiance fields are Wh/m2 over the hour ending at the row)
EPW_FIELDS = {
    6: "outdoor_dry_bulb_temperature_c",
    8: "outdoor_relative_humidity_pct",
    13: "ghi_w_m2",
    14: "dni_w_m2",
    15: "dhi_w_m2",
    21: "wind_speed_m_s",
}
#: ResStock county weather CSV header -> canonical column
RESSTOCK_COLUMNS = {
    "Dry Bulb Temperature [°C]": "outdoor_dry_bulb_temperature_c",
    "Relative Humidity [%]": "outdoor_relative_humidity_pct",
    "Global Horizontal Radiation [W/m2]": "ghi_w_m2",
    "Direct Normal Radiation [W/m2]": "dni_w_m2",
    "Diffuse Horizontal Radiation [W/m2]": "dhi_w_m2",
    "Wind Speed [m/s]": "wind_speed_m_s",
}
#: canonical column -> (lowest, highest) accepted value
RANGES = {
    "outdoor_dry_bulb_temperature_c": (-70.0, 70.0),
    "outdoor_relative_humidity_pct": (0.0, 100.0),
    "ghi_w_m2": (0.0, 1500.0),
    "dni_w_m2": (0.0, 1500.0),
    "dhi_w_m2": (0.0, 1000.0),
    "wind_speed_m_s": (0.0, 60.0),
}
#: CityLearn observed column -> canonical column
CITYLEARN_SOURCES = {
    "outdoor_dry_bulb_temperature": "outdoor_dry_bulb_temperature_c",
    "outdoor_relative_humidity": "outdoor_relative_humidity_pct",
    "diffuse_solar_irradiance": "dhi_w_m2",
    "direct_solar_irradiance": "dni_w_m2",
}
HORIZONS = (6, 12, 24)
EPW_HEADER_LINES = 8
#: largest mean |T_out difference| [degC] between a table's own outdoor temperature and the district's weather
#: over their common hours before :func:`check_weather` refuses the table as simulated on other weather
WEATHER_TOLERANCE_C = 1.5


def read_epw(path: str | Path, tmy_year: int | None = None) -> tuple[pd.DataFrame, dict]:
    """Read an EPW file into the canonical hourly frame.

    Parameters
    ----------
    path
        EPW file: 8 header lines, then hourly rows (hour 1..24, hour-ending, local standard time).
    tmy_year
        Year to place a typical-year file in (its rows carry the years of their source months). Ignored for
        a single-year (AMY) file. A leap ``tmy_year`` gets Feb 29 copied from Feb 28.

    Returns
    -------
    ``(frame, metadata)``; metadata: ``city, state, country, source, wmo, latitude, longitude``
    (degrees north/east), ``utc_offset_hours``, ``elevation_m``, ``typical`` (bool), ``file``.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as error:
        raise InputError(f"cannot read ({error.strerror})", file=path) from error
    return parse_epw(lines, tmy_year=tmy_year, file=path)


def parse_epw(lines: list[str], *, tmy_year: int | None = None,
              file: object = "<epw>") -> tuple[pd.DataFrame, dict]:
    """Parse EPW text lines; see :func:`read_epw`."""
    meta = _epw_location(lines, file)
    dates, values = _epw_rows(lines[EPW_HEADER_LINES:], file)
    years, typical = _row_years(dates[:, 0], tmy_year, file)
    dates[:, 0] = years
    meta["typical"] = typical
    meta["file"] = str(file)
    frame = pd.DataFrame(values, index=_epw_index(dates, file))
    if meta["typical"] and tmy_year is not None:
        frame = _fill_leap_day(frame, tmy_year)
    _validate(frame, file, first_row=EPW_HEADER_LINES + 1)
    return frame, meta


def read_resstock_weather(path: str | Path) -> tuple[pd.DataFrame, dict]:
    """Read a ResStock county weather CSV (``date_time`` = end of the hour, local standard time).

    Returns ``(frame, metadata)`` with the canonical columns.
    """
    path = Path(path)
    try:
        raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read CSV ({one_line(error)})", file=path) from error
    for name in ("date_time", *RESSTOCK_COLUMNS):
        if name not in raw.columns:
            raise InputError("missing column", file=path, column=name, row=1)
    try:
        ends = pd.to_datetime(raw["date_time"].str.strip(), format="%Y-%m-%d %H:%M:%S")
    except ValueError:
        ends = pd.to_datetime(raw["date_time"].str.strip(), errors="coerce")
        i = int(np.argmax(ends.isna().to_numpy()))
        raise InputError(f"not a timestamp: {raw['date_time'].iloc[i]!r}", file=path, column="date_time",
                         row=i + 2) from None
    data = {}
    for source, name in RESSTOCK_COLUMNS.items():
        numbers = pd.to_numeric(raw[source].str.strip(), errors="coerce")
        if numbers.isna().any():
            i = int(np.argmax(numbers.isna().to_numpy()))
            raise InputError(f"non-numeric value {raw[source].iloc[i]!r}", file=path, column=source,
                             row=i + 2)
        data[name] = numbers.to_numpy(dtype=float)
    frame = pd.DataFrame(data, index=pd.DatetimeIndex(ends) - HOUR)
    _validate(frame, path, first_row=2, names={v: k for k, v in RESSTOCK_COLUMNS.items()})
    return frame, {"file": str(path), "typical": False}


def read_weather_file(path: str | Path, tmy_year: int | None = None) -> tuple[pd.DataFrame, dict]:
    """EPW (``.epw``, :func:`read_epw`) or ResStock county CSV (anything else, :func:`read_resstock_weather`)
    -> ``(frame, metadata)``."""

    path = Path(path)
    return read_epw(path, tmy_year=tmy_year) if path.suffix.lower() == ".epw" else read_resstock_weather(path)


def check_weather(own_outdoor_c: pd.Series, weather_outdoor_c: pd.Series, *, what: str, file: object) -> float:
    """Refuse (one line) a table whose own outdoor temperature [degC] differs from the district's weather by more
    than :data:`WEATHER_TOLERANCE_C` on average over their common hours; returns that mean difference.

    Both series are indexed by interval-beginning local standard time; no common hour is also a refusal.
    """
    common = own_outdoor_c.index.intersection(weather_outdoor_c.index)
    if len(common) == 0:
        raise InputError(f"{what} has no hour in common with the district's weather and period", file=file,
                         column="outdoor_dry_bulb_temperature")
    diff = float(np.mean(np.abs(own_outdoor_c.loc[common].to_numpy(dtype=float)
                                - weather_outdoor_c.loc[common].to_numpy(dtype=float))))
    if not diff <= WEATHER_TOLERANCE_C:
        raise InputError(f"{what} was simulated on other weather than the district's (mean |dT_out| = {diff:.2f} "
                         f"degC over {len(common)} h, limit {WEATHER_TOLERANCE_C}): re-simulate it with the "
                         "district's weather file", file=file, column="outdoor_dry_bulb_temperature")
    return diff

@dataclasses.dataclass(frozen=True)
class ForecastSpec:
    """How the 6/12/24 h forecast columns are made.

    ``mode="perfect"``: forecast_h(t) = observed(t + h). ``mode="noisy"``: the perfect value plus, for the
    temperature, an additive error U(-a_h, a_h) [C], and for RH and both irradiances a multiplicative
    error (1 + U(-r_h, r_h)); results clipped at >= 0 (RH also <= 100). Every (column, horizon) pair draws
    from its own stream ``numpy.random.default_rng([seed, column_number, horizon_number])`` (columns
    numbered in CityLearn order 0..3, horizons 0..2), so errors are independent across columns and
    horizons and reproducible. Hours past the end of the data hold the last observed value (no wrap-around).
    Defaults are the accuracies of the 2023 CityLearn challenge data.
    """

    mode: str = "perfect"
    seed: int = 0
    temperature_error_c: tuple[float, float, float] = (1.0, 1.5, 2.0)
    relative_error: tuple[float, float, float] = (0.2, 0.3, 0.4)

    def __post_init__(self) -> None:
        if self.mode not in ("perfect", "noisy"):
            raise InputError(f"forecast mode must be 'perfect' or 'noisy', got {self.mode!r}", column="mode")


def citylearn_weather(frame: pd.DataFrame, index: pd.DatetimeIndex, forecast: ForecastSpec = ForecastSpec(),
                      *, file: object = None) -> pd.DataFrame:
    """CityLearn weather columns (internal names of :data:`WEATHER_COLUMNS`) for the hours of ``index``."""
    select_period(frame, index, file=file)
    out = {}
    for number, (name, source) in enumerate(CITYLEARN_SOURCES.items()):
        series = frame[source]
        out[name] = series.loc[index].to_numpy(dtype=float)
        for k, hours in enumerate(HORIZONS):
            ahead = series.reindex(index + pd.Timedelta(hours=hours)).to_numpy(dtype=float)
            ahead = np.where(np.isnan(ahead), series.iloc[-1], ahead)
            if forecast.mode == "noisy":
                rng = np.random.default_rng([forecast.seed, number, k])
                if name == "outdoor_dry_bulb_temperature":
                    a = forecast.temperature_error_c[k]
                    ahead = ahead + rng.uniform(-a, a, len(ahead))
                else:
                    r = forecast.relative_error[k]
                    ahead = np.clip(ahead * (1.0 + rng.uniform(-r, r, len(ahead))), 0.0, None)
                    if name == "outdoor_relative_humidity":
                        ahead = np.minimum(ahead, 100.0)
            out[f"{name}_predicted_{hours}h"] = ahead
    result = pd.DataFrame(out, index=index)
    return result[list(WEATHER_COLUMNS)]


def _epw_location(lines: list[str], file: object) -> dict:
    """Metadata from the EPW ``LOCATION`` line: place names, ``latitude``/``longitude`` [degrees north/east],
    ``utc_offset_hours`` [h] and ``elevation_m`` [m]; InputError if the text is not an EPW file."""
    if len(lines) <= EPW_HEADER_LINES or not lines[0].startswith("LOCATION"):
        raise InputError("not an EPW file (first line must start with LOCATION)", file=file, row=1)
    loc = lines[0].split(",")
    try:
        return {"city": loc[1], "state": loc[2], "country": loc[3], "source": loc[4], "wmo": loc[5],
                "latitude": float(loc[6]), "longitude": float(loc[7]), "utc_offset_hours": float(loc[8]),
                "elevation_m": float(loc[9])}
    except (IndexError, ValueError) as error:
        raise InputError(f"malformed LOCATION line ({one_line(error)})", file=file, row=1) from None


def _epw_rows(data_lines: list[str], file: object) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The data rows (the lines after the header; blank lines skipped): an int array of
    (year, month, day, hour 1..24) per row and each :data:`EPW_FIELDS` column as floats (temperature [C],
    RH [%], irradiance [Wh/m2 over the hour], wind speed [m/s])."""
    rows = [line.split(",") for line in data_lines if line.strip()]
    dates = np.empty((len(rows), 4), dtype=np.int64)
    values = {name: np.empty(len(rows)) for name in EPW_FIELDS.values()}
    for i, fields in enumerate(rows):
        row = EPW_HEADER_LINES + 1 + i
        if len(fields) < 22:
            raise InputError(f"row has {len(fields)} fields, expected 35", file=file, row=row)
        for j in range(4):
            dates[i, j] = _epw_number(fields[j], file, ("year", "month", "day", "hour")[j], row)
        for index, name in EPW_FIELDS.items():
            values[name][i] = _epw_number(fields[index], file, f"{name} (field {index + 1})", row)
    return dates, values


def _row_years(years: np.ndarray, tmy_year: int | None, file: object) -> tuple[np.ndarray, bool]:
    """The year to place each row in and whether the file is a typical year (rows from several years).

    A typical-year file goes into ``tmy_year`` (InputError if it is not given); a single-year file keeps
    its years.
    """
    distinct = np.unique(years)
    typical = bool(len(distinct) > 1)
    if not typical:
        return years, typical
    if tmy_year is None:
        raise InputError(f"typical-year file (rows carry years {distinct.min()}..{distinct.max()}); "
                         "give tmy_year (the CLI uses the year of --start)", file=file)
    return np.full(len(years), tmy_year, dtype=years.dtype), typical


def _epw_index(dates: np.ndarray, file: object) -> pd.DatetimeIndex:
    """Interval-beginning timestamps (local standard time) of rows given as (year, month, day, hour 1..24)
    with the hour ending at the label; InputError on an hour outside 1..24 or an invalid date."""
    hours = dates[:, 3]
    if not ((hours >= 1) & (hours <= 24)).all():
        i = int(np.argmax((hours < 1) | (hours > 24)))
        raise InputError(f"hour {hours[i]} outside 1..24", file=file, column="hour",
                         row=EPW_HEADER_LINES + 1 + i)
    try:
        days = pd.to_datetime(pd.DataFrame({"year": dates[:, 0], "month": dates[:, 1], "day": dates[:, 2]}))
    except (ValueError, OverflowError) as error:
        raise InputError(f"invalid date ({one_line(error)})", file=file, column="month/day") from None
    return pd.DatetimeIndex(days) + pd.to_timedelta(hours - 1, unit="h")


def _validate(frame: pd.DataFrame, file: object, *, first_row: int,
              names: dict[str, str] | None = None) -> None:
    """InputError on an irregular hourly index or a value outside :data:`RANGES` (names the file column)."""
    check_regular(frame.index, HOUR, file=file, column="timestamp", first_row=first_row)
    for name, (low, high) in RANGES.items():
        values = frame[name].to_numpy()
        bad = (values < low) | (values > high)
        if bad.any():
            i = int(np.argmax(bad))
            label = (names or {}).get(name, name)
            what = "RH above 100 %" if name == "outdoor_relative_humidity_pct" and values[i] > high else \
                f"value {values[i]} outside [{low}, {high}] (a missing-data code?)"
            raise InputError(what, file=file, column=label, row=first_row + i)


def _fill_leap_day(frame: pd.DataFrame, year: int) -> pd.DataFrame:
    """``frame`` with Feb 29 copied from Feb 28 when ``year`` is a leap year and the file lacks that day."""
    if not pd.Timestamp(year=year, month=1, day=1).is_leap_year:
        return frame
    feb28 = frame.loc[f"{year}-02-28"]
    if len(feb28) == 0 or len(frame.loc[f"{year}-02-29":f"{year}-02-29"]):
        return frame
    copy = feb28.copy()
    copy.index = copy.index + pd.Timedelta(days=1)
    return pd.concat([frame, copy]).sort_index()


def _epw_number(text: str, file: object, column: str, row: int) -> float:
    """An EPW field as a float; InputError naming the field otherwise."""
    try:
        return float(text)
    except ValueError:
        raise InputError(f"non-numeric value {text!r}", file=file, column=column, row=row) from None
