"""Reading report variables from an EnergyPlus SQLite output (stdlib sqlite3)."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.errors import InputError

#: EnergyPlus ``DayType`` -> project day_type (1 = Monday ... 7 = Sunday, 8 = holiday).
DAY_TYPES = {"Monday": 1, "Tuesday": 2, "Wednesday": 3, "Thursday": 4, "Friday": 5, "Saturday": 6,
             "Sunday": 7, "Holiday": 8, "CustomDay1": 8, "CustomDay2": 8}


def read_report_variables(sql_path: Path, *, year: int, frequency: str = "Hourly") -> pd.DataFrame:
    """Report variables of the run period (warm-up excluded) as a wide frame.

    Index: interval-END timestamps (tz-naive, local standard time, as EnergyPlus stamps them: the first
    15-minute row ends at 00:15, the first hourly row at 01:00); columns: a MultiIndex
    (variable name, key upper-case) plus ``("day_type", "")`` (1 = Monday ... 8 = holiday).
    ``frequency`` is ``"Hourly"`` or ``"Zone Timestep"``.
    """
    if not Path(sql_path).is_file():
        raise InputError("EnergyPlus SQLite output not found", file=sql_path)
    with sqlite3.connect(f"file:{sql_path}?mode=ro", uri=True) as con:
        dictionary = pd.read_sql_query(
            "SELECT ReportDataDictionaryIndex AS id, Name, KeyValue FROM ReportDataDictionary "
            "WHERE ReportingFrequency = ?", con, params=(frequency,))
        times = pd.read_sql_query(
            "SELECT TimeIndex, Month, Day, Hour, Minute, DayType FROM Time "
            "WHERE (WarmupFlag IS NULL OR WarmupFlag = 0) AND EnvironmentPeriodIndex = "
            "(SELECT MAX(EnvironmentPeriodIndex) FROM Time)", con)
        ids = ",".join(str(int(i)) for i in dictionary["id"])
        data = pd.read_sql_query(
            f"SELECT ReportDataDictionaryIndex AS id, TimeIndex, Value FROM ReportData "
            f"WHERE ReportDataDictionaryIndex IN ({ids or -1})", con)
    if dictionary.empty or data.empty:
        raise InputError(f"no {frequency} report variables in the EnergyPlus output", file=sql_path)
    data = data[data["TimeIndex"].isin(times["TimeIndex"])]
    wide = data.pivot(index="TimeIndex", columns="id", values="Value")
    times = times.set_index("TimeIndex").loc[wide.index]
    day_start = pd.to_datetime(pd.DataFrame({"year": year, "month": times["Month"], "day": times["Day"]}))
    end = (day_start + pd.to_timedelta(times["Hour"].to_numpy(), unit="h")
           + pd.to_timedelta(times["Minute"].to_numpy(), unit="min"))
    names = dictionary.set_index("id").loc[wide.columns]
    keys = names["KeyValue"].str.upper().to_numpy()
    wide.columns = pd.MultiIndex.from_arrays([names["Name"].to_numpy(), keys])
    wide.index = pd.DatetimeIndex(end.to_numpy(), name="end")
    wide[("day_type", "")] = times["DayType"].map(DAY_TYPES).fillna(8).astype("int64").to_numpy()
    return wide.sort_index()


def read_zone_floor_areas(sql_path: Path) -> dict[str, float]:
    """Floor area (m2) of every zone, keyed by upper-case zone name, as EnergyPlus computed it."""
    with sqlite3.connect(f"file:{sql_path}?mode=ro", uri=True) as con:
        rows = con.execute("SELECT ZoneName, FloorArea, Multiplier FROM Zones").fetchall()
    return {name.upper(): area * mult for name, area, mult in rows}


def area_weighted(frame: pd.DataFrame, variable: str, areas: dict[str, float]) -> pd.Series:
    """Floor-area-weighted mean over zones of ``variable`` (e.g. ``Zone Mean Air Temperature``)."""
    part = frame[variable]
    weights = np.array([areas[key] for key in part.columns])
    return pd.Series(part.to_numpy() @ weights / weights.sum(), index=frame.index)
