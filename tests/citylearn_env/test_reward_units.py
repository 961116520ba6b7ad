"""Every reward class on three buildings, per building and central, against values worked out by hand.

Needs nothing outside the repository. Units: net consumption e kWh per step, prices $/kWh, carbon kg/kWh,
temperatures degC, state of charge 0..1, capacities kWh.
"""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env import rewards as R
from citylearn_env.errors import SchemaError

NAMES = ("a", "b", "c")
#: the common observation: a imports 2 kWh, b exports 1 kWh, c imports .5 kWh
E = [2.0, -1.0, 0.5]


def context(central: bool, **kwargs) -> R.RewardContext:
    return R.RewardContext(central_agent=central, building_names=NAMES, **kwargs)


def obs(**values) -> dict[str, np.ndarray]:
    return {k: np.asarray(v, dtype=float) for k, v in values.items()}


def both(spec, observation, **kwargs):
    """(per-building values, central value, per-building terms) of a fresh reward of ``spec``."""
    per_building, terms = R.make_reward(spec, context(False, **kwargs))(observation)
    central, _ = R.make_reward(spec, context(True, **kwargs))(observation)
    return np.asarray(per_building), central, terms


# ------------------------------------------------------------------------------------ CityLearn 2.1 rewards
def test_reward_function():
    values, central, terms = both("citylearn.reward_function.RewardFunction", obs(net_electricity_consumption=E))
    np.testing.assert_allclose(values, [-2.0, 0.0, -0.5])
    assert central == pytest.approx(-(2.0 - 1.0 + 0.5))  # -max(district net 1.5, 0)
    np.testing.assert_allclose(terms["grid_import"], [-2.0, 0.0, -0.5])
    # the central reward is on the district net: 2 - 3 + .5 = -.5 kWh exported -> 0, not the building sum -2.5
    _, central, _ = both("default", obs(net_electricity_consumption=[2.0, -3.0, 0.5]))
    assert central == 0.0


def test_marl():
    values, central, _ = both("marl", obs(net_electricity_consumption=E))
    # sign(-e) * 0.01 * e^2 * max(0, district 1.5)
    expected = [-1 * 0.01 * 4 * 1.5, +1 * 0.01 * 1 * 1.5, -1 * 0.01 * 0.25 * 1.5]
    np.testing.assert_allclose(values, expected)
    assert central == pytest.approx(-0.06 + 0.015 - 0.00375)


def test_independent_sac_reward():
    values, central, _ = both("independent_sac", obs(net_electricity_consumption=E))
    np.testing.assert_allclose(values, [-(2.0 ** 3), 0.0, -(0.5 ** 3)])
    assert central == pytest.approx(-8.125)


STORAGE_OBS = dict(net_electricity_consumption=E, electrical_storage_soc=[0.25, 0.5, 0.9],
                   dhw_storage_soc=[0.5, 0.3, 1.0], cooling_storage_soc=[0.7, 0.7, 0.7])
STORAGE_CAPACITY = {"electrical_storage": np.array([4.0, 4.0, 0.0]), "dhw_storage": np.array([2.0, 0.0, 2.0])}


def test_solar_penalty_reward():
    values, central, terms = both("solar_penalty", obs(**STORAGE_OBS), capacity=STORAGE_CAPACITY)
    # -(1 + sign(e) * soc) * |e| per present storage (capacity > 0); no cooling storage anywhere
    a = -(1 + 0.25) * 2 - (1 + 0.5) * 2   # battery + dhw
    b = -(1 - 0.5) * 1                     # battery only; exporting: sign -1
    c = -(1 + 1.0) * 0.5                   # dhw only
    np.testing.assert_allclose(values, [a, b, c])
    assert [a, b, c] == [-5.5, -0.5, -1.0]
    assert central == pytest.approx(-7.0)
    np.testing.assert_allclose(terms["cooling_storage"], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(terms["dhw_storage"], [-3.0, 0.0, -1.0])


COMFORT_OBS = dict(net_electricity_consumption=E, indoor_dry_bulb_temperature=[20.0, 19.5, 26.0],
                   indoor_dry_bulb_temperature_set_point=[23.0, 23.0, 23.0],
                   cooling_demand=[1.0, 0.0, 1.0], heating_demand=[0.0, 1.0, 0.0])


def test_comfort_reward_defaults():
    values, central, _ = both("comfort", obs(**COMFORT_OBS))
    # band 2, exponents 2 (lower) and 3 (higher): a cooling and 3 below the set point -> -(3^3);
    # b heating, 3.5 below -> -(3.5^2); c cooling, 3 above -> -(3^2)
    np.testing.assert_allclose(values, [-27.0, -12.25, -9.0])
    assert central == pytest.approx(-48.25)


def test_comfort_reward_attributes_and_inner_band():
    spec = {"type": "citylearn.reward_function.ComfortReward",
            "attributes": {"band": 1.0, "lower_exponent": 1.0, "higher_exponent": 2.0}}
    values, central, _ = both(spec, obs(**COMFORT_OBS))
    np.testing.assert_allclose(values, [-(3.0 ** 2), -(3.5 ** 1), -(3.0 ** 1)])
    assert central == pytest.approx(-15.5)
    # within the band: cooling pays below the set point only, heating above it only
    inner = obs(**{**COMFORT_OBS, "indoor_dry_bulb_temperature": [22.5, 23.5, 23.5]})
    values, _, _ = both("comfort", inner)
    np.testing.assert_allclose(values, [-0.5, -0.5, 0.0])


def test_solar_penalty_and_comfort_reward():
    spec = {"type": "solar_penalty_and_comfort", "attributes": {"coefficients": [0.5, 2.0]}}
    observation = obs(**STORAGE_OBS, **{k: v for k, v in COMFORT_OBS.items() if k != "net_electricity_consumption"})
    values, central, terms = both(spec, observation, capacity=STORAGE_CAPACITY)
    solar, comfort = np.array([-5.5, -0.5, -1.0]), np.array([-27.0, -12.25, -9.0])
    np.testing.assert_allclose(values, 0.5 * solar + 2.0 * comfort)
    np.testing.assert_allclose(values, [-56.75, -24.75, -18.5])
    assert central == pytest.approx(0.5 * -7.0 + 2.0 * -48.25)
    np.testing.assert_allclose(terms["comfort"], 2.0 * comfort)


# ------------------------------------------------------------------------------------ SimBuild 2024 rewards
SIGNAL_OBS = dict(net_electricity_consumption=E, electricity_pricing=[0.1, 0.2, 0.4],
                  carbon_intensity=[0.5, 0.4, 0.2])


def test_signal_reward():
    spec = {"type": "src.reward_function.SignalReward",
            "attributes": {"signal": "electricity_pricing", "exponent": 2.0, "window": 24}}
    values, central, _ = both(spec, obs(**SIGNAL_OBS))
    # -(max(e, 0) * price)^2: (2 * .1)^2, 0, (.5 * .4)^2
    np.testing.assert_allclose(values, [-0.04, 0.0, -0.04])
    assert central == pytest.approx(-0.08)
    values, central, _ = both("signal", obs(**SIGNAL_OBS))  # no signal, exponent 1: grid import
    np.testing.assert_allclose(values, [-2.0, 0.0, -0.5])
    assert central == pytest.approx(-2.5)


def test_cost_and_emissions_rewards():
    values, central, _ = both("cost", obs(**SIGNAL_OBS))
    np.testing.assert_allclose(values, [-2.0 * 0.1, 0.0, -0.5 * 0.4])
    assert central == pytest.approx(-0.4)
    values, central, _ = both("emissions", obs(**SIGNAL_OBS))
    np.testing.assert_allclose(values, [-2.0 * 0.5, 0.0, -0.5 * 0.2])
    assert central == pytest.approx(-1.1)


def test_storage_signal_reward_over_two_steps():
    capacity = {"dhw_storage": np.array([2.0, 2.0, 0.0]), "electrical_storage": np.array([4.0, 0.0, 4.0])}
    initial = {"dhw_storage": np.array([0.5, 0.5, 0.0]), "electrical_storage": np.array([0.25, 0.0, 0.5])}
    spec = {"type": "storage_signal", "attributes": {"signal": "electricity_pricing", "exponent": 1.0}}
    first = obs(net_electricity_consumption=[1.0, 2.0, 1.0], electricity_pricing=[0.1, 0.1, 0.2],
                dhw_storage_soc=[0.75, 0.5, 0.0], electrical_storage_soc=[0.25, 0.0, 0.25])
    second = obs(net_electricity_consumption=[-1.0, 1.0, 1.0], electricity_pricing=[0.1, 0.1, 0.2],
                 dhw_storage_soc=[0.25, 1.0, 0.0], electrical_storage_soc=[0.25, 0.0, 0.25])
    for central in (False, True):
        reward = R.make_reward(spec, context(central, capacity=capacity, initial_soc=initial))
        value, terms = reward(first)
        # stored D: a .25 * 2 = .5 kWh; b 0; c -.25 * 4 = -1 kWh. r = -(|D| * price) * sign(D) while importing
        np.testing.assert_allclose(terms["stored_energy"], [0.5, 0.0, -1.0])
        expected = [-(0.5 * 0.1), 0.0, -(1.0 * 0.2) * -1.0]
        if central:
            assert value == pytest.approx(sum(expected))
        else:
            np.testing.assert_allclose(value, expected)
        value, terms = reward(second)
        # D against the first step: a -.5 * 2 = -1 (but exporting -> 0); b .5 * 2 = 1; c 0
        np.testing.assert_allclose(terms["stored_energy"], [-1.0, 1.0, 0.0])
        expected = [0.0, -(1.0 * 0.1), 0.0]
        if central:
            assert value == pytest.approx(-0.1)
        else:
            np.testing.assert_allclose(value, expected)


def test_storage_cost_reduction_reward_over_two_steps():
    active = {"dhw_storage": np.array([True, True, False]), "electrical_storage": np.array([True, False, True])}
    common = dict(net_electricity_consumption=[1.0, 1.0, 1.0], dhw_storage_soc=[0.4, 0.2, 0.9],
                  electrical_storage_soc=[0.5, 0.5, 0.25], dhw_electricity_consumption=[0.0, 1.0, 0.0])
    first = obs(**common, electricity_pricing=[0.2, 0.2, 0.2], dhw_storage_electricity_consumption=[0.0, 0.5, 0.3],
                electrical_storage_electricity_consumption=[-1.0, 0.0, 0.0])
    second = obs(**common, electricity_pricing=[0.3, 0.3, 0.3],
                 dhw_storage_electricity_consumption=[0.0, 0.5, 0.0],
                 electrical_storage_electricity_consumption=[-1.0, 0.0, 0.5])
    for central in (False, True):
        reward = R.make_reward("storage_cost_reduction", context(central, active_actions=active))
        # step 1: prices seen [.2], rank i = 0, n = 1.
        # a: dhw idle -(1 - .4) * (1 - 0), battery discharging +0; b: dhw charging below its device's use -0;
        # c: dhw inactive, battery idle -(1 - .25) * (1 - 0)
        expected = [-0.6 + 0.0, -0.0, -0.75]
        value, _ = reward(first)
        if central:
            assert value == pytest.approx(sum(expected))
        else:
            np.testing.assert_allclose(value, expected)
        # step 2: prices seen [.2, .3], i = 1, n = 2.
        # a: dhw idle -(.6) * (2 - 1), battery discharging +1; b: dhw charging on the device -1;
        # c: battery charging (not a thermal storage) 0
        expected = [-0.6 + 1.0, -1.0, 0.0]
        value, terms = reward(second)
        if central:
            assert value == pytest.approx(-0.6)
        else:
            np.testing.assert_allclose(value, expected)
            np.testing.assert_allclose(terms["electrical_storage"], [1.0, 0.0, 0.0])


TEMPERATURE_OBS = dict(net_electricity_consumption=E, indoor_dry_bulb_temperature=[24.0, 21.5, 23.0],
                       indoor_dry_bulb_temperature_set_point=[23.0, 23.0, 23.0])


def test_set_point_deviation_reward_central_is_a_mean():
    values, central, _ = both("src.reward_function.ComfortReward", obs(**TEMPERATURE_OBS))
    np.testing.assert_allclose(values, [-1.0, -1.5, 0.0])
    assert central == pytest.approx((-1.0 - 1.5 + 0.0) / 3)


def test_comfort_and_consumption_reduction_reward():
    spec = {"type": "src.reward_function.ComfortandConsumptionReductionReward", "attributes": {"multiplier": 3.0}}
    values, central, terms = both(spec, obs(**TEMPERATURE_OBS))
    # T - S = 1, -1.5, 0: over-cooling (b) costs 3 x its deviation
    np.testing.assert_allclose(values, [-1.0, -4.5, 0.0])
    assert central == pytest.approx((-1.0 - 4.5 + 0.0) / 3)
    np.testing.assert_allclose(terms["over_cooling"], [0.0, -4.5, 0.0])
    np.testing.assert_allclose(terms["under_cooling"], [-1.0, 0.0, 0.0])


def test_peak_reduction_reward_tracks_the_running_peak():
    steps = [obs(net_electricity_consumption=e) for e in ([2.0, -1.0, 0.5], [1.0, 3.0, 0.5], [0.0, 1.0, -2.0])]
    per_building = R.make_reward("peak_reduction", context(False))
    # grid import [2, 0, .5] -> peak the same -> 0; then [1, 3, .5] -> peak [2, 3, .5]; then [0, 1, 0]
    expected = ([0.0, 0.0, 0.0], [2.0 - 1.0, 0.0, 0.0], [2.0 - 0.0, 3.0 - 1.0, 0.5 - 0.0])
    for step, want in zip(steps, expected, strict=True):
        np.testing.assert_allclose(per_building(step)[0], want)
    central = R.make_reward("src.reward_function.PeakReductionReward", context(True))
    # district import 2.5, 4.5, 1 -> peaks 2.5, 4.5, 4.5
    assert [central(step)[0] for step in steps] == pytest.approx([0.0, 0.0, 4.5 - 1.0])
    central.reset(context(True))  # a new episode forgets the peak
    assert central(steps[2])[0] == 0.0


def test_average_daily_peak_reward_aggregations():
    values, central, _ = both("average_daily_peak", obs(net_electricity_consumption=E))
    np.testing.assert_allclose(values, [-2.0, 0.0, -0.5])
    assert central == pytest.approx(-1.5)  # district net 1.5 kWh
    spec = {"type": "average_daily_peak", "attributes": {"aggregate": "buildings"}}
    _, central, _ = both(spec, obs(net_electricity_consumption=E))
    assert central == pytest.approx(-2.5)  # sum of the building imports
    with pytest.raises(SchemaError, match="aggregate"):
        R.make_reward({"type": "average_daily_peak", "attributes": {"aggregate": "month"}}, context(True))


# ------------------------------------------------------------------------------------ registry
def test_make_reward_refuses_unknown_types_and_attributes():
    with pytest.raises(SchemaError, match="unknown reward function type"):
        R.make_reward("no_such_reward", context(True))
    with pytest.raises(SchemaError, match="does not take attributes"):
        R.make_reward({"type": "marl", "attributes": {"band": 1.0}}, context(True))
    with pytest.raises(SchemaError, match="settings"):
        R.make_reward({"type": "comfort", "attributes": {"settings": "citylearn-2.1"}}, context(True))
    with pytest.raises(TypeError, match="Behaviour"):
        R.IndependentSACReward(settings="citylearn-2.1")


def test_every_registered_reward_builds_and_returns_terms():
    observation = obs(**{**STORAGE_OBS, **SIGNAL_OBS, **COMFORT_OBS})
    for name in R.REWARDS:
        for central in (False, True):
            value, terms = R.make_reward(name, context(central, capacity=STORAGE_CAPACITY))(observation)
            assert isinstance(value, float) if central else np.shape(value) == (3,), name
            assert all(np.shape(v) == (3,) for v in terms.values()), name
