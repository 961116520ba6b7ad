"""CLI sub-commands that write CityLearn input files (weather, tariff, carbon, eulp).

Every command writes one row per hour from ``--start`` 00:00 to ``--end`` 23:00 (local standard time;
row 0 is CityLearn hour 1) in the chosen layout, and is also a plain Python function (``write_*``). Only the
command handlers live here: they compose the readers of :mod:`pipeline.ingest` (nothing imports this module
but the CLI and its tests).
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from citylearn_env.dataset import LAYOUTS, write_table
from citylearn_env.outputs import output_file
from pipeline.ingest.carbon import read_carbon_intensity
from pipeline.ingest.eulp import citylearn_building, read_eulp_building, solar_noon_lag_hours
from pipeline.ingest.tariff import citylearn_pricing, read_tariff
from pipeline.ingest.timeindex import period_index
from pipeline.ingest.weather import ForecastSpec, citylearn_weather, read_weather_file

DEFAULT_CACHE = Path(".cache") / "districtgen"
PathLike = str | os.PathLike
DateLike = str | dt.date


def write_weather(path: PathLike, start: DateLike, end: DateLike, output: PathLike, *, layout: str = "v2.2",
                  forecast: str = "perfect", seed: int = 0) -> Path:
    """Write CityLearn ``weather.csv`` for a period from an EPW or ResStock weather file."""
    output_file(output, column="--output")

    index = period_index(start, end)
    frame, _ = read_weather_file(path, tmy_year=index[0].year)
    table = citylearn_weather(frame, index, ForecastSpec(mode=forecast, seed=seed), file=path)
    return _write(output, "weather", table, layout)


def write_pricing(path: PathLike, start: DateLike, end: DateLike, output: PathLike, *,
                  layout: str = "v2.2") -> Path:
    """Write CityLearn ``pricing.csv`` for a period from a tariff TOML file."""
    output_file(output, column="--output")

    table = citylearn_pricing(read_tariff(path), period_index(start, end))
    return _write(output, "pricing", table, layout)


def write_carbon(path: PathLike, start: DateLike, end: DateLike, output: PathLike, *, layout: str = "v2.2",
                 clock: str = "prevailing", timezone: str = "America/Chicago",
                 factors: PathLike | None = None) -> Path:
    """Write CityLearn ``carbon_intensity.csv`` from an ERCOT workbook (.xlsx) or a long CSV."""
    output_file(output, column="--output")
    table = read_carbon_intensity(path, period_index(start, end), clock=clock, timezone=timezone, factors=factors)
    return _write(output, "carbon", table, layout)


def write_building(source: PathLike, building: int, start: DateLike, end: DateLike, output: PathLike, *,
                   layout: str = "v2.2", upgrade: int = 0, state: str | None = None,
                   cache_dir: PathLike = DEFAULT_CACHE, timestamp_offset_hours: float = 0.0,
                   weather: PathLike | None = None, tilt: float | None = None, azimuth: float = 180.0,
                   timezone: str | None = None, holidays: Iterable[DateLike] = ()) -> Path:
    """Write one CityLearn building CSV from EULP data (local release folder or base URL)."""
    output_file(output, column="--output")
    index = period_index(start, end)
    eulp = read_eulp_building(str(source), int(building), upgrade=upgrade, state=state, cache_dir=cache_dir,
                              timestamp_offset_hours=timestamp_offset_hours)
    solar = None
    if weather is not None:
        from pipeline.pv import site_pv_yield  # pvlib (pipeline.pv) loads only when PV is asked for

        frame, meta = read_weather_file(weather, tmy_year=index[0].year)
        solar = site_pv_yield(frame, meta, tilt=tilt, azimuth=azimuth, file=weather)
        _warn_if_shifted(eulp.series, meta["longitude"], meta["utc_offset_hours"])
    table = citylearn_building(eulp.loads, index, holidays=holidays, timezone=timezone,
                               solar_generation=solar, file=eulp.series_path)
    return _write(output, "building", table, layout)


def _write(output: PathLike, kind: str, table: pd.DataFrame, layout: str) -> Path:
    """Write a frame of internal-name columns through :func:`citylearn_env.dataset.write_table` (a new file
    renamed into place); ``output`` is checked again (:func:`citylearn_env.outputs.output_file`: no link at it, not
    in a built district)."""
    output_file(output, column="--output")
    return write_table(output, kind, {name: table[name].to_numpy(dtype=float) for name in table.columns}, layout)


def _warn_if_shifted(series, longitude: float, utc_offset_hours: float) -> None:
    """Print a note when the building's own PV output peaks an hour or more away from solar noon."""


    pv = [c for c in series.columns if c.startswith("out.electricity.pv.energy_consumption")]
    if not pv or not series[pv[0]].abs().gt(0).any():
        return
    hourly = series[pv[0]].groupby(series.index.floor("h")).sum()
    lag = solar_noon_lag_hours(hourly, longitude, utc_offset_hours)
    if abs(lag) >= 0.75:
        print(f"districtgen: note: the building's PV output is centred {lag:+.1f} h from solar noon; its "
              f"timestamps may use another time zone (try --timestamp-offset {-round(lag):+d})", file=sys.stderr)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ingest sub-commands to ``districtgen``."""
    weather = _command(subparsers, "weather", "EPW or ResStock weather CSV -> CityLearn weather.csv")
    weather.add_argument("--forecast", choices=("perfect", "noisy"), default="perfect",
                         help="6/12/24 h forecast columns: the future truth, or truth + seeded noise")
    weather.add_argument("--seed", type=int, default=0, help="noise seed (with --forecast noisy)")
    weather.set_defaults(func=lambda a: _done(write_weather(a.file, a.start, a.end, a.output, layout=a.layout,
                                                            forecast=a.forecast, seed=a.seed)))

    tariff = _command(subparsers, "tariff", "TOU tariff TOML -> CityLearn pricing.csv")
    tariff.set_defaults(func=lambda a: _done(write_pricing(a.file, a.start, a.end, a.output, layout=a.layout)))

    carbon = _command(subparsers, "carbon", "ERCOT fuel mix (.xlsx or long CSV) -> carbon_intensity.csv")
    carbon.add_argument("--clock", choices=("prevailing", "standard"), default="prevailing",
                        help="clock of naive timestamps in a long CSV (workbooks are always prevailing)")
    carbon.add_argument("--timezone", default="America/Chicago")
    carbon.add_argument("--factors", type=Path, help="emission factor CSV (default: the packaged one)")
    carbon.set_defaults(func=lambda a: _done(write_carbon(a.file, a.start, a.end, a.output, layout=a.layout,
                                                          clock=a.clock, timezone=a.timezone,
                                                          factors=a.factors)))

    eulp = _command(subparsers, "eulp", "EULP building (folder or base URL) -> CityLearn building CSV",
                    file_help="release folder or http(s) base URL laid out as the OEDI data lake")
    eulp.add_argument("--building", type=int, required=True, help="bldg_id")
    eulp.add_argument("--upgrade", type=int, default=0)
    eulp.add_argument("--state", help="two-letter state (default: in.state of the metadata)")
    eulp.add_argument("--cache", type=Path, default=DEFAULT_CACHE, help="download cache folder")
    eulp.add_argument("--timestamp-offset", type=float, default=0.0,
                      help="hours added to the file's timestamps (e.g. -1 for EST data at a Central site)")
    eulp.add_argument("--weather", type=Path, help="EPW for the solar_generation column (else 0)")
    eulp.add_argument("--tilt", type=float, help="PV tilt [deg] (default: latitude)")
    eulp.add_argument("--azimuth", type=float, default=180.0, help="PV azimuth [deg from north]")
    eulp.add_argument("--timezone", help="IANA zone for daylight_savings_status (default: all 0)")
    eulp.add_argument("--holidays", default="", help="comma-separated dates with day_type 8")
    eulp.set_defaults(func=lambda a: _done(write_building(
        a.file, a.building, a.start, a.end, a.output, layout=a.layout, upgrade=a.upgrade, state=a.state,
        cache_dir=a.cache, timestamp_offset_hours=a.timestamp_offset, weather=a.weather, tilt=a.tilt,
        azimuth=a.azimuth, timezone=a.timezone, holidays=[d for d in a.holidays.split(",") if d.strip()])))


def _command(subparsers, name: str, description: str, file_help: str = "input file") -> argparse.ArgumentParser:
    parser = subparsers.add_parser(name, help=description, description=description)
    parser.add_argument("file", help=file_help)
    parser.add_argument("--start", required=True, help="first date YYYY-MM-DD (its 00:00-01:00 is row 0)")
    parser.add_argument("--end", required=True, help="last date YYYY-MM-DD (inclusive)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="CSV to write")
    parser.add_argument("--layout", choices=LAYOUTS, default="v2.2",
                        help="v2.1 = positional human-readable header; v2.2 = snake_case header")
    return parser


def _done(path: Path) -> int:
    print(f"wrote {path}")
    return 0
