"""Zone-load aggregation of the reference-house ILV tables (gross sums vs netted), on a hand-built two-zone
replay output whose expected rows are worked out by hand below."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks import reference_houses as rh
from citylearn_env.errors import InputError

SITE = "ENVIRONMENT"


def two_zone_replay() -> pd.DataFrame:
    """Three hours of a replay output (the frame :func:`read_report_variables` returns): a kitchen (30 m2)
    and a dining room (10 m2). Convective rates in W, EnergyPlus's sign (cooling objects negative)."""
    end = pd.DatetimeIndex(["2018-01-01 01:00", "2018-01-01 02:00", "2018-01-01 03:00"], name="end")
    columns = {
        ("Other Equipment Convective Heating Rate", "KITCHEN ILV COOL"): [-3000.0, -500.0, 0.0],
        ("Other Equipment Convective Heating Rate", "KITCHEN ILV HEAT"): [0.0, 0.0, 0.0],
        ("Other Equipment Convective Heating Rate", "DINING ILV COOL"): [0.0, 0.0, 0.0],
        ("Other Equipment Convective Heating Rate", "DINING ILV HEAT"): [1000.0, 2000.0, 700.0],
        ("Zone Mean Air Temperature", "KITCHEN"): [24.0, 23.0, 22.0],
        ("Zone Mean Air Temperature", "DINING"): [20.0, 19.0, 18.0],
        ("Zone People Occupant Count", "KITCHEN"): [2.0, 3.0, 0.0],
        ("Zone People Occupant Count", "DINING"): [10.0, 0.0, 1.0],
        ("Site Outdoor Air Drybulb Temperature", SITE): [1.0, 2.0, 3.0],
        ("Site Direct Solar Radiation Rate per Area", SITE): [0.0, 0.0, 0.0],
        ("Site Diffuse Solar Radiation Rate per Area", SITE): [0.0, 0.0, 0.0],
        ("day_type", ""): [1, 1, 1],
    }
    return pd.DataFrame(columns, index=end)


ZONES = ["Kitchen", "Dining"]
AREAS = {"KITCHEN": 30.0, "DINING": 10.0}


def test_gross_parse_reports_each_direction_summed_over_zones():
    rows = rh.parse_replay_hours(two_zone_replay(), 2, ZONES, AREAS, loads="gross")
    # hour 1: kitchen removes 3 kWh while the dining room gets 1 kWh -> both reported, not 2 kWh of cooling
    # hour 2: 0.5 kWh removed, 2 kWh added; hour 3: heating only, 0.7 kWh
    assert rows["cooling_demand"].tolist() == pytest.approx([3.0, 0.5, 0.0])
    assert rows["heating_demand"].tolist() == pytest.approx([1.0, 2.0, 0.7])
    # floor-area weights 30 : 10 -> (3 x 24 + 20) / 4 = 23, (3 x 23 + 19) / 4 = 22, (3 x 22 + 18) / 4 = 21
    assert rows["indoor_dry_bulb_temperature"].tolist() == pytest.approx([23.0, 22.0, 21.0])
    assert rows["occupant_count"].tolist() == [12.0, 3.0, 1.0]
    assert rows["timestamp"].iloc[0] == pd.Timestamp("2018-01-01 00:00") and rows["hour"].tolist() == [1, 2, 3]


def test_net_parse_keeps_only_the_difference():
    rows = rh.parse_replay_hours(two_zone_replay(), 2, ZONES, AREAS, loads="net")
    # 3 - 1 = 2 kWh cooling; 2 - 0.5 = 1.5 kWh heating; 0.7 kWh heating
    assert rows["cooling_demand"].tolist() == pytest.approx([2.0, 0.0, 0.0])
    assert rows["heating_demand"].tolist() == pytest.approx([0.0, 1.5, 0.7])
    gross = rh.parse_replay_hours(two_zone_replay(), 2, ZONES, AREAS, loads="gross")
    pd.testing.assert_frame_equal(rh.net_table(gross), rows)


def test_unknown_aggregation_is_one_clear_error():
    with pytest.raises(InputError, match="loads"):
        rh.aggregate_loads(np.ones(2), np.ones(2), "both")
    with pytest.raises(InputError, match="loads"):
        rh.generate_reference_ilv(rh.SUITE_HOUSES[0], "x", Path("missing.epw"), Path("unused"),
                                  settings=rh.SuiteSettings(loads="both"))


def test_cache_names_keep_net_tables_and_separate_gross():
    house, net = rh.SUITE_HOUSES[0], rh.SuiteSettings(timesteps_per_hour=1, loads="net")
    gross = dataclasses.replace(net, loads="gross")
    # the net tables keep the name they had before the field existed (the repr without `loads`)
    assert rh.settings_text(net) == ("SuiteSettings(partial_runs=6, timesteps_per_hour=1, year=2018, "
                                     "multiplier_range=(0.3, 1.7), probability=0.6, seed=0, "
                                     "max_replay_mad_c=0.2)")
    assert rh.settings_text(gross).endswith("max_replay_mad_c=0.2, loads='gross')")
    paths = {s.loads: rh.table_path(Path("c"), house, "x", "held", s) for s in (gross, net)}
    assert paths["gross"] != paths["net"]
