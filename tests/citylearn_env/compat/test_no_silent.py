"""No silent difference (issue 49, items 3 and 4): the reward setter and a schema-named reward of the program's own
module take effect (doubling the user's reward doubles the result); None device actions meet the ideal load; episode
settings changed between episodes apply at the next reset; upstream's static DataSet calls, numpy scalars, device
methods and units."""

from __future__ import annotations

import logging
import sys
import types

import numpy as np
import pytest

from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.data import DataSet
from citylearn_env.compat.reward_function import MARL, RewardFunction
from citylearn_env.errors import SchemaError
from tests.citylearn_env.compat.conftest import LSTM, PHASE_1, UPSTREAM

END = 23

USER_MODULE = """
from citylearn_env.compat.reward_function import RewardFunction


class SignalReward(RewardFunction):
    def __init__(self, env_metadata, signal=None, exponent=1.0, **kwargs):
        super().__init__(env_metadata, **kwargs)
        self.signal, self.exponent = signal, exponent

    def calculate(self, observations):
        values = [-(max(o['net_electricity_consumption'], 0.0) * (o[self.signal] if self.signal else 1.0))
                  ** self.exponent * FACTOR for o in observations]
        return [sum(values)] if self.central_agent else values
"""


def user_module(name: str, factor: float) -> types.ModuleType:
    """A module of the running program (in sys.modules) defining ``SignalReward`` times ``factor``."""
    module = types.ModuleType(name)
    module.FACTOR = factor
    exec(compile(USER_MODULE, name, "exec"), module.__dict__)  # noqa: S102 - the test's own text
    return module


def rewards_of(env: CityLearnEnv, value: float = 0.2) -> np.ndarray:
    env.reset()
    n = len(env.action_space[0].low)
    out = []
    while not env.done:
        out.append(env.step([[value] * n])[1][0])
    return np.array(out)


def schema_with_reward(reward_type: str) -> dict:
    schema = DataSet.get_schema(PHASE_1)
    schema.update(central_agent=True, simulation_end_time_step=END,
                  reward_function={"type": reward_type, "attributes": {"signal": "electricity_pricing"}})
    return schema


def test_the_reward_setter_takes_effect(cache) -> None:
    plain = rewards_of(CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=END))

    class Doubled(RewardFunction):
        def calculate(self, observations):
            return [2.0 * v for v in super().calculate(observations)]

    env = CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=END)
    env.reward_function = Doubled(env.get_metadata())  # the tutorial's way, after construction
    assert type(env.reward_function) is Doubled
    np.testing.assert_allclose(rewards_of(env), 2.0 * plain, rtol=1e-12)
    env.reward_function = MARL(env.get_metadata())  # a built-in one runs natively, as if passed at construction
    marl = rewards_of(CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=END, reward_function=MARL))
    np.testing.assert_array_equal(rewards_of(env), marl)
    assert env.get_metadata()["reward_function"] == "MARL"


def test_a_schema_names_the_programs_own_reward_class(cache, monkeypatch) -> None:
    name = "simbuild_like_src.reward_function"
    monkeypatch.setitem(sys.modules, name, user_module(name, 1.0))
    once = rewards_of(CityLearnEnv(schema_with_reward(f"{name}.SignalReward")))
    monkeypatch.setitem(sys.modules, name, user_module(name, 2.0))  # the user doubles their reward
    env = CityLearnEnv(schema_with_reward(f"{name}.SignalReward"))
    assert type(env.reward_function).__module__ == name
    np.testing.assert_allclose(rewards_of(env), 2.0 * once, rtol=1e-12)
    assert np.all(once <= 0) and once.sum() < 0


def test_the_paper_names_get_the_users_class_when_loaded_and_a_notice_otherwise(cache, monkeypatch, caplog) -> None:
    copy = rewards_of(CityLearnEnv(schema_with_reward("src.reward_function.SignalReward")))
    monkeypatch.setitem(sys.modules, "src.reward_function", user_module("src.reward_function", 2.0))
    users = rewards_of(CityLearnEnv(schema_with_reward("src.reward_function.SignalReward")))
    np.testing.assert_allclose(users, 2.0 * copy, rtol=1e-6)  # the project's copy is float32 like upstream
    monkeypatch.delitem(sys.modules, "src.reward_function")
    with caplog.at_level(logging.WARNING, logger="citylearn_env.compat"):
        CityLearnEnv(schema_with_reward("src.reward_function.SignalReward"))
    assert any("not imported by the program" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("reward", ["some.string", "os.system", "builtins.object", "x" * 5000])
def test_unknown_reward_names_are_one_line_and_import_nothing(cache, reward) -> None:
    before = set(sys.modules)
    with pytest.raises(SchemaError, match="unknown reward function type") as error:
        CityLearnEnv(PHASE_1, simulation_end_time_step=END, reward_function=reward)
    with pytest.raises(SchemaError, match="unknown reward function type"):
        CityLearnEnv(schema_with_reward(reward))
    assert "\n" not in str(error.value) and len(str(error.value)) < 2000
    assert set(sys.modules) == before


def test_none_device_actions_meet_the_ideal_load(cache) -> None:
    env = CityLearnEnv(LSTM, central_agent=True, simulation_end_time_step=END)
    names = env.action_names[0]
    assert "cooling_device" in names
    ideal = CityLearnEnv(LSTM, central_agent=True, simulation_end_time_step=END,
                         inactive_actions=["cooling_device", "heating_device"])
    assert "cooling_device" not in ideal.action_names[0]
    env.reset()
    ideal.reset()
    for _ in range(END):
        with_none = env.step([[None if n.endswith("_device") else 0.3 for n in names]])
        inactive = ideal.step([[0.3] * len(ideal.action_names[0])])
        assert with_none[1] == inactive[1]
        assert with_none[0][0][:5] == inactive[0][0][:5]  # calendar and weather
    for b, c in zip(env.buildings, ideal.buildings, strict=True):
        np.testing.assert_array_equal(b.cooling_electricity_consumption, c.cooling_electricity_consumption)
        np.testing.assert_array_equal(b.indoor_dry_bulb_temperature, c.indoor_dry_bulb_temperature)
    assert env.buildings[0].cooling_electricity_consumption.sum() > 0


def test_episode_settings_apply_at_the_next_reset(cache) -> None:
    env = CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=47, episode_time_steps=24)
    env.reset()
    for _ in range(5):
        env.step([[0.0] * 5])
    env.episode_time_steps = np.int64(12)  # the paper's switch after training, here mid-episode
    assert env.time_steps == 24 and env.time_step == 5  # the current episode runs on
    while not env.done:
        env.step([[0.0] * 5])
    env.reset()
    # episode 1 of the new 12-step splits (0, 12, 24, 36), as upstream's sequential split: episode % 4
    assert env.time_steps == 12 and env.episode == 1 and env.episode_tracker.episode_start_time_step == 12
    env.rolling_episode_split = True
    assert env.rolling_episode_split


def test_static_dataset_calls_and_numpy_scalars(cache) -> None:
    assert PHASE_1 in DataSet.get_names() and DataSet.get_names() == DataSet().get_names()
    schema = DataSet.get_schema(PHASE_1)
    schema["simulation_end_time_step"] = np.int64(END)
    schema["central_agent"] = np.bool_(True)
    schema["buildings"]["Building_1"]["electrical_storage"]["attributes"]["capacity"] = np.float32(4.0)
    env = CityLearnEnv(schema)
    assert env.time_steps == END + 1 and env.central_agent
    assert env.buildings[0].electrical_storage.capacity == 4.0


def test_device_methods_and_units_are_upstreams(cache) -> None:
    env = CityLearnEnv(PHASE_1, central_agent=True, simulation_end_time_step=END)
    b = env.buildings[0]
    raw = np.genfromtxt(UPSTREAM / "v2.1.2" / PHASE_1 / "Building_1.csv", delimiter=",", skip_header=1)[:END + 1]
    np.testing.assert_allclose(b.energy_simulation.solar_generation, raw[:, -1].astype(np.float32))  # W/kW
    np.testing.assert_allclose(b.pv.get_generation(b.energy_simulation.solar_generation),
                               b.pv.nominal_power * raw[:, -1].astype(np.float32) / 1000.0)
    env.reset()
    env.step([[0.5] * 5])
    battery = b.electrical_storage
    assert battery.efficiency == battery.efficiency_history[-1] != battery.spec.efficiency  # current, not nominal
    assert battery.round_trip_efficiency == pytest.approx(np.sqrt(battery.efficiency))
    soc = battery.soc[-1]
    assert 0 < soc < 0.8 and battery.get_max_input_power() == pytest.approx(battery.nominal_power)  # flat curve
    assert battery.get_max_output_power() == battery.get_max_input_power()
    assert [s.shape for s in env.estimate_observation_space()] == [s.shape for s in env.observation_space]
