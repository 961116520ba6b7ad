"""Calendar columns: hour-ending hours, Monday = 1, holidays = 8, DST status on the change days."""

from __future__ import annotations

import pandas as pd

from pipeline.ingest.calendar import calendar_columns
from pipeline.ingest.timeindex import period_index


def test_hour_ending_and_day_type():
    index = period_index("2018-06-01", "2018-06-03")  # Friday .. Sunday
    cal = calendar_columns(index)
    assert cal["hour"].iloc[0] == 1 and cal["hour"].iloc[23] == 24 and cal["hour"].iloc[24] == 1
    assert cal["day_type"].tolist() == [5] * 24 + [6] * 24 + [7] * 24
    assert (cal["month"] == 6).all() and (cal["daylight_savings_status"] == 0).all()


def test_last_hour_of_the_year_stays_in_december():
    cal = calendar_columns(pd.DatetimeIndex(["2018-12-31 23:00"]))
    assert cal.iloc[0].tolist() == [12, 24, 1, 0]


def test_holidays():
    cal = calendar_columns(period_index("2018-07-04", "2018-07-05"), holidays=["2018-07-04"])
    assert cal["day_type"].tolist() == [8] * 24 + [4] * 24


def test_dst_status_on_change_days():
    spring = calendar_columns(period_index("2018-03-11", "2018-03-11"), timezone="America/Chicago")
    # DST begins at 02:00 CST (clocks jump to 03:00 CDT): the hour starting 02:00 standard is the first
    assert spring["daylight_savings_status"].tolist() == [0, 0] + [1] * 22
    fall = calendar_columns(period_index("2018-11-04", "2018-11-04"), timezone="America/Chicago")
    # DST ends at 02:00 CDT = 01:00 CST
    assert fall["daylight_savings_status"].tolist() == [1] + [0] * 23
