"""The FMU ILV source, on the real Room2R2C FMU compiled from C (no mocks of fmpy)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pipeline.errors import InputError
from surrogates.ilv import validate_ilv
from surrogates.sources.fmu import check_variables, load_multipliers, simulate_ilv_fmu
from tests.surrogates.fmu.build import VARIABLE_MAP, synthetic_house

# steady-state conductance of the default 2R2C zone seen by a heat flow into the air, by hand:
# UA_air + H_am * UA_mass / (H_am + UA_mass) = 120 + 900 * 60 / 960 = 176.25 W/K
STEADY_UA = 176.25


def constant_loads(hours: int, t_out: float, heating_kwh: float) -> pd.DataFrame:
    index = pd.date_range("2026-01-05", periods=hours, freq="h")
    return pd.DataFrame({"direct_solar_irradiance": 0.0, "diffuse_solar_irradiance": 0.0,
                         "outdoor_dry_bulb_temperature": t_out, "occupant_count": 0.0, "cooling_demand": 0.0,
                         "heating_demand": heating_kwh}, index=index)


def test_steady_state_matches_hand_calculation(room_fmu):
    table = simulate_ilv_fmu(room_fmu, constant_loads(24 * 40, 5.0, 1.0), VARIABLE_MAP, n_partial=2, seed=3)
    assert validate_ilv(table).shape == table.shape
    last = table.groupby("reference").tail(1).set_index("reference")
    # ideal replay: 1 kW of heating -> 5 + 1000 / 176.25 = 10.674 degC; free float -> outdoor temperature
    assert last.loc[0, "indoor_dry_bulb_temperature"] == pytest.approx(5.0 + 1000.0 / STEADY_UA, abs=0.02)
    assert last.loc[1, "indoor_dry_bulb_temperature"] == pytest.approx(5.0, abs=0.02)
    assert table[table["reference"] == 1]["heating_demand"].eq(0.0).all()
    partial = table[table["reference"] == 2]["heating_demand"].to_numpy()
    varied = partial != 1.0
    assert 0.5 < varied.mean() < 0.7  # p = 0.6
    assert partial[varied].min() >= 0.3 and partial[varied].max() <= 1.7
    np.testing.assert_array_equal(partial, load_multipliers(len(partial), 2, seed=3))


def test_calendar_and_reproducibility(room_fmu):
    loads = constant_loads(72, 0.0, 2.0)
    a = simulate_ilv_fmu(room_fmu, loads, VARIABLE_MAP, n_partial=1, seed=1)
    b = simulate_ilv_fmu(room_fmu, loads, VARIABLE_MAP, n_partial=1, seed=1)
    pd.testing.assert_frame_equal(a, b)
    assert a["reference"].unique().tolist() == [0, 1, 2]
    first = a.iloc[0]
    assert (first["hour"], first["day_type"], first["month"]) == (1, 1, 1)  # Monday 00:00 -> hour 1


def test_ideal_replay_holds_the_comfort_band(room_fmu):
    """Loads solved hour by hour by the test helper, replayed by the ILV source, keep the zone in [20, 24]."""
    house = synthetic_house(room_fmu, days=10, t_mean=17.25)
    assert house["heating_demand"].sum() > 1 and house["cooling_demand"].sum() > 1  # both modes occur
    table = simulate_ilv_fmu(room_fmu, house, VARIABLE_MAP, n_partial=0, start_values={"T0": 22.0})
    ideal = table[table["reference"] == 0]["indoor_dry_bulb_temperature"]
    assert ideal.min() > 20.0 - 1e-6 and ideal.max() < 24.0 + 1e-6
    assert "indoor_dry_bulb_temperature_set_point" in table.columns


def test_net_heat_flow_mapping_gives_the_same_result(room_fmu):
    loads = constant_loads(48, 3.0, 0.5)
    loads.loc[loads.index[10:20], "cooling_demand"] = 0.8
    loads.loc[loads.index[10:20], "heating_demand"] = 0.0
    split = simulate_ilv_fmu(room_fmu, loads, VARIABLE_MAP, n_partial=0)
    # Q_heat takes heating minus cooling; the air node only sees the difference
    net_map = {k: v for k, v in VARIABLE_MAP.items() if k not in ("heating_power", "cooling_power")}
    net = simulate_ilv_fmu(room_fmu, loads, {**net_map, "net_heating_power": "Q_heat"}, n_partial=0)
    np.testing.assert_allclose(net["indoor_dry_bulb_temperature"], split["indoor_dry_bulb_temperature"],
                               atol=1e-9)


def test_missing_or_wrong_fmu_variables(room_fmu, tmp_path):
    with pytest.raises(InputError) as info:
        check_variables(room_fmu, {**VARIABLE_MAP, "outdoor_dry_bulb_temperature": "T_outdoor"})
    assert info.value.column == "outdoor_dry_bulb_temperature" and "T_outdoor" in str(info.value)
    assert "T_out" in str(info.value)  # lists the FMU's inputs
    with pytest.raises(InputError, match="causality 'input'"):
        check_variables(room_fmu, {**VARIABLE_MAP, "indoor_dry_bulb_temperature": "T_out"})
    with pytest.raises(InputError, match="heating_power"):
        check_variables(room_fmu, {"indoor_dry_bulb_temperature": "T_in"})
    with pytest.raises(InputError, match="unknown mapping key"):
        check_variables(room_fmu, {**VARIABLE_MAP, "humidity": "RH"})
    broken = tmp_path / "broken.fmu"
    broken.write_bytes(b"not a zip")
    with pytest.raises(InputError, match="not a readable FMU"):
        check_variables(broken, VARIABLE_MAP)


def test_bad_loads_frame(room_fmu):
    loads = constant_loads(24, 0.0, 1.0)
    loads.loc[loads.index[5], "heating_demand"] = np.nan
    with pytest.raises(InputError) as info:
        simulate_ilv_fmu(room_fmu, loads, VARIABLE_MAP)
    assert (info.value.column, info.value.row) == ("heating_demand", 5)
    with pytest.raises(InputError, match="consecutive hourly"):
        simulate_ilv_fmu(room_fmu, constant_loads(24, 0.0, 1.0).drop(index=pd.Timestamp("2026-01-05 03:00")),
                         VARIABLE_MAP)
