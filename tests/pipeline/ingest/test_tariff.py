"""TOU tariff: the shipped Austin Energy 2018 file against the paper's table, clocks, holidays, bad input."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from pipeline.errors import InputError
from pipeline.ingest.tariff import citylearn_pricing, hourly_prices, read_tariff
from pipeline.ingest.timeindex import period_index

AUSTIN = Path(__file__).resolve().parents[3] / "raw" / "tariffs" / "austin_energy_tou_2018.toml"


def paper_price(stamp: pd.Timestamp) -> float:
    """The paper's table (reference/paper_application.md), transcribed: weekday 7-15 mid, 15-18 on,
    18-22 mid, 22-7 off; weekend 0.0289 all day."""
    if stamp.dayofweek >= 5:
        return 0.0289
    if 15 <= stamp.hour < 18:
        return 0.0587
    if 7 <= stamp.hour < 15 or 18 <= stamp.hour < 22:
        return 0.0291
    return 0.0289


def test_june_2018_reproduces_the_paper_table_every_hour():
    index = period_index("2018-06-01", "2018-06-30")
    prices = hourly_prices(read_tariff(AUSTIN), index)
    expected = [paper_price(t) for t in index]
    assert prices.tolist() == expected
    on_peak = prices[prices == 0.0587]
    assert len(on_peak) == 21 * 3  # 21 weekdays in June 2018, 3-6 PM
    assert set(on_peak.index.hour) == {15, 16, 17}  # CityLearn hours 16, 17, 18


def test_forecast_columns_continue_the_calendar():
    index = period_index("2018-06-01", "2018-06-30")
    table = citylearn_pricing(read_tariff(AUSTIN), index)
    later = index + pd.Timedelta(hours=6)
    assert table["electricity_pricing_predicted_6h"].tolist() == [paper_price(t) for t in later]
    # the last row's 24 h forecast is 2018-07-01 23:00, a Sunday
    assert table["electricity_pricing_predicted_24h"].iloc[-1] == 0.0289
    assert table["electricity_pricing_predicted_12h"].iloc[8] == 0.0291  # 20:00 Friday June 1


def test_prevailing_clock_moves_on_peak_one_hour_earlier_in_summer_only():
    tariff = dataclasses.replace(read_tariff(AUSTIN), clock="prevailing")
    june = hourly_prices(tariff, period_index("2018-06-04", "2018-06-04"))  # a Monday, CDT
    assert list(june[june == 0.0587].index.hour) == [14, 15, 16]
    january = hourly_prices(tariff, period_index("2018-01-08", "2018-01-08"))  # a Monday, CST
    assert list(january[january == 0.0587].index.hour) == [15, 16, 17]


def test_holiday_is_priced_as_weekend():
    prices = hourly_prices(read_tariff(AUSTIN), period_index("2018-07-04", "2018-07-05"))
    assert (prices.loc["2018-07-04"] == 0.0289).all()  # Wednesday, Independence Day
    assert prices.loc["2018-07-05 16:00"] == 0.0587


BASE = """
clock = "standard"
[prices]
low = 0.1
high = 0.2
[schedules]
weekday = [{ hours = [0, 12], period = "low" }, { hours = [12, 24], period = "high" }]
weekend = [{ hours = [0, 24], period = "low" }]
"""


@pytest.mark.parametrize(
    ("old", "new", "message", "key"),
    [
        ("[12, 24], period = \"high\"", "[11, 24], period = \"high\"", "hour 11 is covered twice",
         "schedules.weekday[1].hours"),
        ("[12, 24], period = \"high\"", "[13, 24], period = \"high\"", "hour 12 is not covered", "schedules.weekday"),
        ("period = \"high\"", "period = \"peak\"", "unknown period 'peak'", "schedules.weekday[1].period"),
        ("high = 0.2", "high = -0.2", "non-negative number", "prices.high"),
        ("high = 0.2", "high = \"cheap\"", "non-negative number", "prices.high"),
        ("clock = \"standard\"", "clock = \"solar\"", "'standard' or 'prevailing'", "clock"),
        ("weekend = ", "holidays = ", "missing schedule", "schedules.weekend"),
    ],
    ids=["overlap", "uncovered", "unknown-period", "negative", "non-numeric", "clock", "missing"],
)
def test_bad_tariff_files(tmp_path, old, new, message, key):
    path = tmp_path / "t.toml"
    path.write_text(BASE.replace(old, new, 1))
    with pytest.raises(InputError) as caught:
        read_tariff(path)
    text = str(caught.value)
    assert message in text and str(path) in text and repr(key) in text


def test_prevailing_clock_around_the_dst_changes():
    tariff = dataclasses.replace(read_tariff(AUSTIN), clock="prevailing")

    def on_peak_hours(day):
        prices = hourly_prices(tariff, period_index(day, day))
        return list(prices[prices == 0.0587].index.hour)

    assert on_peak_hours("2018-03-09") == [15, 16, 17]  # Friday before spring-forward (CST)
    assert on_peak_hours("2018-03-12") == [14, 15, 16]  # Monday after (CDT = standard + 1 h)
    assert on_peak_hours("2018-11-02") == [14, 15, 16]  # Friday before fall-back (CDT)
    assert on_peak_hours("2018-11-05") == [15, 16, 17]  # Monday after (CST)
    late = hourly_prices(tariff, pd.DatetimeIndex(["2018-06-08 23:00"]))  # Friday 23:00 CST = Sat 00:00 CDT
    assert late.iloc[0] == 0.0289
