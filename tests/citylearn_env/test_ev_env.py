"""EV chargers and washing machines wired into the environment (docs/ev.md): schema into the typed config,
action and observation names, bounds, the district step, the history and KPI baseline, gymnasium's checker.

Small districts are written to ``tmp_path``; the upstream EV dataset tests skip without ../shared.
"""

from __future__ import annotations

import json
from dataclasses import FrozenInstanceError

import numpy as np
import pandas as pd
import pytest

from citylearn_env import CityLearnEnv, SchemaError, load_schema
from tests.citylearn_env.test_settings import ARRIVING, _ev_district
from tests.conftest import SHARED, need_shared

EV_SCHEMA = SHARED / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2022_phase_all_plus_evs" \
    / "schema.json"


def _with_machine(tmp_path, path: str) -> str:
    """Add washing machine ``W`` to building B: a start window over steps 1..3 whose cycle draws 2 then 1 kWh;
    no window elsewhere; its action after the charger's."""
    rows = [(-1, -1, "-1")] + [(1, 3, "[2.0, 1.0]")] * 3 + [(-1, -1, "-1")] * 20
    pd.DataFrame([(1, 1, *r) for r in rows], columns=["day_type", "hour", "wm_start_time_step", "wm_end_time_step",
                                                      "load_profile"]).to_csv(tmp_path / "wm.csv", index=False)
    schema = json.loads(open(path).read())
    schema["actions"]["washing_machine"] = {"active": True}
    schema["buildings"]["B"]["washing_machines"] = {"W": {"washing_machine_energy_simulation": "wm.csv"}}
    schema["observations"].update({k: {"active": True, "shared_in_central_agent": True} for k in (
        "electric_vehicle_charger_connected_state", "connected_electric_vehicle_at_charger_soc",
        "connected_electric_vehicle_at_charger_battery_capacity", "washing_machine_start_time_step")})
    open(path, "w").write(json.dumps(schema))
    return path


def test_schema_becomes_frozen_typed_config(tmp_path):
    config = load_schema(_ev_district(tmp_path))
    ev = config.electric_vehicles
    assert ev.vehicles.names == ("EV",) and ev.chargers.names == ("C",) and ev.chargers.building.tolist() == [0]
    assert ev.data.state[0, :6].tolist() == [s for s, *_ in ARRIVING]
    assert config.buildings[0].active_actions == ("electric_vehicle_storage_C",)
    with pytest.raises(FrozenInstanceError):
        ev.vehicles = None
    # the typed edits: realised initial SOCs, and the generic action expanded per charger
    assert config.with_ev_initial_soc({"EV": 0.25}).electric_vehicles.vehicles.battery.initial_soc.tolist() == [0.25]
    assert config.with_actions(["electric_vehicle_storage"]).buildings[0].active_actions == \
        ("electric_vehicle_storage_C",)
    with pytest.raises(SchemaError, match="'initial_soc.X'"):
        config.with_ev_initial_soc({"X": 0.5})


@pytest.mark.parametrize(("change", "key"), [
    (lambda s: s["buildings"]["B"]["chargers"]["C"]["attributes"].update(efficiency=1.5),
     "chargers.C.attributes.efficiency"),
    (lambda s: s["buildings"]["B"]["chargers"]["C"].pop("charger_simulation"),
     "buildings.B.chargers.C.charger_simulation"),
    (lambda s: s["electric_vehicles_def"]["EV"]["battery"]["attributes"].pop("capacity"),
     "electric_vehicles_def.EV.battery.attributes.capacity"),
    (lambda s: s["buildings"]["B"].update(charging_constraints={"building_limit_kw": 5}), "charging_constraints"),
    (lambda s: s["buildings"]["B"]["chargers"]["C"].update(noise_std=2.0), "chargers.C.noise_std"),
])
def test_bad_ev_schema_is_one_clear_error(tmp_path, change, key):
    path = _ev_district(tmp_path)
    schema = json.loads(open(path).read())
    change(schema)
    open(path, "w").write(json.dumps(schema))
    with pytest.raises(SchemaError, match=f"'{key}'"):
        CityLearnEnv(path)


def test_washing_machine_cycle_and_observations(tmp_path):
    env = CityLearnEnv(_with_machine(tmp_path, _ev_district(tmp_path)))
    assert env.action_names == ["B.electric_vehicle_storage_C", "B.W"]
    assert env.action_space.low.tolist() == [-1.0, 0.0]  # the charger can discharge; a machine only starts
    names = [n for n in env.observation_names if n != "hour"]
    assert names == ["B.electric_vehicle_charger_C_connected_state", "B.connected_electric_vehicle_at_charger_C_soc",
                     "B.connected_electric_vehicle_at_charger_C_battery_capacity", "B.W_start_time_step"]
    low, high = env.observation_space.low.tolist(), env.observation_space.high.tolist()
    np.testing.assert_array_equal(low[1:], np.float32([0.0, -0.1, -1.0, -1.0]))  # float32 spaces
    np.testing.assert_array_equal(high[1:], np.float32([1.0, 1.0, 100.0, 24.0]))
    obs, _ = env.reset(seed=0)
    assert obs[1:].tolist() == [0.0, pytest.approx(-0.1), -1.0, -1.0]  # row 0: no EV, no window
    obs, *_ = env.step(np.array([0.0, 1.0]))  # step 1: inside the window 1..3 -> the cycle starts: 2, then 1 kWh
    assert obs[-1] == 1.0  # the window's start step
    env.step(np.array([0.0, 1.0]))  # step 2: same window, already started: no second cycle
    env.step(np.array([0.0, 0.0]))  # step 3
    obs, *_ = env.step(np.array([0.0, 0.0]))  # step 4: the EV has left... and no window
    series = env.series()
    np.testing.assert_allclose(series["washing_machines_electricity_consumption"][0], [0.0, 2.0, 1.0, 0.0, 0.0])
    # the building's own loads are the same at steps 1..4 (constant data): the machine's load is on top
    base = series["net_electricity_consumption"][0, 4]
    np.testing.assert_allclose(series["net_electricity_consumption"][0, 1:] - base, [2.0, 1.0, 0.0, 0.0])
    # the machine's load is not storage: the without-storage baseline keeps it
    np.testing.assert_allclose(series["net_electricity_consumption_without_storage"][0, 1:] - base,
                               [2.0, 1.0, 0.0, 0.0])


def test_charger_consumption_enters_net_and_counts_as_storage(tmp_path):
    env = CityLearnEnv(_ev_district(tmp_path))
    env.reset(seed=0)
    env.step(np.array([0.0]))  # step 1: the EV is on its way
    env.step(np.array([0.5]))  # step 2: plugged in, charges 0.5 x 10 kW = 5 kWh through a lossless charger
    series = env.series()
    charger = series["chargers_electricity_consumption"][0]
    assert charger.tolist() == [0.0, 0.0, pytest.approx(5.0)]
    net, without = series["net_electricity_consumption"][0], series["net_electricity_consumption_without_storage"][0]
    assert net[2] - net[1] == pytest.approx(5.0)  # the same building loads at both steps
    assert without[2] == pytest.approx(net[1])  # EV charging is storage for the KPI baseline (CityLearn 2.5)
    observed = dict(zip(env.observation_names, env.flat_observations()[env.layout.central_index], strict=True))
    assert observed == {"hour": 3.0}  # the schema activates no EV observation here


def test_a_district_without_chargers_carries_no_ev_state(tmp_path):
    from citylearn_env.example import write_example_district

    env = CityLearnEnv(write_example_district(tmp_path, n_buildings=2, hours=24, seed=1))
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.district.ev is None and env.district.machines is None and env.action_layout.device_index is None
    assert "chargers_electricity_consumption" not in env.series()


def test_ev_dataset_names_and_gymnasium_checker():
    need_shared(EV_SCHEMA)
    from gymnasium.utils.env_checker import check_env

    env = CityLearnEnv(EV_SCHEMA, settings="citylearn-2.5", central_agent=True)
    assert env.action_space.shape == (26,)  # 17 batteries, 8 chargers, 1 washing machine
    assert "Building_15.electric_vehicle_storage_charger_15_2" in env.action_names
    assert "Building_15.connected_electric_vehicle_at_charger_charger_15_2_soc" in env.observation_names
    assert "Building_1.washing_machine_1_start_time_step" in env.observation_names
    check_env(env, skip_render_check=True)


def test_vector_copies_of_a_district_with_chargers_are_refused(tmp_path):
    from citylearn_env.vector import CityLearnVectorEnv

    # chargers index the original buildings; a copy's charger action would drive the first copy's charger
    with pytest.raises(SchemaError, match=r"B#1 has no device 'electric_vehicle_storage_C' \(it belongs to B#0\)"):
        CityLearnVectorEnv(_ev_district(tmp_path), 2)


def test_device_history(tmp_path):
    env = CityLearnEnv(_ev_district(tmp_path))
    env.reset(seed=0)
    env.step(np.array([0.0]))
    env.step(np.array([0.5]))  # step 2: 5 kWh into the EV that arrived with 40 %
    frame = env.device_history()
    charger = frame[frame.kind == "charger"]
    assert charger.device.tolist() == ["C"] * 3 and charger.building.tolist() == ["B"] * 3
    assert charger.electricity_consumption.tolist() == [0.0, 0.0, pytest.approx(5.0)]
    ev = frame[frame.kind == "electric_vehicle"]
    assert ev.time_step.tolist() == [0, 1, 2] and 0.4 < ev.soc.iloc[2] <= 0.4 + 5.0 / 50
