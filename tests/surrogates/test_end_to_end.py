"""End to end: test FMU -> ILV table -> train -> export -> citylearn_env episode with the exported model.

A one-building district (schema v2.2 layout) holds a January week of the Austin 2R2C house: its CSVs carry
the weather, calendar and ideal loads, its heat pump heats, and the heating-device action is active. Two
episodes: actions that deliver the ideal heating, and the same with +1 kWh/h for 6 hours (a step in the
heat-pump action). The heating the environment delivered is replayed through the FMU; the environment's
LSTM temperatures must follow the FMU's.

Stated tolerance: the step's temperature change within 0.35 K of the FMU's over the 6 step hours and the
6 after; the episode's temperature within 0.6 K RMSE of the FMU's after the warm-up.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from surrogates.export import export_surrogate
from surrogates.sources.fmu import simulate_ilv_fmu
from tests.surrogates.fmu.build import VARIABLE_MAP

FIRST, HOURS, STEP = 24 * 15, 7 * 24, 4 * 24 + 2  # 16 January 00:00, one week, step at day 5 02:00
NOMINAL_KW, EFFICIENCY, TARGET_C = 4.0, 0.3, 45.0


def write_district(folder, loads: pd.DataFrame, ideal_temperature: np.ndarray, block: dict) -> dict:
    from citylearn_env import dataset
    from citylearn_env.example import write_example_district

    schema = json.loads(write_example_district(folder, n_buildings=1, hours=len(loads)).read_text())
    index = loads.index
    building = {
        "month": index.month, "hour": index.hour + 1, "day_type": index.dayofweek + 1,
        "daylight_savings_status": 0, "indoor_dry_bulb_temperature": ideal_temperature,
        "average_unmet_cooling_setpoint_difference": 0.0, "indoor_relative_humidity": 50.0,
        "non_shiftable_load": 0.5, "dhw_demand": 0.0, "cooling_demand": loads["cooling_demand"].to_numpy(),
        "heating_demand": loads["heating_demand"].to_numpy(), "solar_generation": 0.0,
        "occupant_count": loads["occupant_count"].to_numpy(),
        "indoor_dry_bulb_temperature_set_point": loads["indoor_dry_bulb_temperature_set_point"].to_numpy(),
        "hvac_mode": 2, "power_outage": 0,
    }
    pd.DataFrame({k: building[k] for k in dataset.BUILDING_COLUMNS if k in building}).to_csv(folder / "Building_1.csv",
                                                                                         index=False)
    weather = pd.read_csv(folder / "weather.csv")
    for column in ("outdoor_dry_bulb_temperature", "direct_solar_irradiance", "diffuse_solar_irradiance"):
        weather[column] = loads[column].to_numpy()
    weather.to_csv(folder / "weather.csv", index=False)
    spec = schema["buildings"]["Building_1"]
    spec["type"] = "citylearn.building.LSTMDynamicsBuilding"
    spec["dynamics"] = block
    spec["heating_device"] = {"type": "citylearn.energy_model.HeatPump", "attributes": {
        "nominal_power": NOMINAL_KW, "efficiency": EFFICIENCY, "target_cooling_temperature": 8.0,
        "target_heating_temperature": TARGET_C}}
    schema["actions"]["heating_device"] = {"active": True}
    schema["actions"]["cooling_device"] = {"active": False}
    schema["root_directory"] = str(folder)
    for name in ("heating_demand", "occupant_count", "indoor_dry_bulb_temperature_set_point"):
        schema["observations"].setdefault(name, {"active": True, "shared_in_central_agent": False})
    return schema


def run_episode(schema: dict, heating_kwh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Actions that ask the heat pump for ``heating_kwh``; returns (delivered heating, indoor temperature)."""
    from citylearn_env import CityLearnEnv
    from citylearn_env.devices import carnot_cop_heating

    env = CityLearnEnv(schema)
    env.reset(seed=0)
    t_out = pd.read_csv(f"{schema['root_directory']}/weather.csv")["outdoor_dry_bulb_temperature"].to_numpy()
    cop = carnot_cop_heating(t_out, np.full_like(t_out, TARGET_C), np.full_like(t_out, EFFICIENCY))
    names = env.action_names
    for t in range(len(heating_kwh) - 1):
        action = np.zeros(len(names), dtype=np.float32)
        action[names.index(f"{env.building_names[0]}.heating_device")] = heating_kwh[t + 1] / (NOMINAL_KW * cop[t + 1])
        *_, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    series = env.series()
    return series["heating_demand"][0], series["indoor_dry_bulb_temperature"][0]


@pytest.fixture(scope="module")
def episodes(room_fmu, austin_surrogate, tmp_path_factory):
    pytest.importorskip("citylearn_env")
    loads, table, trained = austin_surrogate
    week = loads.iloc[FIRST:FIRST + HOURS]
    assert week["cooling_demand"].max() == 0.0 and week["heating_demand"].iloc[STEP:STEP + 6].min() > 0.3
    folder = tmp_path_factory.mktemp("district")
    paths = export_surrogate(trained, folder, "Building_1")
    block = json.loads(paths["dynamics"].read_text())
    ideal = table[table["reference"] == 0]["indoor_dry_bulb_temperature"].to_numpy()[FIRST:FIRST + HOURS]
    schema = write_district(folder, week, ideal, block)
    requested = week["heating_demand"].to_numpy().copy()
    stepped = requested.copy()
    stepped[STEP:STEP + 6] += 1.0
    out = {}
    for name, heating in (("base", requested), ("step", stepped)):
        delivered, indoor = run_episode(schema, heating)
        replay = week.iloc[:len(delivered)].copy()
        replay["heating_demand"] = delivered
        # the FMU replays the ideal loads from 1 January so its building mass has the right state
        replay = pd.concat([loads.iloc[:FIRST], replay])
        fmu = simulate_ilv_fmu(room_fmu, replay, VARIABLE_MAP, n_partial=0, start_values={"T0": 22.0})
        simulated = fmu[fmu["reference"] == 0]["indoor_dry_bulb_temperature"].to_numpy()[FIRST:]
        out[name] = (delivered, indoor, simulated)
    return out


def test_env_delivers_the_requested_step(episodes):
    d_heat = episodes["step"][0] - episodes["base"][0]
    np.testing.assert_allclose(d_heat[STEP:STEP + 6], 1.0, atol=1e-6)
    assert np.abs(d_heat[STEP + 6:]).max() < 1e-6


def test_env_temperature_follows_the_fmu(episodes):
    _, indoor, fmu = episodes["base"]
    warm = slice(24, len(indoor))
    assert np.sqrt(np.mean((indoor[warm] - fmu[warm]) ** 2)) < 0.6
    d_env = (episodes["step"][1] - indoor)[STEP:STEP + 12]
    d_fmu = (episodes["step"][2] - fmu)[STEP:STEP + 12]
    assert d_fmu[0] > 0.6
    assert np.max(np.abs(d_env - d_fmu)) < 0.35, (d_fmu.round(2), d_env.round(2))
