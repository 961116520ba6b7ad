"""The realism statistics (pipeline/realism.py) on small hand-made series with known answers, and the
benchmark's real reference (benchmarks/realism.py) on the upstream CityLearn data when ../shared is present."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from pipeline.realism import (
    COOLING_COP,
    cooling_degree_days,
    daily_load_factor,
    electric_equivalent_kwh,
    energy_per_area_kwh_m2,
    hour_of_day_profile,
    hourly_peak_kwh,
    in_band,
    median_profile,
    median_ratio_pct,
    percentile_band,
    profile_l1_distance,
)
from tests.conftest import SHARED, need_shared


def test_hourly_peak_is_the_largest_hour():
    assert hourly_peak_kwh([0.2, 1.5, 0.7]) == 1.5
    assert hourly_peak_kwh(pd.Series([0.0, 0.0])) == 0.0
    assert hourly_peak_kwh([]) == 0.0


def test_energy_per_area_divides_the_total():
    assert energy_per_area_kwh_m2([10.0, 20.0, 30.0], 120.0) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="floor area"):
        energy_per_area_kwh_m2([1.0], 0.0)


def test_electric_equivalent_applies_the_efficiencies():
    one = pd.Series([1.0])
    total = electric_equivalent_kwh(one, pd.Series([3.0]), pd.Series([0.0]), pd.Series([2.0]))
    assert total.iloc[0] == pytest.approx(1.0 + 3.0 / COOLING_COP + 2.0)


def test_daily_load_factor_by_hand():
    flat = [1.0] * 24                         # mean/peak = 1
    spike = [0.0] * 23 + [24.0]               # mean 1, peak 24
    assert daily_load_factor(flat + spike) == pytest.approx((1.0 + 1 / 24) / 2)
    assert daily_load_factor(flat + [5.0] * 5) == pytest.approx(1.0)  # a partial last day is cut
    assert daily_load_factor([0.0] * 24 + flat) == pytest.approx(1.0)  # a zero day is left out
    assert math.isnan(daily_load_factor([0.0] * 24))


def test_hour_of_day_profile_is_normalised_and_wraps_hour_24():
    hours = list(range(1, 25)) * 2             # CityLearn hour-ending labels 1..24 (24 = midnight)
    load = [2.0 if h == 24 else 1.0 for h in hours]
    profile = hour_of_day_profile(load, hours)
    assert profile.sum() == pytest.approx(1.0)
    assert profile[0] == pytest.approx(2.0 / 25.0) and profile[5] == pytest.approx(1.0 / 25.0)
    with pytest.raises(ValueError, match="hours of the day without data"):
        hour_of_day_profile([1.0] * 23, list(range(23)))
    with pytest.raises(ValueError, match="sums to zero"):
        hour_of_day_profile([0.0] * 24, list(range(24)))


def test_profile_distance_and_median_profile():
    flat = np.full(24, 1 / 24)
    night = np.zeros(24)
    night[:12] = 1 / 12
    assert profile_l1_distance(flat, flat) == 0.0
    assert profile_l1_distance(night, flat) == pytest.approx(1.0)  # 12 x (1/12 - 1/24) + 12 x 1/24
    with pytest.raises(ValueError, match="length"):
        profile_l1_distance(flat, flat[:12])
    median = median_profile([flat, night, flat])
    assert median == pytest.approx(flat)


def test_percentile_band_in_band_and_median_ratio():
    low, median, high = percentile_band(list(range(101)) + [float("nan")])
    assert (low, median, high) == pytest.approx((5.0, 50.0, 95.0))
    assert all(math.isnan(v) for v in percentile_band([float("nan")]))
    assert in_band(50.0, (5.0, 50.0, 95.0)) is True and in_band(96.0, (5.0, 50.0, 95.0)) is False
    assert in_band(1.0, (float("nan"),) * 3) is None
    assert median_ratio_pct([1.0, 2.0, 3.0], 1.6) == pytest.approx(25.0)
    assert math.isnan(median_ratio_pct([1.0], 0.0))


def test_cooling_degree_days_by_hand():
    # one day at 28.3 degC: 10 K above the 65 F base for 24 h = 10 K day; a day at 18.3 or below adds nothing
    assert cooling_degree_days([28.3] * 24) == pytest.approx(10.0)
    assert cooling_degree_days([18.3] * 24 + [10.0] * 24) == 0.0
    # 12 h at 20.3 (2 K) and 12 h at 15 (0): 24 K h = 1 K day; another base moves it
    assert cooling_degree_days([20.3] * 12 + [15.0] * 12) == pytest.approx(1.0)
    assert cooling_degree_days([20.3] * 12 + [15.0] * 12, base_c=14.0) == pytest.approx((12 * 6.3 + 12 * 1.0) / 24)


def test_real_reference_is_the_deduplicated_austin_homes():
    root = SHARED / "data" / "citylearn"
    need_shared(root / "upstream" / "v2.4.2" / "citylearn_challenge_2023_phase_1")
    from benchmarks.realism import real_house_months

    summer = real_house_months(root, "JJA")
    # 6 homes x June-August (phase 3 weather) + 3 of them in June 2018 (phase 1, Austin AMY 2018)
    assert len(summer) == 21
    assert sorted({item.month for item in summer}) == [6, 7, 8]
    assert real_house_months(root, "DJF") == []


def test_real_weather_is_each_distinct_summer_once():
    """Every copy of the 2023 datasets carries a weather.csv; most are the same weather: one series per
    distinct month (June twice: the phase-1 June and the later phases' June-August are other years)."""
    root = SHARED / "data" / "citylearn"
    need_shared(root / "upstream" / "v2.4.2" / "citylearn_challenge_2023_phase_1")
    from benchmarks.realism import real_weather_months

    weather = real_weather_months(root)
    assert sorted(weather) == [6, 7, 8]
    assert [len(weather[m]) for m in (6, 7, 8)] == [2, 1, 1]
    assert len(weather[7][0]) == len(weather[8][0]) == 31 * 24 and all(len(v) == 30 * 24 for v in weather[6])
    assert all(24.0 < float(v.mean()) < 33.0 for m in weather for v in weather[m])  # an Austin summer, degC


def test_weather_line_compares_degree_days_per_30_days():
    from benchmarks.realism import weather_line

    june = np.full(30 * 24, 28.3)   # 10 K above the base: 300 K day in 30 days
    july = np.full(31 * 24, 28.3)   # 310 K day in 31 days: 300 per 30 days
    line = weather_line({6: [june + 3.0]}, {6}, {6: [june], 7: [july]}, {6, 7})
    assert "real (months [6, 7]) 300, mean 28.3 degC" in line
    assert "built (months [6]) 390 (+30 %), mean 31.3 degC" in line


def test_benchmark_table_flags_houses_outside_the_real_band():
    from benchmarks.realism import HouseMonth, fill_statistics, realism_table

    def month(name: str, cooling: float, area: float | None = None) -> HouseMonth:
        hours = np.tile(np.arange(1, 25), 30)
        loads = pd.DataFrame({"month": 6, "hour": hours, "non_shiftable_load": 0.5, "dhw_demand": 0.1,
                              "cooling_demand": cooling / 720.0, "heating_demand": 0.0})
        return HouseMonth(name, 6, loads, area)

    real = [month(f"r{i}", c) for i, c in enumerate([1000.0, 1500.0, 2000.0])]
    built = [month("B1", 1500.0, 100.0), month("B2", 9000.0, 100.0)]
    flat = np.full(24, 1 / 24)
    fill_statistics(real, flat)
    fill_statistics(built, flat)
    assert built[0].stats["cooling_kwh_m2"] == pytest.approx(15.0)
    assert built[0].stats["profile_l1"] == pytest.approx(0.0) and built[0].stats["daily_load_factor"] == 1.0
    table, summary = realism_table(built, real)
    assert summary["cooling_kwh"]["in_band"] == [True, False]
    assert summary["cooling_kwh"]["median_vs_real_pct"] == pytest.approx((5250.0 / 1500.0 - 1) * 100)
    assert "9,000 **no**" in table and "| n/a |" in table  # real houses have no floor area


def test_several_months_per_house_give_medians_and_months_in_band():
    from benchmarks.realism import HouseMonth, fill_statistics, per_house_table

    def month(name: str, number: int, cooling: float) -> HouseMonth:
        hours = np.tile(np.arange(1, 25), 30)
        loads = pd.DataFrame({"month": number, "hour": hours, "non_shiftable_load": 0.5, "dhw_demand": 0.1,
                              "cooling_demand": cooling / 720.0, "heating_demand": 0.0})
        return HouseMonth(name, number, loads)

    real = [month(f"r{i}", 7, c) for i, c in enumerate([1000.0, 1500.0, 2000.0])]
    # B1: two months in the band (1,200 and 1,800 kWh), one above; B2: one month, below
    built = [month("B1", 6, 1200.0), month("B1", 7, 1800.0), month("B1", 8, 9000.0), month("B2", 6, 100.0)]
    flat = np.full(24, 1 / 24)
    fill_statistics(real, flat)
    fill_statistics(built, flat)
    rows = {line.split(" | ")[0].lstrip("| "): line for line in per_house_table(built, real).splitlines()}
    cooling = rows["cooling in the month [kWh]"].split(" | ")
    # band 5 % / median / 95 % of 1,000, 1,500, 2,000 -> 1,050 / 1,500 / 1,950
    assert cooling[1:4] == ["1,050", "1,500", "1,950"]
    assert cooling[4] == "1,800 (2/3)" and cooling[5] == "100 (0/1)"
    # median of the four house-months (1,500) against the real median (1,500)
    assert cooling[6].strip(" |") == "+0 %"
    # with no real reference: the medians only, no band columns
    alone = per_house_table(built, None).splitlines()
    assert alone[0] == "| statistic | B1 | B2 |"
    assert "| cooling in the month [kWh] | 1,800 | 100 |" in alone


def test_own_row_electricity_counts_every_end_use_group_once():
    # the row's electricity that the house's lights and equipment are compared with: indoor and outdoor
    # lighting, pumps and appliances, each once (a group left out would show as a false excess of ours)
    from benchmarks.realism import OWN_ROW
    from surrogates.energyplus.end_uses import KWH_PER_MBTU, parse_end_uses

    mbtu = {"plug_loads": 10.0, "range_oven": 1.0, "clothes_dryer": 2.0, "lighting_interior": 3.0,
            "lighting_garage": 0.5, "lighting_exterior": 0.25, "pool_pump": 4.0}
    row = {"building_id": 7, **{f"report_simulation_output.end_use_electricity_{k}_m_btu": v for k, v in mbtu.items()}}
    reference = {label: kwh for _, kwh, label in OWN_ROW}["plug + lighting"]
    assert reference(pd.Series(row), parse_end_uses(row)) == pytest.approx(sum(mbtu.values()) * KWH_PER_MBTU)
