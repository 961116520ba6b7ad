"""CityLearn calendar columns (month, hour, day_type, daylight_savings_status) for an hourly index."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable
from zoneinfo import ZoneInfo

import numpy as np
import pandas as pd

from citylearn_env.dataset import calendar_of


def calendar_columns(
    index: pd.DatetimeIndex,
    holidays: Iterable[str | dt.date] = (),
    timezone: str | None = None,
) -> pd.DataFrame:
    """Calendar columns of a CityLearn building file for an hourly index.

    Parameters
    ----------
    index
        Interval-beginning timestamps in local standard time, tz-naive (the package's canonical index).
    holidays
        Dates whose rows get ``day_type`` 8.
    timezone
        IANA zone (e.g. ``"America/Chicago"``) used only for ``daylight_savings_status``: 1 where the
        interval's start lies in daylight saving time there. ``None`` writes 0 everywhere (what
        EnergyPlus-derived CityLearn data hold, since their simulations run without DST).

    Returns
    -------
    DataFrame with int columns ``month`` (1-12), ``hour`` (1-24, hour-ending: the row starting at 00:00 is
    hour 1), ``day_type`` (1 = Monday ... 7 = Sunday, 8 = holiday) and ``daylight_savings_status`` (0/1).
    """
    index = pd.DatetimeIndex(index)
    cal = calendar_of(index.to_numpy(), holidays)
    dst = np.zeros(len(index), dtype=np.int64)
    if timezone is not None:
        zone = ZoneInfo(timezone)
        std_offset = _standard_offset(zone, index)
        for i, stamp in enumerate(index):
            instant = (stamp.to_pydatetime() - std_offset).replace(tzinfo=dt.UTC)
            dst[i] = int(bool(instant.astimezone(zone).dst()))
    return pd.DataFrame(
        {
            "month": cal["month"].astype(np.int64),
            "hour": cal["hour"].astype(np.int64),
            "day_type": cal["day_type"].astype(np.int64),
            "daylight_savings_status": dst,
        },
        index=index,
    )


def _standard_offset(zone: ZoneInfo, index: pd.DatetimeIndex) -> dt.timedelta:
    """UTC offset of the zone's standard time (offset minus DST) in the year of the index."""
    year = int(index[0].year) if len(index) else 2000
    probe = dt.datetime(year, 1, 15, 12, tzinfo=zone)
    return probe.utcoffset() - probe.dst()
