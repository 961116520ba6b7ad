"""One test per field of :class:`citylearn_env.settings.Behaviour`: flip that field alone from CORRECTED to its
CITYLEARN_2_1 value and check the hand-predicted effect at the function that reads it.

``test_every_field_has_a_test`` fails when a field is added without a ``test_<field>`` function here.
Needs nothing outside the repository (small inputs are made in the tests or written to ``tmp_path``).
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from citylearn_env import kpis
from citylearn_env import rewards as R
from citylearn_env.dataset import DynamicsBlock
from citylearn_env.devices import Curve, interpolate_curve
from citylearn_env.dynamics import LSTMBank, LSTMSpec
from citylearn_env.errors import SchemaError
from citylearn_env.outages import reliability_outage_signal
from citylearn_env.schema import load_schema
from citylearn_env.settings import (
    CITYLEARN_2_1,
    CITYLEARN_2_5,
    CORRECTED,
    ONLY_BEFORE_2_1_2,
    ONLY_IN_2_5,
    PRESETS,
    Behaviour,
    resolve,
)
from tests.citylearn_env.test_kpi_units import HAND_A, hand_series


def flipped(field: str) -> Behaviour:
    """CORRECTED with ``field`` alone set to its CityLearn 2.1 value (2.5 value for the 2.5-only quirks)."""
    preset = CITYLEARN_2_5 if field in ONLY_IN_2_5 else CITYLEARN_2_1
    return replace(CORRECTED, **{field: getattr(preset, field)})


# ------------------------------------------------------------------------------------------ the presets
@pytest.mark.parametrize("field", Behaviour.field_names())
def test_every_field_has_a_test(field):
    assert callable(globals().get(f"test_{field}")), f"Behaviour.{field} has no test_{field} in {__name__}"


@pytest.mark.parametrize("field", Behaviour.field_names())
def test_every_field_differs_between_the_presets(field):
    if field in ONLY_BEFORE_2_1_2:  # a CityLearn 2.1.0 quirk that 2.1.2 no longer has
        assert getattr(CORRECTED, field) == getattr(CITYLEARN_2_1, field)
        return
    if field in ONLY_IN_2_5:  # a CityLearn 2.5 quirk: 2.1 behaves as corrected
        assert getattr(CORRECTED, field) == getattr(CITYLEARN_2_1, field)
        assert getattr(CORRECTED, field) != getattr(CITYLEARN_2_5, field)
    else:
        assert getattr(CORRECTED, field) != getattr(CITYLEARN_2_1, field)
    assert flipped(field) != CORRECTED and replace(flipped(field), **{field: getattr(CORRECTED, field)}) == CORRECTED


def test_resolve():
    assert resolve() is CORRECTED and resolve(None, True) is CITYLEARN_2_1
    assert resolve("citylearn-2.1") is CITYLEARN_2_1 and resolve("corrected") is CORRECTED
    custom = flipped("lstm_float32")
    assert resolve(custom, True) is custom  # an explicit object wins over the shorthand
    assert set(PRESETS) == {"corrected", "citylearn-2.1", "citylearn-2.5"}
    assert resolve("citylearn-2.5") is CITYLEARN_2_5 and CITYLEARN_2_5.legacy_outage_draws
    with pytest.raises(SchemaError, match="unknown behaviour preset"):
        resolve("citylearn-2.2")
    with pytest.raises(TypeError):
        resolve(8.0)


# ------------------------------------------------------------------------------------------ data sets
def _district_without_hvac_mode(tmp_path) -> str:
    """A one-building, 24-step schema in tmp_path whose building file has no hvac_mode column."""
    for name, frame in (("building.csv", pd.DataFrame({
            "month": [6] * 24, "hour": list(range(1, 25)), "day_type": [3] * 24,
            "indoor_dry_bulb_temperature": [24.0] * 24, "non_shiftable_load": [1.0] * 24,
            "dhw_demand": [0.0] * 24, "cooling_demand": [2.0] * 24, "heating_demand": [0.0] * 24,
            "solar_generation": [0.0] * 24}).assign(daylight_savings_status=0,
                                                    average_unmet_cooling_setpoint_difference=0.0,
                                                    indoor_relative_humidity=50.0)),
                        ("weather.csv", pd.DataFrame({c: [20.0] * 24 for c in (
                            "outdoor_dry_bulb_temperature", "outdoor_relative_humidity",
                            "diffuse_solar_irradiance", "direct_solar_irradiance",
                            *(f"{base}_predicted_{h}" for base in (
                                "outdoor_dry_bulb_temperature", "outdoor_relative_humidity",
                                "diffuse_solar_irradiance", "direct_solar_irradiance")
                              for h in ("6h", "12h", "24h")))}))):
        frame.to_csv(tmp_path / name, index=False)
    schema = {
        "root_directory": str(tmp_path), "central_agent": True,
        "simulation_start_time_step": 0, "simulation_end_time_step": 23, "seconds_per_time_step": 3600,
        "observations": {"hour": {"active": True, "shared_in_central_agent": True}},
        "actions": {},
        "buildings": {"B": {"include": True, "energy_simulation": "building.csv", "weather": "weather.csv"}},
    }
    path = tmp_path / "schema.json"
    path.write_text(json.dumps(schema))
    return str(path)


def test_missing_hvac_mode_is_off(tmp_path):
    path = _district_without_hvac_mode(tmp_path)
    corrected = load_schema(path).buildings[0].series["hvac_mode"]
    old = load_schema(path, settings=replace(CORRECTED, missing_hvac_mode_is_off=True)).buildings[0].series["hvac_mode"]
    np.testing.assert_array_equal(corrected, np.ones(24))  # 1 = cooling, as documented
    np.testing.assert_array_equal(old, np.zeros(24))  # 0 = off, as CityLearn 2.1.0 read it
    # CityLearn 2.1.2 (the 2.1 preset) fills ones as well: its EnergySimulation defaults the column to 1
    np.testing.assert_array_equal(load_schema(path, settings="citylearn-2.1").buildings[0].series["hvac_mode"], np.ones(24))


# ------------------------------------------------------------------------------------------ devices
def test_battery_curve_extrapolates_first_segment():
    # one curve (0, 1) - (1, .5) - (2, .5): segment 0 has slope -.5
    curve = Curve.from_points([[(0.0, 1.0), (1.0, 0.5), (2.0, 0.5)]])
    field = flipped("battery_curve_extrapolates_first_segment").battery_curve_extrapolates_first_segment
    x = np.array([3.0])
    # beyond the last point: held at .5, or segment 0 continued: 1 + (3 - 0) * -.5 = -.5
    assert interpolate_curve(x, curve, extrapolate_first_segment=CORRECTED.battery_curve_extrapolates_first_segment)[0] \
        == 0.5
    assert interpolate_curve(x, curve, extrapolate_first_segment=field)[0] == pytest.approx(-0.5)
    # inside the curve both agree: x = 1.5 on the flat segment
    for flag in (False, True):
        assert interpolate_curve(np.array([1.5]), curve, extrapolate_first_segment=flag)[0] == pytest.approx(0.5)


# ------------------------------------------------------------------------------------------ LSTM bank
S30 = 1.0 / (1.0 + math.exp(-30.0))  # an input/output gate biased fully open


def tiny_spec() -> LSTMSpec:
    """One hidden unit, one layer, lookback 1; inputs (temperature [10, 30] degC, day_type_sin [-1, 1]).

    Only the cell gate g sees an input (day_type_sin, weight 1); the input and output gates have bias 30,
    the forget gate acts on a zero cell. From a zero state: c = S30 * tanh(x), h = S30 * tanh(c), y = h
    (head weight 1, bias 0), with x the normalised day_type_sin = (sin(2 pi d / P) + 1) / 2.
    """
    w_ih = np.zeros((4, 2))
    w_ih[2, 1] = 1.0
    state = {"l_lstm.weight_ih_l0": w_ih, "l_lstm.weight_hh_l0": np.zeros((4, 1)),
             "l_lstm.bias_ih_l0": np.array([30.0, 0.0, 0.0, 30.0]), "l_lstm.bias_hh_l0": np.zeros(4),
             "l_linear.weight": np.ones((1, 1)), "l_linear.bias": np.zeros(1)}
    block = DynamicsBlock("tiny.pth", input_observation_names=("indoor_dry_bulb_temperature", "day_type_sin"),
                          input_normalization_minimum=(10.0, -1.0), input_normalization_maximum=(30.0, 1.0),
                          hidden_size=1, num_layers=1, lookback=1)
    return LSTMSpec(state, block)


def predict(settings: Behaviour, day_type: float = 7.0) -> float:
    """The tiny bank's prediction at its second step (the first fills the buffer)."""
    bank = LSTMBank([tiny_spec()], settings=settings, backend="numpy")
    inputs = {"indoor_dry_bulb_temperature": np.array([23.0]), "day_type": np.array([day_type])}
    assert math.isnan(bank.step(inputs, np.array([1.0]))[0])
    return float(bank.step(inputs, np.array([1.0]))[0])


def hand_y(x: float) -> float:
    return S30 * math.tanh(S30 * math.tanh(x))


def test_lstm_day_type_period():
    # Sunday (7): period 7 -> sin(2 pi) = 0 -> x = .5; period 8 -> sin(7 pi / 4) = -sqrt(2)/2
    x7, x8 = (0.0 + 1) / 2, (-math.sqrt(2) / 2 + 1) / 2
    assert predict(CORRECTED) == pytest.approx(10 + 20 * hand_y(x7), abs=1e-12)
    assert predict(flipped("lstm_day_type_period")) == pytest.approx(10 + 20 * hand_y(x8), abs=1e-12)
    # 18.64 vs 12.89 degC
    assert predict(CORRECTED) - predict(flipped("lstm_day_type_period")) > 5.0


def test_lstm_output_uses_last_input_bounds():
    y = hand_y(0.5)
    # de-normalised with the temperature's bounds 10 + 20 y, or the last input's (day_type_sin) -1 + 2 y
    assert predict(CORRECTED) == pytest.approx(10 + 20 * y, abs=1e-12)
    assert predict(flipped("lstm_output_uses_last_input_bounds")) == pytest.approx(-1 + 2 * y, abs=1e-12)


def test_lstm_float32():
    x = (math.sin(2 * math.pi * 7 / 7) + 1) / 2
    x32 = float(np.float32(x))  # the window input rounded to float32, then the output arithmetic in float32
    expected = float(np.float32(np.float32(hand_y(x32)) * np.float32(20.0) + np.float32(10.0)))
    ours = predict(flipped("lstm_float32"))
    assert ours == pytest.approx(expected, abs=2e-6)
    assert ours == float(np.float32(ours))  # a float32 value
    corrected = predict(CORRECTED)
    assert corrected != ours and abs(corrected - ours) < 1e-5


# ------------------------------------------------------------------------------------------ outages
def test_legacy_outage_draws():
    # an outage every day (saifi 365), starting at midnight, lasting ~100 h on average: 3 hourly days
    kwargs = dict(saifi=365.0, caidi=6000.0, seed=11, start_time_steps=[0])
    corrected = reliability_outage_signal(72, **kwargs, legacy=CORRECTED.legacy_outage_draws)
    legacy = reliability_outage_signal(72, **kwargs, legacy=flipped("legacy_outage_draws").legacy_outage_draws)
    assert corrected[0] == 1  # day 0 is eligible
    assert not legacy[:24].any() and legacy[24] == 1  # CityLearn 2.1 never starts an outage on day 0
    # a trailing partial day: fine corrected, refused by the 2.1 generator
    assert reliability_outage_signal(30, **kwargs).shape == (30,)
    with pytest.raises(SchemaError, match="whole number of days"):
        reliability_outage_signal(30, **kwargs, legacy=True)


# ------------------------------------------------------------------------------------------ rewards
def test_independent_sac_reward_precedence_bug():
    observation = {"net_electricity_consumption": np.array([2.0])}
    context = R.RewardContext(central_agent=False, building_names=["a"])
    assert R.make_reward("independent_sac", context)(observation)[0][0] == -(2.0 ** 3)
    bug = R.make_reward("independent_sac", context, settings=flipped("independent_sac_reward_precedence_bug"))
    assert bug(observation)[0][0] == -2.0


def test_comfort_reward_float32():
    # cooling at 22.9 degC, set point 23, band 2: inside the band below the set point -> -(S - T)
    observation = {"net_electricity_consumption": np.array([0.0]), "cooling_demand": np.array([1.0]),
                   "indoor_dry_bulb_temperature": np.array([22.9]),
                   "indoor_dry_bulb_temperature_set_point": np.array([23.0])}
    context = R.RewardContext(central_agent=False, building_names=["a"])
    assert R.make_reward("comfort", context)(observation)[0][0] == -(23.0 - 22.9)
    upstream = R.make_reward("comfort", context, settings=flipped("comfort_reward_float32"))(observation)[0][0]
    assert upstream == -(23.0 - float(np.float32(22.9)))  # float32(22.9) = 22.899999618530273
    assert upstream == pytest.approx(-0.100000381, abs=1e-9)
    # the combined reward rounds each (central) part to float32: 2 x float32(-0.1000000000000014)
    combined = {"type": "solar_penalty_and_comfort", "attributes": {"coefficients": [1.0, 2.0]}}
    central = R.RewardContext(central_agent=True, building_names=["a"])
    part = -(23.0 - 22.9)
    assert R.make_reward(combined, central)(observation)[0] == 2 * part
    assert R.make_reward(combined, central, settings=replace(CORRECTED, comfort_reward_float32=True))(
        observation)[0] == 2 * float(np.float32(-(23.0 - float(np.float32(22.9)))))


def test_storage_signal_reward_multiplies_by_delta():
    # a battery of 4 kWh goes from soc .5 to .375 (D = -.5 kWh) while importing at .1 $/kWh
    context = R.RewardContext(central_agent=False, building_names=["a"],
                              capacity={"electrical_storage": np.array([4.0])},
                              initial_soc={"electrical_storage": np.array([0.5])})
    observation = {"net_electricity_consumption": np.array([1.0]), "electricity_pricing": np.array([0.1]),
                   "electrical_storage_soc": np.array([0.375])}
    spec = {"type": "storage_signal", "attributes": {"signal": "electricity_pricing"}}
    # -(|D| * s) * sign(D) = -(.05) * -1; the quirk multiplies by D: -(.05) * -.5
    assert R.make_reward(spec, context)(observation)[0][0] == pytest.approx(0.05)
    quirk = R.make_reward(spec, context, settings=flipped("storage_signal_reward_multiplies_by_delta"))
    assert quirk(observation)[0][0] == pytest.approx(0.025)


def _one_charger(connected: bool, gap: float) -> R.RewardContext:
    """One building, one 7.4 kW charger asked for 1 kWh; when ``connected`` a 40 kWh EV leaving now (0 h) at
    SOC 0.5 + ``gap`` for a required 0.5. Zero net consumption: no self-consumption terms; MARL is 0."""
    step = R.ChargerStep(
        building=np.array([0]), connected=np.array([connected]), action_energy=np.array([1.0]),
        previous_soc=np.array([0.5]), soc=np.array([0.5 + gap]), capacity=np.array([40.0]),
        min_capacity=np.array([4.0]), required_soc=np.array([0.5]), hours_until_departure=np.array([0.0]),
        max_charging_power=np.array([7.4]), max_discharging_power=np.array([7.4]))
    return R.RewardContext(central_agent=False, building_names=["a"], chargers=lambda: step)


def test_ev_reward_skips_unplugged_chargers():
    # no EV plugged in, 1 kWh > 0.1 asked: no_car_charging (-5) x 1 / (1 + 0); upstream never scores it
    observation, context = {"net_electricity_consumption": np.array([0.0])}, _one_charger(False, 0.0)
    assert R.make_reward("electric_vehicles", context)(observation)[0][0] == -5.0
    quirk = R.make_reward("electric_vehicles", context, settings=flipped("ev_reward_skips_unplugged_chargers"))
    assert quirk(observation)[0][0] == 0.0


def test_ev_reward_squares_soc_under_weight():
    # leaving 0.3 below the required SOC (12 kWh, none movable at 0 h): soc_under only, -5 x |-5| corrected,
    # (-5) ** 2 = +25 upstream
    observation, context = {"net_electricity_consumption": np.array([0.0])}, _one_charger(True, -0.3)
    assert R.make_reward("electric_vehicles", context)(observation)[0][0] == -25.0
    quirk = R.make_reward("electric_vehicles", context, settings=flipped("ev_reward_squares_soc_under_weight"))
    assert quirk(observation)[0][0] == 25.0


# ------------------------------------------------------------------------------------------ KPIs
def test_kpi_plain_division():
    # a flat baseline: no ramping and no load-factor loss to compare against
    series = {"net_electricity_consumption": np.array([[1.0, 3.0, 1.0, 3.0]]),
              "net_electricity_consumption_without_storage_and_partial_load": np.full((1, 4), 2.0)}
    corrected = kpis.district_kpis(series, dynamics=[True])
    plain = kpis.district_kpis(series, dynamics=[True], settings=flipped("kpi_plain_division"))
    # ramping 6 / 0 and 1-LF (1 - 2/3) / (1 - 2/2): NaN corrected, +inf plain
    assert math.isnan(corrected["ramping_average"]) and plain["ramping_average"] == math.inf
    assert math.isnan(corrected["daily_one_minus_load_factor_average"])
    assert plain["daily_one_minus_load_factor_average"] == math.inf
    # the peaks divide fine either way: 3 / 2
    assert corrected["daily_peak_average"] == plain["daily_peak_average"] == 1.5


def test_kpi_discomfort_over_all_steps():
    names = ["a", "b"]
    corrected = kpis.building_kpis(hand_series(), names, dynamics=[True, False])
    upstream = kpis.building_kpis(hand_series(), names, dynamics=[True, False],
                                  settings=flipped("kpi_discomfort_over_all_steps"))
    # a: six +3 degC deltas over its 24 occupied steps, or over all 48 steps
    assert corrected[0]["discomfort_delta_average"] == pytest.approx(HAND_A["discomfort_delta_average"])
    assert corrected[0]["discomfort_delta_average"] == pytest.approx(18 / 24)
    assert upstream[0]["discomfort_delta_average"] == pytest.approx(18 / 48)
    assert upstream[0]["discomfort_proportion"] == corrected[0]["discomfort_proportion"] == pytest.approx(6 / 24)


def test_kpi_discomfort_against_one_set_point():
    series = hand_series()
    # b: heating 21, cooling 25; its one set point 23 (cooling mode) as in hand_series
    series["indoor_dry_bulb_temperature_heating_set_point"] = np.full_like(series["occupant_count"], 21.0)
    series["indoor_dry_bulb_temperature_cooling_set_point"] = np.full_like(series["occupant_count"], 25.0)
    corrected = kpis.building_kpis(series, ["a", "b"], dynamics=[True, False])
    upstream = kpis.building_kpis(series, ["a", "b"], dynamics=[True, False],
                                  settings=flipped("kpi_discomfort_against_one_set_point"))
    # b at 20 degC for 12 of 48 occupied steps: 3 below 23 (cold beyond the 2 degC band), 1 below 21 (not)
    assert upstream[1]["discomfort_too_cold_proportion"] == pytest.approx(12 / 48)
    assert corrected[1]["discomfort_too_cold_proportion"] == 0.0
    # a at 26 degC on 6 steps: 3 above 23 (hot), 1 above 25 (inside the band); at 23 inside [21, 25]: delta 0
    assert upstream[0]["discomfort_too_hot_proportion"] == pytest.approx(6 / 24)
    assert corrected[0]["discomfort_too_hot_proportion"] == 0.0
    assert corrected[0]["discomfort_delta_average"] == pytest.approx(6 * 1 / 24)
    # the paper's discomfort objective: b's 12 steps 1 degC below 21 and 36 steps inside the band; a's 6 steps
    # 1 degC above 25. Against 23: 12 x 3 + 36 x 1 and 6 x 3
    assert kpis.objectives(series)["discomfort"] == pytest.approx(12 + 6)
    assert kpis.objectives(series, one_set_point=True)["discomfort"] == pytest.approx(36 + 36 + 18)


def test_kpi_baseline_from_first_building():
    series = hand_series()
    for kind in ("", "_cost", "_emission"):  # the without-storage baseline: twice the partial-load one
        series[f"net_electricity_consumption{kind}_without_storage"] = \
            2 * series[f"net_electricity_consumption{kind}_without_storage_and_partial_load"]
    upstream_settings = flipped("kpi_baseline_from_first_building")
    corrected = kpis.building_kpis(series, ["a", "b"], dynamics=[True, False])
    upstream = kpis.building_kpis(series, ["a", "b"], dynamics=[True, False], settings=upstream_settings)
    # b has no dynamics: its own baseline (without storage) imports 2 x 96 = 192 kWh; a's condition: 96
    assert corrected[1]["electricity_consumption_total"] == pytest.approx(48 / 192)
    assert upstream[1]["electricity_consumption_total"] == pytest.approx(48 / 96)
    # district: the partial-load baseline (ramping 4 per step) unless the first building has no dynamics,
    # in which case CityLearn 2.1 takes the without-storage one (ramping 8 per step); control ramps 1
    assert kpis.district_kpis(series, dynamics=[False, True])["ramping_average"] == pytest.approx(1 / 4)
    assert kpis.district_kpis(series, dynamics=[False, True], settings=upstream_settings)["ramping_average"] \
        == pytest.approx(1 / 8)


def test_kpi_float32_score():
    score = (0.10 * 0.65 + 0.30 * 0.25 + 0.075 * (0.25 + 13 / 24 + 6 / 13 + 6 / 13) + 0.15 * 1.0 + 0.15 * 0.75)
    corrected = kpis.evaluate_challenge(hand_series(), ["a", "b"], dynamics=[True, False])
    upstream = kpis.evaluate_challenge(hand_series(), ["a", "b"], dynamics=[True, False],
                                       settings=flipped("kpi_float32_score"))
    ours = corrected.set_index("kpi")["value"]["average_score"]
    single = upstream.set_index("kpi")["value"]["average_score"]
    assert ours == pytest.approx(score, rel=1e-14)
    assert single == float(np.float32(single)) and single != ours  # a float32 sum ...
    assert single == pytest.approx(score, rel=1e-6)  # ... within float32 round-off
    # the KPI rows themselves are the same
    pd.testing.assert_series_equal(corrected["value"][:-1], upstream["value"][:-1])


# ------------------------------------------------------------------------------------------ environment
def _example(tmp_path, **schema_changes) -> str:
    from citylearn_env.example import write_example_district

    path = write_example_district(tmp_path, n_buildings=2, hours=48)
    schema = json.loads(path.read_text())
    schema.update(schema_changes)
    path.write_text(json.dumps(schema))
    return str(path)


def test_wrapper_day_type_period(tmp_path):
    from citylearn_env import CityLearnEnv
    from citylearn_env.wrappers import NormalizedObservationWrapper

    path = _example(tmp_path)
    values = {}
    for settings in (CORRECTED, flipped("wrapper_day_type_period")):
        wrapper = NormalizedObservationWrapper(CityLearnEnv(path, settings=settings))
        observation, _ = wrapper.reset(seed=0)
        raw = wrapper.unwrapped.observation_names.index("day_type")
        env = wrapper.unwrapped
        day = float(env.flat_observations()[env.layout.central_index][raw])
        names = wrapper.observation_names
        values[settings.wrapper_day_type_period] = (day, observation[names.index("day_type_cos")],
                                                    observation[names.index("day_type_sin")])
    for period, (day, cos, sin) in values.items():
        # (cos, sin) of 2 pi d / P scaled from [-1, 1] to [0, 1]
        assert cos == pytest.approx((math.cos(2 * math.pi * day / period) + 1) / 2, abs=1e-6)
        assert sin == pytest.approx((math.sin(2 * math.pi * day / period) + 1) / 2, abs=1e-6)
    assert values[7.0][1] != pytest.approx(values[8.0][1], abs=1e-3)


def test_legacy_random_episode_split(tmp_path):
    from citylearn_env import CityLearnEnv

    # 48 steps in four 12-step splits starting at 0, 12, 24, 36
    path = _example(tmp_path, episode_time_steps=12, random_episode_split=True, random_seed=5)
    legacy = CityLearnEnv(path, settings=flipped("legacy_random_episode_split"))
    starts = []
    for episode in range(12):
        legacy.reset()
        starts.append(legacy.episode_start)
        # CityLearn 2.1: RandomState(seed * (episode + 1)) chooses among all splits but the last
        assert legacy.episode_start == 12 * int(np.random.RandomState(5 * (episode + 1)).choice(3))
    assert 36 not in starts
    corrected = CityLearnEnv(path, settings=CORRECTED)
    corrected.reset(seed=0)
    seen = {corrected.episode_start}
    for _ in range(40):
        corrected.reset()
        seen.add(corrected.episode_start)
    assert seen == {0, 12, 24, 36}  # the env's seeded generator reaches the last split too


# ------------------------------------------------------------------------------------------ CityLearn 2.5
#: one charger's rows (state, EV, departure time, required SOC %, arrival time, arrival SOC %); rows 6..23 away
ARRIVING = [(3, "", "", "", "", ""), (2, "EV", "", "", 1, 40), (1, "EV", 3, 80, "", ""), (1, "EV", 2, 80, "", ""),
            (1, "EV", 1, 80, "", ""), (3, "", "", "", "", "")]
#: an arrival without an announcing state-2 row: away, away, then plugged in (required SOC 80 %)
UNANNOUNCED = [(3, "", "", "", "", ""), (3, "", "", "", "", ""), (1, "EV", 3, 80, "", ""), (1, "EV", 2, 80, "", "")]


def _ev_district(tmp_path, rows=ARRIVING, battery: dict | None = None, **top) -> str:
    """The 24-step one-building district of :func:`_district_without_hvac_mode` with one 10 kW charger
    (efficiency 1) serving one EV (50 kWh, 50 kW, initial SOC 0.5) on ``rows``, and optionally a battery."""
    path = _district_without_hvac_mode(tmp_path)
    rows = [*rows, *[(3, "", "", "", "", "")] * (24 - len(rows))]
    pd.DataFrame(rows, columns=["electric_vehicle_charger_state", "electric_vehicle_id",
                                "electric_vehicle_departure_time", "electric_vehicle_required_soc_departure",
                                "electric_vehicle_estimated_arrival_time", "electric_vehicle_estimated_soc_arrival"]
                 ).to_csv(tmp_path / "charger.csv", index=False)
    schema = json.loads(open(path).read())
    schema.update(random_seed=2022, **top)
    schema["actions"] = {"electric_vehicle_storage": {"active": True}}
    schema["electric_vehicles_def"] = {"EV": {"include": True, "battery": {"attributes": {
        "capacity": 50, "nominal_power": 50, "initial_soc": 0.5, "depth_of_discharge": 0.9}}}}
    schema["buildings"]["B"]["chargers"] = {"C": {"charger_simulation": "charger.csv", "attributes": {
        "max_charging_power": 10, "max_discharging_power": 10, "efficiency": 1.0}}}
    if battery is not None:
        schema["actions"] = {"electrical_storage": {"active": True}, **schema["actions"]}
        schema["buildings"]["B"]["electrical_storage"] = {"type": "citylearn.energy_model.Battery",
                                                           "attributes": battery}
    open(path, "w").write(json.dumps(schema))
    return path


def _ev_soc(path: str, settings: Behaviour, actions, seed: int = 0) -> np.ndarray:
    """The EV's SOC over the steps after ``len(actions)`` step calls (action = the charger's, then others)."""
    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(path, settings=settings)
    env.reset(seed=seed)
    for a in actions:
        env.step(np.atleast_1d(np.asarray(a, dtype=float)))
    return env.district.ev_record.soc[0, : len(actions) + 1]


def test_ev_unwritten_soc_is_zero(tmp_path):
    from citylearn_env.ev import upstream_uniform

    path = _ev_district(tmp_path)
    loss = 0.001 + 0.008 * upstream_uniform(2022)  # the EV's drawn standby loss per step
    # the EV arrives at step 2 with the arrival SOC announced in row 1 (40 %) and every action is 0
    corrected = _ev_soc(path, CORRECTED, [0.0] * 3)
    assert corrected[2] == pytest.approx(0.4 * (1 - loss)) and corrected[3] == pytest.approx(0.4 * (1 - loss) ** 2)
    upstream = _ev_soc(path, flipped("ev_unwritten_soc_is_zero"), [0.0] * 3)
    assert upstream[2] == pytest.approx(0.4) and upstream[3] == 0.0  # forced at arrival, then never written


def test_ev_step_starts_from_previous_soc(tmp_path):
    from citylearn_env.ev import upstream_uniform

    path = _ev_district(tmp_path, rows=UNANNOUNCED)
    u = upstream_uniform(2022)
    loss = 0.001 + 0.008 * u
    # a 0.01 action asks 0.1 kWh of the EV plugged in at step 2; at x = 0.1 / 50 kW the drawn efficiency curve
    # runs from e (0.85 + 0.05 u) at 0 to e (0.90 + 0.05 u) at 0.25 + 0.1 u (e = 0.90 + 0.08 u), and sqrt of it
    # reaches the battery. The EV came without an announced arrival SOC: the connection rule sets 0.8 (the
    # required SOC); the step starts there (corrected) or from the SOC of step 1, still the initial 0.5 (2.5)
    e = 0.90 + 0.08 * u
    efficiency = e * (0.85 + 0.05 * u) + e * 0.05 * (0.1 / 50.0) / (0.25 + 0.1 * u)
    stored = 0.1 * math.sqrt(efficiency) / 50.0
    corrected = _ev_soc(path, CORRECTED, [0.0, 0.01])
    upstream = _ev_soc(path, flipped("ev_step_starts_from_previous_soc"), [0.0, 0.01])
    assert corrected[2] == pytest.approx(0.8 * (1 - loss) + stored, abs=1e-9)
    assert upstream[2] == pytest.approx(0.5 * (1 - loss) + stored, abs=1e-9)


def test_ev_data_from_range_start(tmp_path):
    from citylearn_env import CityLearnEnv

    path = _ev_district(tmp_path, episode_time_steps=[[0, 2], [3, 5]])
    states = {}
    for settings in (CORRECTED, flipped("ev_data_from_range_start")):
        env = CityLearnEnv(path, settings=settings)
        env.reset(seed=0)
        env.reset()  # the second episode: rows 3..5
        states[settings.ev_data_from_range_start] = env.district.ev_data.state[0].tolist()
    assert states[False] == [1, 1, 3]  # rows 3, 4, 5
    assert states[True] == [3, 2, 1]  # rows 0, 1, 2 again (CityLearn 2.5 does not re-window)


def test_legacy_ev_drift_draws(tmp_path):
    path = _ev_district(tmp_path, rows=UNANNOUNCED[:1] * 3)  # away at steps 0..2: the SOC drifts at step 1
    # SOC(1) = SOC(0) * clip(draw, 0.6, 1.4) with SOC(0) = 0.5; the draw from the env's generator (gymnasium's
    # np_random(7) is numpy's default_rng(7)) or from RandomState(7) (CityLearn 2.5's global numpy seeded 7)
    corrected = _ev_soc(path, CORRECTED, [0.0], seed=7)
    legacy = _ev_soc(path, flipped("legacy_ev_drift_draws"), [0.0], seed=7)
    assert corrected[1] == pytest.approx(0.5 * np.clip(np.random.default_rng(7).normal(1.0, 0.2), 0.6, 1.4))
    assert legacy[1] == pytest.approx(0.5 * np.clip(np.random.RandomState(7).normal(1.0, 0.2), 0.6, 1.4))


#: a 60 kWh / 50 kW lossless battery with a linear efficiency curve (0.8 at 0, 1.0 at full power)
BATTERY = {"capacity": 60.0, "nominal_power": 50.0, "efficiency": 0.9, "loss_coefficient": 0.0,
           "capacity_loss_coefficient": 0.0, "depth_of_discharge": 1.0,
           "power_efficiency_curve": [[0.0, 0.8], [1.0, 1.0]], "capacity_power_curve": [[0.0, 1.0], [1.0, 1.0]]}


def _battery_step(path: str, settings: Behaviour, action: float) -> tuple[float, float, float]:
    """(energy balance [kWh], efficiency, upper action bound) of the battery's first step under ``action``."""
    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(path, settings=settings)
    env.reset(seed=0)
    env.step(np.array([action, 0.0]))  # electrical_storage, then the charger
    r = env.district.battery_record
    return float(r.energy_balance[0, 1]), float(r.efficiency[0, 1]), float(env.action_space.high[0])


def test_battery_efficiency_from_request(tmp_path):
    path = _ev_district(tmp_path, battery={**BATTERY, "initial_soc": 0.95})
    # asked for 10/60 of capacity = 10 kWh, held to the 3 kWh still free: the efficiency is read at 3/50 = 0.06
    # (0.8 + 0.2 * 0.06 = 0.812) or at the request, min(10, 50)/50 = 0.2 (0.84, CityLearn 2.5)
    balance, efficiency, _ = _battery_step(path, CORRECTED, 10 / 60)
    assert balance == pytest.approx(3.0) and efficiency == pytest.approx(0.812)
    _, efficiency, _ = _battery_step(path, flipped("battery_efficiency_from_request"), 10 / 60)
    assert efficiency == pytest.approx(0.84)


def test_battery_action_fraction_of_nominal_power(tmp_path):
    path = _ev_district(tmp_path, battery={**BATTERY, "initial_soc": 0.0})
    # action 0.5 of an empty battery: 0.5 x 60 kWh capacity = 30 kWh (bound 50/60), or 0.5 x 50 kW x 1 h = 25 kWh
    balance, _, high = _battery_step(path, CORRECTED, 0.5)
    assert balance == pytest.approx(30.0) and high == pytest.approx(50 / 60)
    balance, _, high = _battery_step(path, flipped("battery_action_fraction_of_nominal_power"), 0.5)
    assert balance == pytest.approx(25.0) and high == 1.0


def test_battery_autosize_from_placeholder_pv(tmp_path):
    from citylearn_env import pv_battery_autosize as pvb
    from citylearn_env.example import write_example_district

    path = write_example_district(tmp_path, n_buildings=1, hours=48, seed=5)
    raw = json.loads(path.read_text())
    raw["buildings"]["Building_1"]["electrical_storage"].update(
        autosize=True, autosize_attributes={"duration": 2.0, "safety_factor": 1.0})
    path.write_text(json.dumps(raw))
    b = load_schema(path).buildings[0]
    peak = pvb.baseline_consumption(b.series, b.cooling_device, b.heating_device, b.dhw_device).reshape(-1, 24)
    # corrected: CityLearn 2.2+'s rule (mean daily peak consumption for 2 h); 2.1: the zero-size PV's peak, 0
    assert b.electrical_storage.capacity == pytest.approx(peak.max(axis=1).mean() * 2.0)
    assert b.electrical_storage.capacity > 0
    old = load_schema(path, settings=flipped("battery_autosize_from_placeholder_pv")).buildings[0]
    assert old.electrical_storage.capacity == 0.0


def test_battery_defaults_drawn(tmp_path):
    from citylearn_env.config import DEFAULT_CAPACITY_POWER_CURVE, DEFAULT_POWER_EFFICIENCY_CURVE

    path = _ev_district(tmp_path, battery={"capacity": 6.4, "nominal_power": 5.0, "efficiency": 0.9})
    fixed = load_schema(path).buildings[0].electrical_storage
    assert fixed.power_efficiency_curve == DEFAULT_POWER_EFFICIENCY_CURVE and fixed.loss_coefficient == 0.006
    assert fixed.capacity_power_curve == DEFAULT_CAPACITY_POWER_CURVE
    drawn = load_schema(path, settings=flipped("battery_defaults_drawn")).buildings[0].electrical_storage
    # CityLearn 2.5 draws within its ranges (one number u per device): loss 0.001..0.009, curves around the
    # given efficiency 0.9 (kept): efficiency 0.9 at the fourth point, 0.85..0.9 of it at zero power
    assert drawn.efficiency == 0.9 and 0.001 <= drawn.loss_coefficient <= 0.009
    u = (drawn.loss_coefficient - 0.001) / 0.008
    assert drawn.power_efficiency_curve[3] == pytest.approx((0.75 + 0.1 * u, 0.9))
    assert drawn.power_efficiency_curve[0] == pytest.approx((0.0, 0.9 * (0.85 + 0.05 * u)))
    assert drawn.capacity_power_curve[-1] == pytest.approx((1.0, 0.2 + 0.1 * u))


# ------------------------------------------------------------------------------------------ CityLearn 2.5 dynamics
def _example_edited(tmp_path, edit=None, hours: int = 48) -> str:
    """The one-building example district (dhw_storage and electrical_storage actions), edited by ``edit(raw)``."""
    from citylearn_env.example import write_example_district

    path = write_example_district(tmp_path, n_buildings=1, hours=hours, seed=3)
    raw = json.loads(path.read_text())
    if edit is not None:
        edit(raw)
    path.write_text(json.dumps(raw))
    return str(path)


def test_thermal_device_defaults_drawn(tmp_path):
    from citylearn_env.ev import upstream_device_seed, upstream_uniform

    def edit(raw):
        raw["random_seed"] = 7
        b = raw["buildings"]["Building_1"]
        b["dhw_storage"]["attributes"].pop("loss_coefficient")
        b["cooling_device"]["attributes"] = {"nominal_power": 2.0}

    path = _example_edited(tmp_path, edit)
    fixed = load_schema(path).buildings[0]
    assert fixed.dhw_storage.efficiency == 1.0 and fixed.dhw_storage.loss_coefficient == 0.006
    assert (fixed.cooling_device.efficiency, fixed.cooling_device.target_cooling_temperature) == (0.2, 8.0)
    drawn = load_schema(path, settings=flipped("thermal_device_defaults_drawn")).buildings[0]
    # one number u per device from its upstream seed: low + (high - low) u for each left-out attribute
    u_tank, u_pump = (upstream_uniform(upstream_device_seed("Building_1", "citylearn.building.Building", slot,
                                                            f"citylearn.energy_model.{cls}", 7))
                      for slot, cls in (("dhw_storage", "StorageTank"), ("cooling_device", "HeatPump")))
    assert drawn.dhw_storage.efficiency == 0.9 + (0.98 - 0.9) * u_tank
    assert drawn.dhw_storage.loss_coefficient == 0.001 + (0.009 - 0.001) * u_tank
    assert drawn.cooling_device.efficiency == 0.2 + (0.3 - 0.2) * u_pump
    assert drawn.cooling_device.target_cooling_temperature == 7.0 + (10.0 - 7.0) * u_pump
    assert drawn.cooling_device.target_heating_temperature == 45.0 + (50.0 - 45.0) * u_pump
    assert drawn.cooling_device.nominal_power == 2.0 and drawn.dhw_device == fixed.dhw_device  # given: kept


def _first_call(path: str, settings: Behaviour, action: np.ndarray):
    """The env after reset and one step call with ``action``."""
    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(path, settings=settings)
    env.reset(seed=0)
    env.step(action)
    return env


def test_storage_action_scaled_by_other_tank(tmp_path):
    path = _example_edited(tmp_path)
    action = np.array([0.5, 0.0])  # dhw_storage, electrical_storage
    own = _first_call(path, CORRECTED, action).district.end_use("dhw").record.storage_soc[0, 1]
    other = _first_call(path, flipped("storage_action_scaled_by_other_tank"), action)
    # half the DHW tank's capacity charges it; CityLearn 2.5 scales by the (absent, 0 kWh) heating tank
    assert own > 0.3 and other.district.end_use("dhw").record.storage_soc[0, 1] == 0.0


def test_thermal_storage_bounds_from_device_power(tmp_path):
    from citylearn_env import CityLearnEnv

    def edit(raw):
        raw["buildings"]["Building_1"]["dhw_storage"]["attributes"]["capacity"] = 4.0

    path = _example_edited(tmp_path, edit)
    building = load_schema(path).buildings[0]
    peak, power = building.series["dhw_demand"].max(), building.dhw_device.nominal_power
    # +-peak DHW demand / capacity (2.1), or +-heater power [kW] / capacity (2.5)
    assert CityLearnEnv(path).action_space.high[0] == pytest.approx(peak / 4.0)
    assert CityLearnEnv(path, settings=flipped("thermal_storage_bounds_from_device_power")).action_space.high[0] \
        == pytest.approx(power / 4.0)
    assert abs(power - peak) > 0.05


def test_act_then_advance(tmp_path):
    from citylearn_env import CityLearnEnv

    path = _example_edited(tmp_path)
    charge = np.array([0.0, 0.5])  # the battery charges
    for settings, acted in ((CORRECTED, 1), (flipped("act_then_advance"), 0)):
        env = _first_call(path, settings, charge)
        soc, net = env.district.battery_record.soc[0], env.district.building_record.net_electricity_consumption[0]
        assert env.t == 1 and soc[acted] > soc[1 - acted]  # 2.1: rows 0 (initial) then 1; 2.5: row 0 charged
        assert np.isfinite(env.rewards[acted]) and np.isnan(env.rewards[1 - acted])
    # 2.5: the observation is row 1 before control (battery SOC 0, net 0, as 2.5.0 shows it) and row T - 1 is
    # never acted on
    env = CityLearnEnv(path, settings=flipped("act_then_advance"))
    obs, _ = env.reset(seed=0)
    names = env.observation_names
    obs, *_ = env.step(charge)
    net = env.district.building_record.net_electricity_consumption[0]
    assert obs[names.index("Building_1.electrical_storage_soc")] == 0.0 == net[1]
    for _ in range(env.episode_length - 2):
        env.step(charge)
    assert env.t == env.episode_length - 1 and net[-1] == 0.0 and net[-2] != 0.0


def test_first_step_booked_three_times(tmp_path):
    path = _example_edited(tmp_path)
    base = replace(CORRECTED, act_then_advance=True)  # row 0 is acted on only with CityLearn 2.5's timing
    zeros = np.zeros(2)
    once = _first_call(path, base, zeros).district
    thrice = _first_call(path, replace(base, first_step_booked_three_times=True), zeros).district
    # no storage use: devices and the non-shiftable load booked at reset, at the call and at the update
    row = once.episode
    loads = row["non_shiftable_load"][0, 0] + row["cooling_demand"][0, 0] / once.end_use("cooling").cop[0, 0] \
        + row["dhw_demand"][0, 0] / 0.9
    net_once = once.building_record.net_electricity_consumption[0, 0]
    assert net_once == pytest.approx(loads - row.pv_generation[0, 0])
    assert thrice.building_record.net_electricity_consumption[0, 0] == pytest.approx(net_once + 2 * loads)
    assert thrice.building_record.net_electricity_consumption[0, 1] == 0.0  # row 1 not acted on yet
    # without act_then_advance row 0 is never acted on: the field alone changes nothing
    assert _first_call(path, flipped("first_step_booked_three_times"), zeros).district.building_record \
        .net_electricity_consumption[0, 0] == pytest.approx(net_once)


def _mode_switch_district(tmp_path, heating_load: float = 0.0) -> str:
    """The tiny-LSTM district of test_upstream_later (lookback 2, one v2.2 ``dynamics`` model, combined action)
    with hvac_mode switching between cooling (1) and heating (2) every 6 hours; heating rows carry
    ``heating_load`` kWh of ideal heating load."""
    from tests.citylearn_env.test_upstream_later import lstm_district

    path = lstm_district(tmp_path, hvac_mode=1.0)
    csv = tmp_path / "Building_1.csv"
    frame = pd.read_csv(csv)
    mode = np.where((np.arange(len(frame)) // 6) % 2 == 0, 1.0, 2.0)
    frame["hvac_mode"] = mode
    frame["heating_demand"] = np.where(mode == 2, heating_load, 0.0)
    frame["cooling_demand"] = np.where(mode == 1, frame["cooling_demand"], 0.0)
    frame.to_csv(csv, index=False)
    return str(path)


def _zero_episode(path: str, settings: Behaviour):
    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(path, settings=settings)
    env.reset(seed=0)
    for _ in range(env.episode_length - 1):
        env.step(np.zeros(env.action_space.shape))
    return env


def test_lstm_one_model_across_modes(tmp_path):
    from types import SimpleNamespace

    from citylearn_env.dynamics import separate_heating_model

    block = DynamicsBlock("m.pth", input_observation_names=("indoor_dry_bulb_temperature",),
                          input_normalization_minimum=(10.0,), input_normalization_maximum=(30.0,),
                          hidden_size=1, num_layers=1, lookback=1)
    single = SimpleNamespace(cooling_model=block, heating_model=block)  # how a v2.2 schema's model loads
    pair = SimpleNamespace(cooling_model=block, heating_model=replace(block))  # a v2.1 cooling/heating pair
    one = flipped("lstm_one_model_across_modes")
    assert separate_heating_model(single, CORRECTED) and not separate_heating_model(single, one)
    assert separate_heating_model(pair, CORRECTED) and separate_heating_model(pair, one)
    # in an episode: the data set's 22 degC stays wherever the model warms up again (2.1's reading: the lookback
    # = 2 rows from every switch, which serve the ideal load too, as does the row after), never after the first
    # warm-up with one model
    path = _mode_switch_district(tmp_path)
    kept = {}
    for settings in (CORRECTED, one):
        temperature = _zero_episode(path, settings).series()["indoor_dry_bulb_temperature"][0]
        kept[settings] = int((temperature[3:] == 22.0).sum())
    assert kept[one] == 0 and kept[CORRECTED] == 2 * 7  # 7 switches in rows 3..47


def test_kpi_partial_load_heating_cop_of_last_step(tmp_path):
    path = _mode_switch_district(tmp_path, heating_load=1.0)
    saved = {}
    for settings in (CORRECTED, flipped("kpi_partial_load_heating_cop_of_last_step")):
        env = _zero_episode(path, settings)
        s = env.series()
        saved[settings] = s["net_electricity_consumption_without_storage_and_partial_load"][0] \
            - s["net_electricity_consumption_without_storage"][0]
        heating = s["heating_demand_without_partial_load"][0] - s["heating_demand"][0]
        cooling = (s["cooling_demand_without_partial_load"][0] - s["cooling_demand"][0]) / s["cooling_device_cop"][0]
        cop = s["heating_device_cop"][0]
    assert heating.sum() > 5.0 and np.ptp(cop) > 0.1  # heat not served, at varying COP
    np.testing.assert_allclose(saved[CORRECTED], cooling + heating / cop, rtol=1e-12)
    # CityLearn 2.1 / 2.5: every step's heating difference over the COP of the last step
    np.testing.assert_allclose(saved[flipped("kpi_partial_load_heating_cop_of_last_step")],
                               cooling + heating / cop[-1], rtol=1e-12)


def test_kpi_names_2_5():
    series = hand_series()
    series["indoor_dry_bulb_temperature_cooling_set_point"] = np.full((2, 48), 23.0)
    series["indoor_dry_bulb_temperature_heating_set_point"] = np.full((2, 48), 22.5)
    table = kpis.evaluate(series, ["a", "b"], dynamics=[True, True], settings=flipped("kpi_names_2_5"))
    assert set(table["cost_function"]) == {*kpis.BUILDING_KPIS_2_5, *kpis.DISTRICT_KPIS_2_5}
    value = table.set_index(["cost_function", "name"])["value"]
    # a: 26 degC on 6 of its 24 occupied steps, 3 above the cooling set point (band 2): hot; b: 20 degC on 12 of 48,
    # 2.5 below the heating set point: cold. Deltas over every step, unoccupied ones 0
    assert value["discomfort_hot_proportion", "a"] == pytest.approx(6 / 24) and value["discomfort_cold_proportion",
                                                                                     "a"] == 0.0
    assert value["discomfort_cold_proportion", "b"] == pytest.approx(12 / 48)
    assert value["discomfort_hot_delta_average", "a"] == pytest.approx(3 * 6 / 48)
    assert value["discomfort_cold_delta_maximum", "b"] == 2.5 and value["discomfort_cold_delta_minimum", "b"] == 0.0
    # ramping: increases only, the control series one step short (47 steps: 23 rises of 1 kWh); baseline 24 x 4
    assert value["ramping_average", "District"] == pytest.approx(23 / 96)
    assert value["all_time_peak_average", "District"] == pytest.approx(3 / 6.5)
    corrected = kpis.evaluate(series, ["a", "b"], dynamics=[True, True])
    assert "annual_peak_average" in set(corrected["cost_function"]) and "discomfort_cold_proportion" not in \
        set(corrected["cost_function"])
