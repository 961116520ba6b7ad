"""Time-of-use tariffs described in a small TOML file -> hourly price series.

File format (see ``raw/tariffs/austin_energy_tou_2018.toml``)::

    name = "..."                 # free text
    unit = "$/kWh"               # only $/kWh is accepted
    clock = "standard"           # or "prevailing": which clock the schedule hours use
    timezone = "America/Chicago" # IANA zone; needed for "prevailing"
    holidays = ["2018-07-04"]    # dates priced with holiday_schedule
    holiday_schedule = "weekend" # a key of [schedules]
    [prices]                     # period name -> price [$/kWh]
    off_peak = 0.0289
    [schedules]                  # "weekday" (Mon-Fri) and "weekend" (Sat-Sun) are required
    weekday = [{ hours = [0, 7], period = "off_peak" }, ...]   # [start, end) clock hours covering 0-24

Prices of an hour are those of the schedule period containing the hour's start on the tariff's clock.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import tomllib
from pathlib import Path
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import numpy as np
import pandas as pd

from citylearn_env.dataset import PRICING_COLUMNS
from pipeline.errors import InputError
from pipeline.ingest.messages import one_line

HORIZONS = (6, 12, 24)


@dataclasses.dataclass(frozen=True)
class Tariff:
    """A parsed TOU tariff: for each day kind, the price [$/kWh] of each clock hour 0..23."""

    name: str
    clock: str
    timezone: str | None
    holidays: frozenset[dt.date]
    weekday: tuple[float, ...]
    weekend: tuple[float, ...]
    holiday: tuple[float, ...]
    periods: dict[str, float]


def read_tariff(path: str | Path) -> Tariff:
    """Read and validate a tariff TOML file."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise InputError(f"cannot read ({error.strerror})", file=path) from error
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"not valid TOML ({one_line(error)})", file=path) from error
    return parse_tariff(data, file=path)


def parse_tariff(data: dict, *, file: object = "<tariff>") -> Tariff:
    """Validate a tariff mapping (the parsed TOML); InputError names the key that is wrong."""
    _check_tables_and_unit(data, file)
    clock, timezone = _clock_and_timezone(data, file)
    prices = _period_prices(data["prices"], file)
    schedules = {name: _day_prices(spec, prices, file, f"schedules.{name}")
                 for name, spec in data["schedules"].items()}
    holiday_key = _holiday_schedule_key(data, schedules, file)
    holidays = _holiday_dates(data.get("holidays", []), file)
    return Tariff(name=str(data.get("name", "")), clock=clock, timezone=timezone, holidays=holidays,
                  weekday=schedules["weekday"], weekend=schedules["weekend"], holiday=schedules[holiday_key],
                  periods=prices)


def hourly_prices(tariff: Tariff, index: pd.DatetimeIndex) -> pd.Series:
    """Price [$/kWh] of each hour of ``index`` (interval-beginning, local standard time)."""
    index = pd.DatetimeIndex(index)
    clock = index
    if tariff.clock == "prevailing":
        zone = ZoneInfo(tariff.timezone)
        probe = dt.datetime(int(index[0].year), 1, 15, 12, tzinfo=zone)
        std = probe.utcoffset() - probe.dst()
        shift = [(t.to_pydatetime() - std).replace(tzinfo=dt.UTC).astimezone(zone).dst() for t in index]
        clock = index + pd.to_timedelta(shift)
    table = np.array([tariff.weekday, tariff.weekend, tariff.holiday])
    kind = np.where(clock.dayofweek.to_numpy() >= 5, 1, 0)
    if tariff.holidays:
        kind = np.where(np.isin(clock.normalize().date, list(tariff.holidays)), 2, kind)
    return pd.Series(table[kind, clock.hour.to_numpy()], index=index, name="electricity_pricing")


def citylearn_pricing(tariff: Tariff, index: pd.DatetimeIndex) -> pd.DataFrame:
    """CityLearn pricing columns: the price and its 6/12/24 h perfect forecasts from the tariff calendar."""
    out = {"electricity_pricing": hourly_prices(tariff, index).to_numpy()}
    for hours in HORIZONS:
        out[f"electricity_pricing_predicted_{hours}h"] = hourly_prices(
            tariff, index + pd.Timedelta(hours=hours)).to_numpy()
    return pd.DataFrame(out, index=index)[list(PRICING_COLUMNS)]


def _check_tables_and_unit(data: dict, file: object) -> None:
    """InputError unless ``[prices]`` and ``[schedules]`` are tables and ``unit`` (if given) is $/kWh."""
    for key in ("prices", "schedules"):
        if not isinstance(data.get(key), dict):
            raise InputError("missing table", file=file, column=key)
    if data.get("unit", "$/kWh") != "$/kWh":
        raise InputError(f"unit must be '$/kWh', got {data['unit']!r}", file=file, column="unit")


def _clock_and_timezone(data: dict, file: object) -> tuple[str, str | None]:
    """The schedule clock (``"standard"`` by default or ``"prevailing"``) and the IANA time zone, checked.

    The zone is required for the prevailing clock and must be known to :mod:`zoneinfo` when given.
    """
    clock = data.get("clock", "standard")
    if clock not in ("standard", "prevailing"):
        raise InputError(f"must be 'standard' or 'prevailing', got {clock!r}", file=file, column="clock")
    timezone = data.get("timezone")
    if clock == "prevailing" and not timezone:
        raise InputError("required when clock = 'prevailing'", file=file, column="timezone")
    if timezone:
        try:
            ZoneInfo(timezone)
        except (ZoneInfoNotFoundError, ValueError):
            raise InputError(f"unknown time zone {timezone!r}", file=file, column="timezone") from None
    return clock, timezone


def _period_prices(table: dict, file: object) -> dict[str, float]:
    """Period name -> price [$/kWh] from the ``[prices]`` table; each must be a finite number >= 0."""
    prices = {}
    for name, value in table.items():
        if (isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value)
                or value < 0):
            raise InputError(f"price must be a non-negative number, got {value!r}", file=file,
                             column=f"prices.{name}")
        prices[name] = float(value)
    return prices


def _holiday_schedule_key(data: dict, schedules: dict[str, tuple[float, ...]], file: object) -> str:
    """The schedule used on holidays (``holiday_schedule``, default ``"weekend"``), after checking that
    the required ``weekday`` and ``weekend`` schedules exist."""
    for name in ("weekday", "weekend"):
        if name not in schedules:
            raise InputError("missing schedule", file=file, column=f"schedules.{name}")
    holiday_key = data.get("holiday_schedule", "weekend")
    if holiday_key not in schedules:
        raise InputError(f"unknown schedule {holiday_key!r}; known: {', '.join(schedules)}", file=file,
                         column="holiday_schedule")
    return holiday_key


def _holiday_dates(days: list, file: object) -> frozenset[dt.date]:
    """The ``holidays`` list (TOML dates or ``YYYY-MM-DD`` strings) as dates."""
    holidays = set()
    for i, day in enumerate(days):
        try:
            holidays.add(day if isinstance(day, dt.date) else dt.date.fromisoformat(str(day)))
        except ValueError:
            raise InputError(f"not a date YYYY-MM-DD: {day!r}", file=file, column=f"holidays[{i}]") from None
    return frozenset(holidays)


def _day_prices(spec: object, prices: dict[str, float], file: object, key: str) -> tuple[float, ...]:
    """Price [$/kWh] of each clock hour 0..23 from a schedule (a list of ``{ hours = [start, end),
    period = name }`` blocks covering every hour exactly once); InputError names the block that is wrong."""
    if not isinstance(spec, list) or not spec:
        raise InputError("must be a list of { hours = [start, end], period = name }", file=file, column=key)
    hours: list[float | None] = [None] * 24
    for i, block in enumerate(spec):
        where = f"{key}[{i}]"
        if not isinstance(block, dict) or "hours" not in block or "period" not in block:
            raise InputError("needs 'hours' and 'period'", file=file, column=where)
        span = block["hours"]
        if (not isinstance(span, list) or len(span) != 2 or not all(isinstance(h, int) for h in span)
                or not 0 <= span[0] < span[1] <= 24):
            raise InputError(f"hours must be [start, end] with 0 <= start < end <= 24, got {span!r}",
                             file=file, column=f"{where}.hours")
        if block["period"] not in prices:
            raise InputError(f"unknown period {block['period']!r}; known: {', '.join(prices)}", file=file,
                             column=f"{where}.period")
        for hour in range(span[0], span[1]):
            if hours[hour] is not None:
                raise InputError(f"hour {hour} is covered twice", file=file, column=f"{where}.hours")
            hours[hour] = prices[block["period"]]
    if None in hours:
        raise InputError(f"hour {hours.index(None)} is not covered", file=file, column=key)
    return tuple(hours)
