"""A SYNTHETIC ERCOT "Fuel Mix Report" workbook (IntGenbyFuel layout) from documented assumptions.

No value comes from a real ERCOT file; only the layout does: one sheet per month, header
``Date, Fuel, Settlement Type, Total, 0:15 ... 23:45, 0:00`` (labels = END of each 15-minute interval,
Central prevailing time), one row per day and fuel, cells in MWh per 15 minutes, ``Total`` = the day's
MWh. Spring-forward day: the cells 2:15-3:00 are empty (92 values); fall-back day: the ``Nov`` sheet has
four extra columns ``01:15 (DST)`` .. ``02:00 (DST)`` holding the second (standard-time) pass through
01:00-02:00 (100 values), while the regular 1:15-2:00 columns hold the first (daylight-time) pass.

Assumptions (ERCOT-like 2018 magnitudes, MW): system load = monthly mean x (1 + a cos(2 pi (h - 17)/24))
with a = 0.18 in summer and 0.10 otherwise, -5 % on weekends; nuclear 4,900 flat; wind monthly mean
x (1 + 0.3 cos(2 pi (h - 2)/24)) x a log-normal daily factor (linearly interpolated between
day centres); solar 1,800 x sin-shaped daylight bell x a
daily cloud factor; hydro 80, biomass 50, other 20; coal = 42 % of the remaining load clipped to
7,000-14,500; gas = the rest, 80 % combined cycle (Gas-CC) and 20 % other gas units (Gas). ``h`` is the
local *standard* hour. Everything is seeded (default 2018), so the workbook is reproducible.
"""

from __future__ import annotations

import datetime as dt
import io
import re
import zipfile
from collections.abc import Sequence
from pathlib import Path
from zoneinfo import ZoneInfo

import numpy as np
import pandas as pd

FUELS = ("Biomass", "Coal", "Gas", "Gas-CC", "Hydro", "Nuclear", "Other", "Solar", "Wind")
MONTHS = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")
#: monthly mean system load and wind (MW), daylight hours (sunrise, sunset in standard time)
LOAD_MW = (39000, 37000, 37000, 38000, 44000, 49000, 51000, 52000, 46000, 41000, 38000, 40000)
WIND_MW = (8500, 9000, 9500, 10000, 9000, 8000, 6500, 6000, 7000, 8500, 9000, 8500)
DAYLIGHT = ((7.4, 17.7), (7.1, 18.1), (6.6, 18.5), (6.1, 18.9), (5.6, 19.3), (5.4, 19.5), (5.6, 19.5),
            (5.9, 19.1), (6.2, 18.5), (6.5, 17.9), (6.9, 17.4), (7.3, 17.4))
TIMEZONE = ZoneInfo("America/Chicago")
STANDARD = dt.timezone(dt.timedelta(hours=-6))


def day_intervals(day: dt.date) -> list[tuple[dt.datetime, str]]:
    """The 15-minute intervals of one local day as (interval end in local standard time, ERCOT label).

    92 intervals on the spring-forward day (no 2:15-3:00 labels), 100 on the fall-back day: the first pass
    through 01:00-02:00 takes the regular 1:15-2:00 labels, the second pass ``01:15 (DST)`` ..
    ``02:00 (DST)``.
    """
    start = dt.datetime.combine(day, dt.time(), TIMEZONE).astimezone(dt.UTC)
    stop = dt.datetime.combine(day + dt.timedelta(days=1), dt.time(), TIMEZONE).astimezone(dt.UTC)
    count = int((stop - start) / dt.timedelta(minutes=15))
    out = []
    for k in range(1, count + 1):
        end = start + k * dt.timedelta(minutes=15)
        local = end.astimezone(TIMEZONE)
        out.append((end.astimezone(STANDARD).replace(tzinfo=None), f"{local.hour}:{local.minute:02d}"))
    if count == 92:  # the interval ending at the jump (02:00 CST = 03:00 CDT) keeps its 2:00 label
        out[7] = (out[7][0], "2:00")
    if count == 100:
        first = [f"{(m // 60)}:{m % 60:02d}" for m in range(15, 121, 15)]
        second = ["01:15 (DST)", "01:30 (DST)", "01:45 (DST)", "02:00 (DST)"]
        out = [(end, (first + second)[i] if i < 12 else label) for i, (end, label) in enumerate(out)]
    return out


def synthetic_generation_mw(ends: Sequence[dt.datetime], rng: np.random.Generator) -> pd.DataFrame:
    """Generation per fuel (MW) at interval ends given in local standard time (the assumptions above)."""
    ends = pd.DatetimeIndex(ends)
    hour = (ends - pd.Timedelta(minutes=7.5)).hour + (ends - pd.Timedelta(minutes=7.5)).minute / 60.0
    month = ends.month.to_numpy() - 1
    summer = np.isin(month, [5, 6, 7, 8])
    amplitude = np.where(summer, 0.18, 0.10)
    weekend = (ends - pd.Timedelta(minutes=1)).dayofweek.to_numpy() >= 5
    load = np.take(LOAD_MW, month) * (1 + amplitude * np.cos(2 * np.pi * (hour - 17) / 24)) * np.where(
        weekend, 0.95, 1.0) * (1 + 0.01 * rng.standard_normal(len(ends)))
    day = (ends - pd.Timedelta(minutes=1)).normalize()
    days, day_index = np.unique(day, return_inverse=True)
    days_elapsed = (day - days[0]).total_seconds().to_numpy() / 86400.0 + hour / 24.0
    daily = np.exp(0.35 * rng.standard_normal(len(days)))
    wind_day = np.interp(days_elapsed, np.arange(len(days)) + 0.5, daily)
    cloud_day = rng.uniform(0.55, 1.0, len(days))[day_index]
    rise, sets = np.take([d[0] for d in DAYLIGHT], month), np.take([d[1] for d in DAYLIGHT], month)
    bell = np.clip(np.sin(np.pi * (hour - rise) / (sets - rise)), 0.0, None) * ((hour > rise) & (hour < sets))
    out = {
        "Biomass": np.full(len(ends), 50.0), "Hydro": np.full(len(ends), 80.0),
        "Other": np.full(len(ends), 20.0),
        "Nuclear": np.full(len(ends), 4900.0) * (1 + 0.002 * rng.standard_normal(len(ends))),
        "Wind": np.take(WIND_MW, month) * (1 + 0.3 * np.cos(2 * np.pi * (hour - 2) / 24)) * wind_day,
        "Solar": 1800.0 * bell * cloud_day,
    }
    residual = load - sum(out.values())
    out["Coal"] = np.clip(0.42 * residual, 7000.0, 14500.0)
    gas = np.clip(residual - out["Coal"], 0.0, None)
    out["Gas-CC"], out["Gas"] = 0.8 * gas, 0.2 * gas
    return pd.DataFrame(out, index=ends)[list(FUELS)]


def write_synthetic_fuel_mix(path: Path, *, year: int = 2018, months: Sequence[int] = (6, 7),
                             seed: int = 2018) -> Path:
    """Write the synthetic workbook for ``months`` (1-12) of ``year``; byte-for-byte reproducible."""
    from openpyxl import Workbook

    rng = np.random.default_rng(seed)
    book = Workbook()
    notice = book.active
    notice.title = "Disclaimer"
    notice["A1"] = "SYNTHETIC DATA generated by districtgen (tools/synthetic_fuel_mix.py)."
    notice["A2"] = "Layout of the ERCOT Fuel Mix Report; values are NOT ERCOT data. See raw/README.md."
    regular = [f"{(m // 60) % 24}:{m % 60:02d}" for m in range(15, 24 * 60 + 1, 15)]
    for month in months:
        sheet = book.create_sheet(MONTHS[month - 1])
        days = pd.date_range(dt.date(year, month, 1), periods=pd.Period(f"{year}-{month:02d}").days_in_month)
        layouts = [day_intervals(d.date()) for d in days]
        dst = ["01:15 (DST)", "01:30 (DST)", "01:45 (DST)", "02:00 (DST)"]
        extra = dst if any(len(lay) == 100 for lay in layouts) else []
        header = ["Date", "Fuel", "Settlement Type", "Total", *regular, *extra]
        sheet.append(header)
        column = {label: i for i, label in enumerate(header)}
        for d, layout in zip(days, layouts, strict=True):
            mwh = synthetic_generation_mw([end for end, _ in layout], rng) * 0.25
            for fuel in FUELS:
                row: list[object] = [None] * len(header)
                row[0], row[1], row[2] = d.to_pydatetime(), fuel, "FINAL"
                values = np.round(mwh[fuel].to_numpy(), 3)
                for (_, label), value in zip(layout, values, strict=True):
                    row[column[label]] = float(value)
                row[3] = round(float(values.sum()), 3)
                sheet.append(row)
        for cell in sheet["A"][1:]:
            cell.number_format = "mm/dd/yyyy"
    fixed = dt.datetime(year, 1, 1)
    book.properties.created = book.properties.modified = fixed
    buffer = io.BytesIO()
    book.save(buffer)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    with zipfile.ZipFile(buffer) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst_zip:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename == "docProps/core.xml":  # openpyxl stamps the save time; pin it
                stamp = fixed.isoformat().encode() + b"Z"
                data = re.sub(rb"(<dcterms:modified[^>]*>)[^<]*", rb"\g<1>" + stamp, data)
            dst_zip.writestr(zipfile.ZipInfo(info.filename, date_time=(year, 1, 1, 0, 0, 0)), data,
                             compress_type=zipfile.ZIP_DEFLATED)
    tmp.replace(path)
    return path
