"""Rewards: CityLearn 2.1.2's reward functions on the golden traces (central and per building, t = 1..719),
the SimBuild and paper rewards against hand-computed values, and the registry."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from citylearn_env import rewards as R
from citylearn_env.actions import STORAGE_ACTIONS
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_1, CORRECTED
from tests.conftest import GOLDEN, need_shared

SCENARIOS = ("no_control", "storage_pv_random", "full_random", "full_random_outage")
#: trace / district.csv column suffix -> our spec (attributes as the golden driver built them)
GOLDEN_REWARDS = {
    "RewardFunction": "citylearn.reward_function.RewardFunction",
    "SolarPenaltyReward": "citylearn.reward_function.SolarPenaltyReward",
    "ComfortReward_default": {"type": "citylearn.reward_function.ComfortReward", "attributes": {}},
    "SolarPenaltyAndComfortReward_default": {"type": "citylearn.reward_function.SolarPenaltyAndComfortReward",
                                             "attributes": {"band": 2.0, "coefficients": [1.0, 1.0]}},
}


@pytest.fixture(scope="module")
def golden():
    """scenario -> dict(obs=per-t observation dicts, names, capacity, schema reward, trace, district)."""
    out = {}
    for scenario in SCENARIOS:
        folder = GOLDEN / scenario
        need_shared(folder / "observations_all.parquet", folder / "trace.parquet", folder / "district.csv")
        frame = pd.read_parquet(folder / "observations_all.parquet").sort_values(["building", "time_step"])
        names = list(dict.fromkeys(frame["building"]))
        steps = int(frame["time_step"].max()) + 1
        arrays = {c: frame[c].to_numpy(dtype=float).reshape(len(names), steps)
                  for c in frame.columns if c not in ("building", "time_step")}
        schema = json.loads((folder / "schema_used.json").read_text())
        capacity = {kind: np.array([((schema["buildings"][n].get(kind) or {}).get("attributes") or {})
                                    .get("capacity", 0.0) for n in names]) for kind in STORAGE_ACTIONS}
        trace = pd.read_parquet(folder / "trace.parquet").sort_values(["building", "time_step"])
        out[scenario] = {
            "obs": [{c: a[:, t] for c, a in arrays.items()} for t in range(steps)],
            "names": names, "capacity": capacity, "schema_reward": schema["reward_function"],
            "trace": trace, "district": pd.read_csv(folder / "district.csv"),
        }
    return out


def run(reward: R.Reward, observations) -> np.ndarray:
    """Reward values for t = 1..T-1 (CityLearn gives no reward at reset)."""
    return np.array([reward(obs)[0] for obs in observations[1:]])


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_citylearn_rewards_match_golden(golden, scenario):
    g = golden[scenario]
    specs = {**GOLDEN_REWARDS, "schema_ComfortReward": g["schema_reward"]}
    n, steps = len(g["names"]), len(g["obs"])
    for column, spec in specs.items():
        for central in (True, False):
            context = R.RewardContext(central_agent=central, building_names=g["names"], capacity=g["capacity"])
            ours = run(R.make_reward(spec, context, settings=CITYLEARN_2_1), g["obs"])
            if central:
                # district.csv prints 9 significant digits: allow that rounding on top of 1e-5
                reference = g["district"][f"reward_{column}"].to_numpy()[1:]
                np.testing.assert_allclose(ours, reference, rtol=1e-8, atol=1e-5, err_msg=column)
            else:
                reference = g["trace"][f"reward_{column}_building"].to_numpy().reshape(n, steps)[:, 1:].T
                np.testing.assert_allclose(ours, reference, rtol=0, atol=1e-5, err_msg=column)
    # the env's own reward is the schema reward, central
    np.testing.assert_allclose(g["district"]["reward_env"].to_numpy()[1:],
                               g["district"]["reward_schema_ComfortReward"].to_numpy()[1:], rtol=0, atol=0)


def test_corrected_comfort_differs_only_by_float32_rounding(golden):
    g = golden["full_random"]
    context = R.RewardContext(central_agent=False, building_names=g["names"], capacity=g["capacity"])
    fixed = run(R.make_reward("comfort", context), g["obs"][:200])
    upstream = run(R.make_reward("comfort", context, settings=CITYLEARN_2_1), g["obs"][:200])
    np.testing.assert_allclose(fixed, upstream, rtol=1e-6)


# ---------------------------------------------------------------------------------------- hand-made inputs
def ctx(central: bool, n: int = 2, **kwargs) -> R.RewardContext:
    return R.RewardContext(central_agent=central, building_names=[f"B{i}" for i in range(n)], **kwargs)


def obs(**values) -> dict[str, np.ndarray]:
    return {k: np.asarray(v, dtype=float) for k, v in values.items()}


def call(spec, central, observation, **kwargs):
    return R.make_reward(spec, ctx(central, **kwargs))(observation)[0]


def test_default_marl_and_independent_sac():
    o = obs(net_electricity_consumption=[2.0, -1.0])
    assert list(call("default", False, o)) == [-2.0, 0.0]
    assert call("default", True, o) == -1.0  # district net 1 kWh, not a sum of per-building rewards
    # MARL: sign(-e) * 0.01 * e^2 * max(0, 1)
    np.testing.assert_allclose(call("marl", False, o), [-0.04, 0.01])
    assert call("marl", True, o) == pytest.approx(-0.03)
    assert list(call("independent_sac", False, o)) == [-8.0, 0.0]
    assert list(R.make_reward("independent_sac", ctx(False), settings=CITYLEARN_2_1)(o)[0]) == [-2.0, 0.0]


def test_solar_penalty_by_hand():
    o = obs(net_electricity_consumption=[2.0, -1.0], dhw_storage_soc=[0.5, 0.5],
            electrical_storage_soc=[0.25, 0.0], cooling_storage_soc=[0.9, 0.9])
    capacity = {"dhw_storage": np.array([2.0, 0.0]), "electrical_storage": np.array([4.0, 4.0])}
    value, terms = R.make_reward("solar_penalty", ctx(False, capacity=capacity))(o)
    # B0: dhw -(1 + .5) * 2 + battery -(1 + .25) * 2 ; B1: battery only, -(1 - 0) * 1 ; cooling absent
    np.testing.assert_allclose(value, [-5.5, -1.0])
    assert list(terms["cooling_storage"]) == [0.0, 0.0]


def test_comfort_reward_bands_and_modes():
    temperature = [20.0, 21.0, 22.0, 24.0, 25.0, 26.0]  # set point 23, band 2: 21 and 25 are the band edges
    cooling = obs(indoor_dry_bulb_temperature=temperature, indoor_dry_bulb_temperature_set_point=[23.0] * 6,
                  cooling_demand=[1.0] * 6, heating_demand=[0.0] * 6, net_electricity_consumption=[0.0] * 6)
    np.testing.assert_allclose(call("comfort", False, cooling, n=6), [-27.0, -2.0, -1.0, 0.0, 0.0, -9.0])
    heating = {**cooling, "cooling_demand": np.zeros(6), "heating_demand": np.ones(6)}
    np.testing.assert_allclose(call("comfort", False, heating, n=6), [-9.0, 0.0, 0.0, -1.0, -2.0, -27.0])
    combined = R.make_reward({"type": "solar_penalty_and_comfort", "attributes": {"coefficients": [0.0, 2.0]}},
                             ctx(True, n=6))
    assert combined(cooling)[0] == pytest.approx(2 * -39.0)


def test_signal_rewards_by_hand():
    o = obs(net_electricity_consumption=[2.0, -1.0], electricity_pricing=[0.1, 0.3], carbon_intensity=[0.5, 0.4])
    np.testing.assert_allclose(call("cost", False, o), [-0.2, 0.0])
    np.testing.assert_allclose(call("emissions", False, o), [-1.0, 0.0])
    assert call({"type": "src.reward_function.SignalReward",
                 "attributes": {"signal": "electricity_pricing", "exponent": 2.0}}, True, o) == pytest.approx(-0.04)
    assert call("signal", True, o) == -2.0  # no signal: grid import


def test_storage_signal_reward_by_hand_and_upstream_quirk():
    capacity = {"dhw_storage": np.array([2.0, 2.0]), "electrical_storage": np.array([4.0, 4.0])}
    steps = [obs(net_electricity_consumption=[1.0, -1.0], electricity_pricing=[0.1, 0.1],
                 dhw_storage_soc=[0.5, 0.5], electrical_storage_soc=[0.25, 0.0]),
             obs(net_electricity_consumption=[1.0, 1.0], electricity_pricing=[0.1, 0.1],
                 dhw_storage_soc=[0.25, 0.5], electrical_storage_soc=[0.25, 0.0])]
    spec = {"type": "src.reward_function.StorageSignalReward",
            "attributes": {"signal": "electricity_pricing", "exponent": 1.0}}
    for settings, second in ((CORRECTED, [0.05, 0.0]), (CITYLEARN_2_1, [0.025, 0.0])):
        reward = R.make_reward(spec, ctx(False, capacity=capacity), settings=settings)
        # step 1: B0 stores .5 * 2 + .25 * 4 = 2 kWh while importing -> -(2 * .1); B1 exports -> 0
        np.testing.assert_allclose(reward(steps[0])[0], [-0.2, 0.0])
        # step 2: B0 releases .5 kWh while importing -> +.05 (CityLearn 2.1: -(.05) * (-.5) = +.025); B1 unchanged
        np.testing.assert_allclose(reward(steps[1])[0], second)


def test_storage_cost_reduction_reward_by_hand():
    active = {"dhw_storage": np.array([True, True]), "electrical_storage": np.array([True, False])}
    reward = R.make_reward("storage_cost_reduction", ctx(True, active_actions=active))
    base = dict(dhw_storage_soc=[0.4, 0.2], electrical_storage_soc=[0.5, 0.5], net_electricity_consumption=[1, 1],
                dhw_storage_electricity_consumption=[0.0, 0.5], dhw_electricity_consumption=[0.0, 1.0],
                electrical_storage_electricity_consumption=[-1.0, -1.0])
    reward(obs(electricity_pricing=[0.2, 0.2], **base))
    # prices seen {0.2, 0.3}: rank i = 1, n = 2. B0: idle dhw -(1 - .4) * (2 - 1), discharging battery +1;
    # B1: dhw charging while the heater uses more -> -1; battery action inactive
    value, terms = reward(obs(electricity_pricing=[0.3, 0.3], **base))
    np.testing.assert_allclose(terms["dhw_storage"], [-0.6, -1.0])
    np.testing.assert_allclose(terms["electrical_storage"], [1.0, 0.0])
    assert value == pytest.approx(-0.6)


def test_set_point_and_discomfort_consumption_rewards():
    o = obs(indoor_dry_bulb_temperature=[24.0, 21.0], indoor_dry_bulb_temperature_set_point=[23.0, 23.0])
    assert list(call("src.reward_function.ComfortReward", False, o)) == [-1.0, -2.0]
    assert call("setpoint_deviation", True, o) == -1.5  # central: mean
    np.testing.assert_allclose(call("discomfort_consumption", False, o), [-1.0, -6.0])
    spec = {"type": "src.reward_function.ComfortandConsumptionReductionReward", "attributes": {"multiplier": 12}}
    assert call(spec, True, o) == pytest.approx((-1.0 - 24.0) / 2)


def test_peak_rewards_by_hand():
    series = [[2.0, 1.0], [1.0, 3.0], [-1.0, 0.5]]
    reward = R.make_reward("peak_reduction", ctx(False))
    got = [list(reward(obs(net_electricity_consumption=e))[0]) for e in series]
    assert got == [[0.0, 0.0], [1.0, 0.0], [2.0, 2.5]]
    central = R.make_reward("src.reward_function.PeakReductionReward", ctx(True))
    assert [central(obs(net_electricity_consumption=e))[0] for e in series] == [0.0, 0.0, 3.5]
    central.reset(ctx(True))
    assert central(obs(net_electricity_consumption=[0.0, 1.0]))[0] == 0.0
    o = obs(net_electricity_consumption=[2.0, -3.0])
    assert call("average_daily_peak", True, o) == 0.0  # the district exports
    assert call({"type": "average_daily_peak", "attributes": {"aggregate": "buildings"}}, True, o) == -2.0
    assert list(call("average_daily_peak", False, o)) == [-2.0, 0.0]


# ---------------------------------------------------------------------------------------- registry
def test_every_registered_reward_builds_and_has_the_right_shape(golden):
    g = golden["full_random"]
    o = g["obs"][100]
    active = {k: np.ones(6, bool) for k in ("dhw_storage", "electrical_storage", "cooling_device")}
    for name in R.REWARDS:
        for central in (True, False):
            context = R.RewardContext(central_agent=central, building_names=g["names"], capacity=g["capacity"],
                                      initial_soc={}, active_actions=active)
            value, terms = R.make_reward(name, context)(o)
            assert isinstance(value, float) if central else np.shape(value) == (6,), name
            assert terms and all(np.shape(v) == (6,) for v in terms.values()), name


def test_unknown_type_and_bad_attributes():
    with pytest.raises(SchemaError, match=r"unknown reward.*citylearn\.reward_function\.RewardFunction.*cost"):
        R.make_reward({"type": "os.system", "attributes": {}}, ctx(True))
    with pytest.raises(SchemaError, match="band"):
        R.make_reward({"type": "citylearn.reward_function.RewardFunction", "attributes": {"band": 1}}, ctx(True))
    with pytest.raises(SchemaError, match="coefficients"):
        R.make_reward({"type": "solar_penalty_and_comfort", "attributes": {"coefficients": [1, 2, 3]}}, ctx(True))
    with pytest.raises(RuntimeError, match="reset"):
        R.RewardFunction()(obs(net_electricity_consumption=[1.0]))
