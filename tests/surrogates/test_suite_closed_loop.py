"""The trainer on a hand-written 1R1C zone (closed-loop error bound from the data), determinism of the full
recipe, the export run by the environment's LSTM runtime, and the reference-house model transforms."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
import torch

from benchmarks import reference_houses as rh
from citylearn_env.settings import CORRECTED
from surrogates.config import TrainConfig
from surrogates.evaluate import bank_rollout, monthly_rmse, predict_segment
from surrogates.export import dynamics_block, save_checkpoint
from surrogates.ilv import calendar_columns, validate_ilv
from surrogates.sources.fmu import load_multipliers
from surrogates.train import run_segments, train_surrogate

UA_W_K = 200.0  # envelope conductance
TAU_H = 20.0  # time constant C / UA
SET_POINT_C = 21.0


def one_r_one_c(hours: int = 24 * 75, references=(0, 2, 3, 4, 5, 6)) -> pd.DataFrame:
    """ILV table of a 1R1C zone: T[t+1] = T[t] + (T_out[t] - T[t]) / tau + 1000 q[t] / (UA tau)
    (hourly explicit Euler, q = heating kWh in the hour), ideal load q* = UA (21 - T_out) / 1000 holds 21 C;
    partial runs multiply q* by held U(0.3, 1.7) draws (p = 0.6)."""
    stamps = pd.date_range("2026-01-05", periods=hours, freq="h")
    t = np.arange(hours)
    t_out = 5.0 + 5.0 * np.sin(2 * np.pi * (t - 9) / 24) + 3.0 * np.sin(2 * np.pi * t / (24 * 9))
    ideal_kwh = UA_W_K * (SET_POINT_C - t_out) / 1000.0
    frames = []
    for ref in references:
        q = ideal_kwh * load_multipliers(hours, ref, seed=3)
        temp = np.empty(hours)
        temp[0] = SET_POINT_C
        for k in range(hours - 1):
            temp[k + 1] = temp[k] + (t_out[k] - temp[k]) / TAU_H + 1000.0 * q[k] / (UA_W_K * TAU_H)
        # row k holds the load of hour k and the temperature at its end
        frame = pd.DataFrame({"reference": ref, "timestamp": stamps})
        frame = pd.concat([frame, calendar_columns(stamps)], axis=1).assign(
            direct_solar_irradiance=0.0, diffuse_solar_irradiance=0.0, outdoor_dry_bulb_temperature=t_out,
            occupant_count=0.0, cooling_demand=0.0, heating_demand=q,
            indoor_dry_bulb_temperature=np.append(temp[1:], temp[-1]))
        frames.append(frame)
    return validate_ilv(pd.concat(frames, ignore_index=True))


SMALL = TrainConfig(hidden_size=8, epochs=12, pretrain_steps=400, chunk_hours=12, long_chunk_hours=24,
                    long_chunk_epochs=4, validation_hours=168, progress=False)


@pytest.fixture(scope="module")
def zone():
    table = one_r_one_c()
    return table, train_surrogate(table, SMALL)


def test_closed_loop_error_bound_from_the_data(zone):
    table, trained = zone
    test = run_segments(table)[6]
    simulated = table["indoor_dry_bulb_temperature"].to_numpy()[test.start + SMALL.lookback:test.stop]
    predicted = predict_segment(trained.model, trained.normalization, trained.inputs, SMALL.lookback, table, test)
    rmse = float(np.sqrt(np.mean((predicted - simulated) ** 2)))
    # ignoring the loads (predicting the set point the ideal loads hold) errs by the data's own spread
    # around 21 C; the surrogate must explain at least 3/4 of that variance (RMSE <= half)
    no_model = float(np.sqrt(np.mean((simulated - SET_POINT_C) ** 2)))
    assert no_model > 0.5  # the partial loads do move the zone
    assert rmse <= 0.5 * no_model, (rmse, no_model)
    # the steady-state gain is UA^-1 = 5 K per kW: 1 kWh/h more heating for a day warms the zone by
    # 5 (1 - exp(-24 / 20)) ~ 3.5 K; the surrogate's response to that step must be within 1 K of it
    rows = table.iloc[test.start:test.start + 24 * 8].copy()
    stepped = rows.copy()
    stepped.iloc[24 * 6:24 * 7, stepped.columns.get_loc("heating_demand")] += 1.0
    segment = run_segments(rows)[6]
    base = predict_segment(trained.model, trained.normalization, trained.inputs, SMALL.lookback, rows, segment)
    up = predict_segment(trained.model, trained.normalization, trained.inputs, SMALL.lookback, stepped, segment)
    expected = 5.0 * (1.0 - (1.0 - 1.0 / TAU_H) ** 24)
    assert abs((up - base)[24 * 7 - SMALL.lookback - 1] - expected) < 1.0


def test_full_recipe_is_deterministic(zone):
    table, trained = zone
    # the fixed schedule: 8 epochs of 12-h chunks, then 4 of 24-h chunks at the long phase's rate
    assert [h["chunk_hours"] for h in trained.history] == [12] * 8 + [24] * 4
    assert {h["learning_rate"] for h in trained.history[8:]} == {SMALL.long_chunk_learning_rate}
    again = train_surrogate(table, SMALL)
    for key, value in trained.model.state_dict().items():
        assert torch.equal(value, again.model.state_dict()[key]), key
    strip = [{k: v for k, v in h.items() if k != "seconds"} for h in trained.history]
    assert strip == [{k: v for k, v in h.items() if k != "seconds"} for h in again.history]


def test_export_runs_identically_in_the_environment_runtime(zone, tmp_path):
    table, trained = zone
    pth = save_checkpoint(trained, tmp_path / "zone.pth")
    block = dynamics_block(trained, str(pth)).to_schema()
    test = run_segments(table)[6]
    ours = predict_segment(trained.model, trained.normalization, trained.inputs, SMALL.lookback, table, test)
    # the environment's bank (weights read without torch) with torch's float32 rounding
    hours = bank_rollout(pth, block, table, [test], dataclasses.replace(CORRECTED, lstm_float32=True))
    assert len(hours) == len(ours)
    np.testing.assert_allclose(hours["predicted"].to_numpy(), ours, atol=1e-4)
    # float64 (the environment's default) differs only by float32 rounding
    exact = bank_rollout(pth, block, table, [test], CORRECTED)
    np.testing.assert_allclose(exact["predicted"].to_numpy(), ours, atol=1e-3)
    monthly = monthly_rmse(hours)
    assert monthly["hours"].sum() == len(hours)
    by_hand = np.sqrt(np.mean((hours["predicted"] - hours["simulated"])[hours["month"] == 2] ** 2))
    assert monthly.loc[monthly["month"] == 2, "rmse_c"].item() == pytest.approx(by_hand)


MODEL = {
    "Zone": {"a": {}, "attic": {}},
    "ZoneHVAC:EquipmentConnections": {"c": {"zone_name": "a"}},
    "AirLoopHVAC": {"x": {}}, "ZoneVentilation:DesignFlowRate": {"v": {}}, "EnergyManagementSystem:Program": {"p": {}},
    "ZoneInfiltration:DesignFlowRate": {"i": {"air_changes_per_hour": 0.5}, "j": {"flow_rate_per_exterior_surface_area": 3e-4}},
    "WindowMaterial:SimpleGlazingSystem": {"g": {"u_factor": 3.0, "solar_heat_gain_coefficient": 0.4}},
    "People": {"p": {"floor_area_per_person": 20.0}},
    "Lights": {"l": {"watts_per_floor_area": 10.0}},
    "GasEquipment": {"k": {"design_level": 1000.0}},
}


def test_hvac_free_model_and_variation_by_hand():
    model, zones = rh.hvac_free_model(MODEL)
    assert zones == ["a"]
    assert set(model) == {"Zone", "ZoneInfiltration:DesignFlowRate", "WindowMaterial:SimpleGlazingSystem", "People",
                          "Lights", "GasEquipment"}
    house = rh.ReferenceHouse("h", "m", infiltration_factor=4.0, window_u_factor=2.5, gains_factor=0.5)
    varied = rh.apply_variation(model, house)
    assert varied["ZoneInfiltration:DesignFlowRate"]["i"]["air_changes_per_hour"] == 2.0
    assert varied["ZoneInfiltration:DesignFlowRate"]["j"]["flow_rate_per_exterior_surface_area"] == pytest.approx(1.2e-3)
    assert varied["WindowMaterial:SimpleGlazingSystem"]["g"]["u_factor"] == 5.8  # 7.5 capped at single glazing
    assert varied["People"]["p"]["floor_area_per_person"] == 40.0  # half the people
    assert varied["Lights"]["l"]["watts_per_floor_area"] == 5.0
    assert varied["GasEquipment"]["k"]["design_level"] == 500.0
    assert model["Lights"]["l"]["watts_per_floor_area"] == 10.0  # input untouched
    replay = rh.replay_model(varied, zones, [10.0] * 12, rh.Path("loads.csv"), tph=1, year=2018)
    assert set(replay["OtherEquipment"]) == {"a ILV cool", "a ILV heat"}
    assert replay["OtherEquipment"]["a ILV cool"]["design_level"] == -1.0
    ideal = rh.ideal_model(varied, zones, [10.0] * 12, tph=1, year=2018)
    assert list(ideal["ZoneHVAC:IdealLoadsAirSystem"]) == ["a ideal loads air system"]


@pytest.mark.slow
def test_reference_house_ilv_passes_the_replay_check(tmp_path):
    pytest.importorskip("pyenergyplus", reason="pyenergyplus-lbnl (extra 'energyplus') ships the reference models")
    from surrogates.energyplus.engine import EnergyPlusNotInstalledError, find_energyplus
    from surrogates.ilv import read_ilv

    try:
        find_energyplus()
    except EnergyPlusNotInstalledError:
        pytest.skip("EnergyPlus engine not installed")
    house = rh.SUITE_HOUSES[2]
    epw = rh.package_data_dir("weather") / "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"
    paths = rh.generate_reference_ilv(house, "tampa", epw, tmp_path, schemes=["upstream"],
                                      settings=rh.SuiteSettings(partial_runs=1))
    table = read_ilv(paths["upstream"])
    assert sorted(table["reference"].unique()) == [0, 2] and len(table) == 2 * 8760
    ideal = table[table["reference"] == 0]
    # ideal loads hold the zones in the 20..24 C band (small excursions from hourly load averaging)
    assert ideal["indoor_dry_bulb_temperature"].between(19.5, 24.5).mean() > 0.99
    assert rh.generate_reference_ilv(house, "tampa", epw, tmp_path, schemes=["upstream"],
                                     settings=rh.SuiteSettings(partial_runs=1)) == paths  # cached
