"""A stock row's own annual end uses: both column layouts, units, the groups the schedules keep apart, the
refusal of a bad value, and the schedules that then add up to what the row says."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from citylearn_env.errors import InputError
from surrogates.energyplus.end_uses import END_USE_GROUPS, KWH_PER_MBTU, parse_end_uses
from surrogates.energyplus.epw import MAINS_OFFSET_K, read_epw_mains_mean
from surrogates.energyplus.house import build_house_model
from surrogates.energyplus.metadata import HouseParameters, house_parameters_from_metadata
from surrogates.energyplus.occupancy import daylight_days
from surrogates.energyplus.occupant_schedules import EXTERIOR_HOURS, ScheduleTargets, generate_schedules
from surrogates.energyplus.schedule_file import (
    HOT_WATER_USE_C,
    SCHEDULE_COLUMNS,
    WATER_KJ_PER_L_K,
    house_schedules,
    schedule_targets,
)

ROOT = Path(__file__).resolve().parents[3]
STOCK = ROOT / "raw" / "eulp" / "resstock_characteristics_100_dwellings.parquet"
TRAVIS = ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw"


def results_row(**mbtu: float) -> dict[str, object]:
    """A buildstockbatch results row with the given electricity end uses [MBtu/year]."""
    row: dict[str, object] = {"building_id": 5, "build_existing_model.occupants": "2",
                              "upgrade_costs.floor_area_conditioned_ft_2": 1500.0}
    for name, value in mbtu.items():
        key = ("report_simulation_output.load_hot_water_delivered_m_btu" if name == "dhw"
               else f"report_simulation_output.end_use_electricity_{name}_m_btu")
        row[key] = value
    return row


def test_results_layout_in_mbtu_grouped_per_day():
    uses = parse_end_uses(results_row(plug_loads=10.0, refrigerator=2.0, range_oven=1.0, clothes_dryer=3.0,
                                      lighting_interior=4.0, lighting_exterior=0.5, lighting_garage=0.25,
                                      pool_pump=5.0, dhw=8.0))
    per_day = KWH_PER_MBTU / 365.0
    assert uses.plug == pytest.approx(12.0 * per_day)
    assert uses.cooking == pytest.approx(1.0 * per_day)
    assert uses.dryer == pytest.approx(3.0 * per_day)
    assert uses.lighting == pytest.approx(4.0 * per_day)
    assert uses.outdoor_lighting == pytest.approx(0.75 * per_day)
    assert uses.exterior == pytest.approx(5.0 * per_day)
    assert uses.dhw_delivered == pytest.approx(8.0 * per_day)
    # 1 MBtu is 293.07 kWh: a 10 MBtu plug load is about 8 kWh a day
    assert 7.9 < 10.0 * per_day < 8.1


def test_published_layout_in_kwh_and_no_results_means_none():
    row = {"bldg_id": 3, "out.electricity.plug_loads.energy_consumption.kwh": 3650.0,
           "out.electricity.clothes_dryer.energy_consumption.kwh": 730.0,
           "out.load.hot_water.energy_delivered.kbtu": 10_000.0}
    uses = parse_end_uses(row)
    assert (uses.plug, uses.dryer, uses.cooking) == pytest.approx((10.0, 2.0, 0.0))
    assert uses.dhw_delivered == pytest.approx(10_000.0 * 0.29307107 / 365.0)
    assert parse_end_uses({"bldg_id": 3, "in.plug_loads": "100%"}) is None
    assert set(END_USE_GROUPS) == {"plug", "cooking", "dryer", "lighting", "outdoor_lighting",
                                    "exterior"}


def test_a_bad_value_names_the_column_and_the_building():
    with pytest.raises(InputError) as error:
        parse_end_uses(results_row(plug_loads=10.0, clothes_dryer=-1.0), source="stock.parquet")
    text = str(error.value)
    assert "end_use_electricity_clothes_dryer_m_btu" in text and "bldg_id=5" in text and "stock.parquet" in text


def test_targets_follow_the_row_and_hot_water_follows_the_delivered_heat():
    row = results_row(plug_loads=10.0, range_oven=1.0, clothes_dryer=3.0, lighting_interior=4.0, dhw=8.0)
    house = house_parameters_from_metadata(row)
    targets = schedule_targets(house, 30.0, mains_mean_c=23.0)
    per_day = KWH_PER_MBTU / 365.0
    assert targets.plug_kwh_per_day == pytest.approx(10.0 * per_day)
    assert (targets.cooking_kwh_per_day, targets.dryer_kwh_per_day) == pytest.approx((per_day, 3.0 * per_day))
    # litres x 4.186 kJ/(L K) x (43 - 23) K = the delivered heat
    heat_kj = targets.dhw_litres_per_day * WATER_KJ_PER_L_K * (HOT_WATER_USE_C - 23.0)
    assert heat_kj / 3600.0 == pytest.approx(8.0 * per_day)
    # without results the floor-area densities apply, as before
    assert schedule_targets(HouseParameters(bldg_id=1, floor_area_m2=150.0)).cooking_kwh_per_day is None


def test_schedules_keep_each_end_use_and_run_outdoor_pumps_by_day():
    targets = ScheduleTargets(occupants=3, dhw_litres_per_day=150.0, plug_kwh_per_day=12.0,
                              lighting_kwh_per_day=3.0, latitude_deg=30.0, cooking_kwh_per_day=1.2,
                              dryer_kwh_per_day=2.5, exterior_kwh_per_day=8.0, clock_zone="America/Chicago")
    s = generate_schedules(targets, year=2018, seed=1, bldg_id=9)
    kwh_day = {name: getattr(s, name).mean() * 24 / 1000 for name in ("cooking_w", "dryer_w", "exterior_w",
                                                                        "plug_w", "lighting_w")}
    assert kwh_day["cooking_w"] == pytest.approx(1.2) and kwh_day["dryer_w"] == pytest.approx(2.5)
    assert kwh_day["exterior_w"] == pytest.approx(8.0)
    assert kwh_day["plug_w"] == pytest.approx(12.0 + 1.2 + 2.5 + 8.0)
    assert kwh_day["lighting_w"] == pytest.approx(3.0)
    by_hour = s.exterior_w.reshape(365, 24)
    start, end = int(EXTERIOR_HOURS[0]), int(EXTERIOR_HOURS[1])
    # the pumps' timer keeps the clock: an hour earlier in standard time on days in daylight time
    summer = daylight_days(2018, "America/Chicago")
    for day, shift in enumerate(summer.astype(int)):
        assert np.all(by_hour[day, :start - shift] == 0) and np.all(by_hour[day, end - shift:] == 0)
        np.testing.assert_allclose(by_hour[day, start - shift:end - shift], 8000.0 / (end - start))
    assert summer.sum() == 238  # 11 March to 3 November 2018
    # the dryer keeps its cycles (most hours without one), only their power follows the row
    assert np.mean(s.dryer_w == 0) > 0.8


def test_garage_and_exterior_lights_use_electricity_but_do_not_heat_the_zone(tmp_path):
    row = results_row(plug_loads=10.0, lighting_interior=3.0, lighting_garage=0.5, lighting_exterior=1.0,
                      pool_pump=2.0, dhw=8.0)
    house = house_parameters_from_metadata(row)
    per_day = KWH_PER_MBTU / 365.0
    schedules = house_schedules(house, 2018, 2, 4, 30.0)
    kwh_day = {name: getattr(schedules, name).mean() * 24 / 1000 for name in ("lighting_w", "outdoor_lighting_w")}
    assert kwh_day == pytest.approx({"lighting_w": 3.0 * per_day, "outdoor_lighting_w": 1.5 * per_day})
    # outdoor lights burn when the interior lights do (occupied dark hours), in proportion
    np.testing.assert_allclose(schedules.outdoor_lighting_w * 3.0, schedules.lighting_w * 1.5, rtol=1e-9)
    model = build_house_model(house, mode="ideal", ground_temperatures_c=[20.0] * 12, timesteps_per_hour=2,
                              schedule_seed=4, latitude_deg=30.0, schedule_dir=tmp_path)
    table = pd.read_csv(model["Schedule:File"]["occupancy"]["file_name"])
    assert list(table.columns) == list(SCHEDULE_COLUMNS)
    zone_lights = sum(table["lighting_fraction"] * obj["lighting_level"] for obj in model["Lights"].values())
    np.testing.assert_allclose(zone_lights, schedules.lighting_w, rtol=1e-4, atol=2e-3)
    outdoor = [obj for obj in model["ElectricEquipment"].values() if obj["schedule_name"] == "exterior"]
    assert outdoor and all(obj["fraction_lost"] == 1.0 for obj in outdoor)
    outdoor_w = sum(table["exterior_fraction"] * obj["design_level"] for obj in outdoor)
    np.testing.assert_allclose(outdoor_w, schedules.exterior_w + schedules.outdoor_lighting_w, rtol=1e-4, atol=2e-3)


def test_mains_mean_is_the_mean_air_temperature_plus_the_offset():
    rows = np.loadtxt(TRAVIS, delimiter=",", skiprows=8, usecols=6)
    assert read_epw_mains_mean(TRAVIS) == pytest.approx(rows.mean() + MAINS_OFFSET_K)
    assert 18.0 < read_epw_mains_mean(TRAVIS) < 28.0  # Austin: about 21 C air, mains a few K warmer


def test_real_stock_rows_carry_their_end_uses():
    import pandas as pd

    from pipeline.ingest.stock import read_characteristics_row

    row = read_characteristics_row(STOCK, 8)
    uses = house_parameters_from_metadata(row).end_uses
    raw = pd.read_parquet(STOCK).set_index("building_id").loc[8]
    expected = sum(float(raw[f"report_simulation_output.end_use_electricity_{u}_m_btu"])
                   for u in END_USE_GROUPS["plug"]
                   if f"report_simulation_output.end_use_electricity_{u}_m_btu" in raw.index)
    assert uses.plug == pytest.approx(expected * KWH_PER_MBTU / 365.0)
    assert uses.dhw_delivered > 0
