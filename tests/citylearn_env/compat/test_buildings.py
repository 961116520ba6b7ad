"""``env.buildings[i]``: upstream attribute names read from the native arrays (equal to them, lazily, read only),
LSTM buildings and ``ignore_dynamics``, and ``BaselineAgent`` (every action switched off)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from citylearn_env import CityLearnEnv as NativeEnv
from citylearn_env.compat.agents.base import BaselineAgent
from citylearn_env.compat.building import LSTMDynamicsBuilding
from citylearn_env.compat.citylearn import CityLearnEnv
from tests.citylearn_env.compat.conftest import LSTM, native_env, replay

END = 47
#: building attribute -> native series name (same name unless given)
SERIES = ("net_electricity_consumption", "net_electricity_consumption_cost", "net_electricity_consumption_emission",
          "net_electricity_consumption_without_storage", "net_electricity_consumption_without_storage_and_partial_load",
          "net_electricity_consumption_without_storage_and_partial_load_and_pv", "indoor_dry_bulb_temperature",
          "indoor_dry_bulb_temperature_without_partial_load", "cooling_demand", "cooling_demand_without_partial_load",
          "cooling_electricity_consumption", "dhw_demand", "dhw_electricity_consumption",
          "dhw_storage_electricity_consumption", "electrical_storage_electricity_consumption", "non_shiftable_load",
          "non_shiftable_load_electricity_consumption", "energy_from_electrical_storage", "energy_to_electrical_storage",
          "energy_from_dhw_storage", "energy_from_dhw_device", "energy_from_cooling_device",
          "energy_from_dhw_device_to_dhw_storage", "energy_to_non_shiftable_load", "solar_generation")


@pytest.fixture(scope="module")
def runs(cache) -> tuple[CityLearnEnv, NativeEnv]:
    """The LSTM data set, central, random actions: the compat env and the native env replayed with them."""
    env = CityLearnEnv(LSTM, simulation_end_time_step=END)
    rng = np.random.default_rng(3)
    env.reset()
    actions = []
    while not env.terminated:
        space = env.action_space[0]
        a = rng.uniform(space.low, space.high)
        actions.append(a)
        env.step([a])
    native = native_env(LSTM, simulation_end_time_step=END)
    rewards, _ = replay(native, actions)
    np.testing.assert_array_equal([r[0] for r in env.rewards[1:]], rewards)
    return env, native


def test_building_series_equal_the_native_arrays(runs) -> None:
    env, native = runs
    series = native.series()
    for i, b in enumerate(env.buildings):
        assert isinstance(b, LSTMDynamicsBuilding) and b.name == native.building_names[i]
        for name in SERIES:
            np.testing.assert_array_equal(getattr(b, name), series[name][i], err_msg=name)
        np.testing.assert_array_equal(b.dhw_storage.soc, series["dhw_storage_soc"][i])
        np.testing.assert_array_equal(b.electrical_storage.soc, series["electrical_storage_soc"][i])
        np.testing.assert_array_equal(b.electrical_storage.capacity_history, series["electrical_storage_capacity"][i])
        np.testing.assert_array_equal(b.electrical_storage.efficiency_history, series["electrical_storage_efficiency"][i])
        np.testing.assert_array_equal(b.energy_simulation.indoor_dry_bulb_temperature_set_point,
                                      native.data("indoor_dry_bulb_temperature_set_point")[i])
        np.testing.assert_array_equal(b.pricing.electricity_pricing, native.data("electricity_pricing")[i])
        np.testing.assert_array_equal(b.carbon_intensity.carbon_intensity, native.data("carbon_intensity")[i])
        cop = b.cooling_device.get_cop(b.weather.outdoor_dry_bulb_temperature, heating=False)
        np.testing.assert_allclose(cop, series["cooling_device_cop"][i], rtol=1e-12)
        config = native.config.buildings[i]
        assert b.electrical_storage.capacity == config.electrical_storage.capacity
        assert b.cooling_device.nominal_power == config.cooling_device.nominal_power
        assert b.pv.nominal_power == config.pv_nominal_power
        assert b.observations(include_all=True)["net_electricity_consumption"] == b.net_electricity_consumption[-1]
    np.testing.assert_allclose(env.net_electricity_consumption, series["net_electricity_consumption"].sum(axis=0))


def test_an_upstream_time_series_table_builds(runs) -> None:
    """The SimBuild program's per-building table: upstream attributes of equal lengths at the episode end."""
    env, _ = runs
    frames = [pd.DataFrame({
        "bldg_name": b.name, "net_electricity_consumption": b.net_electricity_consumption,
        "indoor_dry_bulb_temperature_set_point": b.energy_simulation.indoor_dry_bulb_temperature_set_point,
        "cooling_cop": b.cooling_device.get_cop(b.weather.outdoor_dry_bulb_temperature, heating=False),
        "dhw_storage_soc": b.dhw_storage.soc, "power_outage": b.energy_simulation.power_outage,
        "pricing": b.pricing.electricity_pricing}) for b in env.buildings]
    assert len(pd.concat(frames)) == 3 * (END + 1)


def test_views_are_lazy_and_read_only(cache) -> None:
    env = CityLearnEnv(LSTM, simulation_end_time_step=END)
    b = env.buildings[1]
    assert set(vars(b)) == {"_env", "_index"}  # nothing cached: an unused view costs nothing per step
    env.reset()
    for _ in range(5):
        env.step([np.zeros(env.action_space[0].shape)])
    assert b.net_electricity_consumption.shape == (6,) and b.time_step == 5
    with pytest.raises(AttributeError, match="read only"):
        b.name = "x"
    with pytest.raises(ValueError, match="read-only"):
        b.net_electricity_consumption[0] = 1.0
    with pytest.raises(AttributeError, match="no attribute"):
        b.no_such_attribute  # noqa: B018


def test_ignore_dynamics_runs_the_data_set_temperatures(cache) -> None:
    env = CityLearnEnv(LSTM, simulation_end_time_step=END)
    for b in env.buildings:  # as the SimBuild program does for its storage-only runs
        b.ignore_dynamics = True
    assert all(b.ignore_dynamics for b in env.buildings) and not env.native.district.dynamics.any()
    env.reset()
    while not env.terminated:
        env.step([np.full(env.action_space[0].shape, 0.5)])
    b = env.buildings[0]
    np.testing.assert_array_equal(b.indoor_dry_bulb_temperature, b.energy_simulation.indoor_dry_bulb_temperature)
    config = native_env(LSTM, simulation_end_time_step=END).config
    config = config.replace(buildings=tuple(dataclasses.replace(x, cooling_model=None, heating_model=None)
                                            for x in config.buildings))
    native = NativeEnv(config, settings="citylearn-2.1")
    rewards, _ = replay(native, [np.full(native.action_space.shape, 0.5)] * END)
    np.testing.assert_array_equal([r[0] for r in env.rewards[1:]], rewards)


def test_baseline_agent_switches_every_action_off(cache) -> None:
    env = CityLearnEnv(LSTM, simulation_end_time_step=END)
    agent = BaselineAgent(env)
    assert env.action_space[0].shape == (0,) and agent.action_names == [[]]
    agent.learn(episodes=1)
    native = native_env(LSTM, simulation_end_time_step=END)
    native = NativeEnv(native.config.with_actions(()), settings="citylearn-2.1")
    replay(native, [np.zeros(0)] * END)
    pd.testing.assert_frame_equal(env.evaluate(), native.evaluate())
    district = env.evaluate().set_index(["name", "cost_function"])["value"]
    assert district["District", "cost_total"] == pytest.approx(1.0)
