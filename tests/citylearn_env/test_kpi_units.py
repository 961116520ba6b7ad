"""Every KPI function on small hand-made series, each expected value worked out by hand in the test.

Needs nothing outside the repository. Units: energies kWh per step, cost $ per step, emissions kg per step,
temperatures degC; the ratios are dimensionless.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from citylearn_env import kpis
from citylearn_env.settings import CITYLEARN_2_1, CORRECTED

T = 48  # two days of hourly steps


# ---------------------------------------------------------------------------------------------- primitives
def test_ramping():
    # |5 - 2| + |1 - 5| + |1 - 1| + |4 - 1| = 3 + 4 + 0 + 3
    assert kpis.ramping(np.array([2.0, 5.0, 1.0, 1.0, 4.0])) == 10.0
    assert kpis.ramping(np.array([7.0])) == 0.0


def test_one_minus_load_factor_blocks_from_the_first_step():
    # window 2 over [4, 2 | 1, 3 | 3]: 1 - 3/4 = 1/4, 1 - 2/3 = 1/3, the short last block 1 - 3/3 = 0
    assert kpis.one_minus_load_factor(np.array([4.0, 2.0, 1.0, 3.0, 3.0]), 2) == pytest.approx(
        (1 / 4 + 1 / 3 + 0) / 3)
    # a negative maximum is divided as is: [-1, -3] -> 1 - (-2) / (-1) = -1
    assert kpis.one_minus_load_factor(np.array([-1.0, -3.0]), 2) == pytest.approx(-1.0)


def test_one_minus_load_factor_zero_max_block():
    net = np.array([1.0, 3.0, 2.0, 2.0, 0.0, 0.0])
    # corrected: [0, 0] has no load factor and is skipped -> mean(1 - 2/3, 1 - 1) = 1/6
    assert kpis.one_minus_load_factor(net, 2) == pytest.approx(1 / 6)
    # plain division: 1 - 0/0 = NaN enters the mean
    assert math.isnan(kpis.one_minus_load_factor(net, 2, plain_division=True))
    assert math.isnan(kpis.one_minus_load_factor(np.zeros(4), 2))


def test_peak():
    # window 2 over [1, 4 | 2, 6 | 3]: maxima 4, 6, 3
    assert kpis.peak(np.array([1.0, 4.0, 2.0, 6.0, 3.0]), 2) == pytest.approx(13 / 3)
    assert kpis.peak(np.array([1.0, 4.0, 2.0, 6.0, 3.0]), 8760) == 6.0


def test_positive_sum():
    assert kpis.positive_sum(np.array([1.5, -2.0, 0.5, 0.0])) == 2.0


def test_discomfort_occupied_steps_and_all_steps():
    temperature = np.array([19.0, 26.0, 22.0, 25.0, 20.0])
    set_point = np.full(5, 23.0)
    occupants = np.array([1.0, 1.0, 0.0, 2.0, 0.0])
    # deltas -4, 3, -1, 2, -3; occupied steps 0, 1, 3 -> -4 (too cold), 3 (too hot), 2 (on the band edge)
    stats = kpis.discomfort(temperature, set_point, 2.0, occupants)
    assert stats["discomfort_proportion"] == pytest.approx(2 / 3)
    assert stats["discomfort_too_cold_proportion"] == pytest.approx(1 / 3)
    assert stats["discomfort_too_hot_proportion"] == pytest.approx(1 / 3)
    assert stats["discomfort_delta_minimum"] == -4.0
    assert stats["discomfort_delta_maximum"] == 3.0
    assert stats["discomfort_delta_average"] == pytest.approx((-4 + 3 + 2) / 3)
    # over all steps: unoccupied deltas count as 0 -> [-4, 3, 0, 2, 0]; proportions unchanged
    every = kpis.discomfort(temperature, set_point, 2.0, occupants, over_all_steps=True)
    assert every["discomfort_delta_average"] == pytest.approx((-4 + 3 + 0 + 2 + 0) / 5)
    assert every["discomfort_delta_minimum"] == -4.0 and every["discomfort_delta_maximum"] == 3.0
    assert every["discomfort_proportion"] == pytest.approx(2 / 3)


def test_band_delta_is_zero_inside_the_band_and_the_distance_outside():
    temperature = np.array([18.0, 20.0, 22.0, 24.0, 26.0])
    # band [20, 24]: 2 degC below it, the two edges and the middle inside, 2 degC above it
    assert kpis.band_delta(temperature, np.full(5, 20.0), np.full(5, 24.0)).tolist() == [-2.0, 0, 0, 0, 2.0]
    # edges swapped: the same band
    assert kpis.band_delta(temperature, np.full(5, 24.0), np.full(5, 20.0)).tolist() == [-2.0, 0, 0, 0, 2.0]
    # one set point: T - S
    assert kpis.band_delta(temperature, np.full(5, 23.0), np.full(5, 23.0)).tolist() == [-5, -3, -1, 1, 3]


def test_discomfort_against_the_band_counts_no_deadband_step():
    # heating 20, cooling 25, band 1: 24 degC sits in the deadband (2.1's one cooling set point 25: -1 delta,
    # inside its band too); 18.5 is 1.5 below heating (cold); 26.5 is 1.5 above cooling (hot); 19.5 is 0.5 below
    temperature = np.array([24.0, 18.5, 26.5, 19.5])
    stats = kpis.discomfort(temperature, np.full(4, 20.0), 1.0, np.ones(4), cooling_set_point=np.full(4, 25.0))
    assert stats["discomfort_too_cold_proportion"] == pytest.approx(1 / 4)
    assert stats["discomfort_too_hot_proportion"] == pytest.approx(1 / 4)
    assert stats["discomfort_delta_minimum"] == -1.5 and stats["discomfort_delta_maximum"] == 1.5
    assert stats["discomfort_delta_average"] == pytest.approx((0 - 1.5 + 1.5 - 0.5) / 4)


def test_discomfort_objective_against_the_band():
    series = {k: np.zeros((1, 4)) for k in ("net_electricity_consumption", "electricity_pricing",
                                             "carbon_intensity")}
    series |= {"indoor_dry_bulb_temperature": np.array([[21.0, 23.0, 26.0, 19.0]]),
               # the one set point follows hvac_mode: cooling 24, cooling 24, cooling 24, heating 20
               "indoor_dry_bulb_temperature_set_point": np.array([[24.0, 24.0, 24.0, 20.0]]),
               "indoor_dry_bulb_temperature_cooling_set_point": np.full((1, 4), 24.0),
               "indoor_dry_bulb_temperature_heating_set_point": np.full((1, 4), 20.0)}
    # band [20, 24]: 0 + 0 + 2 + 1 degC h; against the one set point: 3 + 1 + 2 + 1
    assert kpis.objectives(series)["discomfort"] == pytest.approx(3.0)
    assert kpis.objectives(series, one_set_point=True)["discomfort"] == pytest.approx(7.0)


def test_discomfort_without_occupants_is_nan():
    stats = kpis.discomfort(np.array([30.0, 30.0]), np.array([23.0, 23.0]), 2.0, np.zeros(2))
    assert all(math.isnan(v) for v in stats.values())


def test_normalized_unserved_energy():
    expected, served = np.array([2.0, 4.0, 1.0, 3.0]), np.array([2.0, 1.0, 0.0, 3.0])
    # outage steps 1, 2: unserved (4 - 1) + (1 - 0) = 4 of 4 + 1 = 5 expected
    assert kpis.normalized_unserved_energy(expected, served, np.array([0, 1, 1, 0])) == pytest.approx(4 / 5)
    # all steps: 4 unserved of 2 + 4 + 1 + 3 = 10
    assert kpis.normalized_unserved_energy(expected, served) == pytest.approx(4 / 10)
    # no outage step: NaN (both ways)
    assert math.isnan(kpis.normalized_unserved_energy(expected, served, np.zeros(4)))
    assert math.isnan(kpis.normalized_unserved_energy(expected, served, np.zeros(4), plain_division=True))
    # an outage with nothing expected and nothing missing: 0 corrected, 0/0 = NaN plain
    zero = np.zeros(2)
    assert kpis.normalized_unserved_energy(zero, zero, np.ones(2)) == 0.0
    assert math.isnan(kpis.normalized_unserved_energy(zero, zero, np.ones(2), plain_division=True))
    # 1 kWh "unserved" of 0 expected: NaN corrected, +inf plain
    assert math.isnan(kpis.normalized_unserved_energy(np.zeros(1), np.array([-1.0]), np.ones(1)))
    assert kpis.normalized_unserved_energy(np.zeros(1), np.array([-1.0]), np.ones(1), plain_division=True) \
        == math.inf


def test_divide():
    assert kpis.divide(3.0, 4.0) == 0.75 and kpis.divide(3.0, 4.0, plain=True) == 0.75
    assert kpis.divide(0.0, 0.0) == 1.0
    assert math.isnan(kpis.divide(0.0, 0.0, plain=True))
    assert math.isnan(kpis.divide(1.0, 0.0))
    assert kpis.divide(1.0, 0.0, plain=True) == math.inf
    assert kpis.divide(-1.0, 0.0, plain=True) == -math.inf
    assert math.isnan(kpis.divide(math.inf, 2.0))
    assert kpis.divide(math.inf, 2.0, plain=True) == math.inf
    assert math.isnan(kpis.divide(math.nan, 2.0))


# ---------------------------------------------------------------------------------------------- objectives
def test_objectives_two_buildings():
    series = {
        "net_electricity_consumption": np.array([[1.0, -2.0, 3.0, 0.5], [2.0, 2.0, -1.0, 1.0]]),
        "electricity_pricing": np.tile([0.1, 0.2, 0.1, 0.3], (2, 1)),
        "carbon_intensity": np.tile([0.5, 0.5, 1.0, 1.0], (2, 1)),
        "indoor_dry_bulb_temperature": np.array([[24.0, 22.5, 23.0, 25.0], [23.0, 21.0, 22.0, 23.5]]),
        "indoor_dry_bulb_temperature_set_point": np.full((2, 4), 23.0),
    }
    out = kpis.objectives(series, steps_per_day=2)
    # cost: a 1 * .1 + 3 * .1 + .5 * .3 = .55; b 2 * .1 + 2 * .2 + 1 * .3 = .9
    np.testing.assert_allclose(out["per_building"]["cost"], [0.55, 0.9])
    assert out["cost"] == pytest.approx(1.45)
    # emissions: a .5 + 3 + .5 = 4; b 1 + 1 + 1 = 3
    assert out["emissions"] == pytest.approx(7.0)
    # consumption: a 1 + 3 + .5; b 2 + 2 + 1
    np.testing.assert_allclose(out["per_building"]["consumption"], [4.5, 5.0])
    # discomfort: a 1 + .5 + 0 + 2; b 0 + 2 + 1 + .5
    np.testing.assert_allclose(out["per_building"]["discomfort"], [3.5, 3.5])
    assert out["discomfort"] == pytest.approx(7.0)
    # district P = [3, 0, 2, 1.5]; day maxima 3 and 2 -> (3 + 2) * 2 steps per day / 4 steps
    assert out["average_daily_peak"] == pytest.approx(2.5)


# ---------------------------------------------------------------------------------------------- evaluate
def _alternate(even: float, odd: float) -> np.ndarray:
    return np.tile([even, odd], T // 2)


def hand_series() -> dict[str, np.ndarray]:
    """2 buildings (a, b), 48 hourly steps, built from alternating even/odd step values.

    a: net [1, 3], baseline 2.5; b: net [2, -1] (exports at odd steps), baseline [0, 4]. Price [.1, .3] $/kWh,
    carbon .5 kg/kWh. a is occupied (1 person) for the first 24 steps at 26 degC on steps 0..5 and 23 degC
    otherwise; b is occupied (2) throughout at 20 degC on steps 0..11, 24 degC after; set point 23. a has an
    outage on steps 2 and 3, where its cooling device delivers .25 of a 1 kWh demand; b has none.
    """
    net = np.stack([_alternate(1.0, 3.0), _alternate(2.0, -1.0)])
    base = np.stack([np.full(T, 2.5), _alternate(0.0, 4.0)])
    price = np.tile(_alternate(0.1, 0.3), (2, 1))
    carbon = np.full((2, T), 0.5)
    series = {"electricity_pricing": price, "carbon_intensity": carbon}
    for suffix in ("", "_without_storage", "_without_storage_and_partial_load"):
        values = net if suffix == "" else base
        series[f"net_electricity_consumption{suffix}"] = values
        series[f"net_electricity_consumption_cost{suffix}"] = values * price
        series[f"net_electricity_consumption_emission{suffix}"] = values * carbon
    temperature = np.full((2, T), 23.0)
    temperature[0, :6] = 26.0
    temperature[1, :12], temperature[1, 12:] = 20.0, 24.0
    occupants = np.zeros((2, T))
    occupants[0, :24], occupants[1] = 1.0, 2.0
    outage = np.zeros((2, T))
    outage[0, 2:4] = 1.0
    zeros = np.zeros((2, T))
    series.update({"indoor_dry_bulb_temperature": temperature,
                   "indoor_dry_bulb_temperature_set_point": np.full((2, T), 23.0),
                   "occupant_count": occupants, "power_outage": outage})
    for name in (*kpis.DEMANDS, *kpis.DELIVERED):
        series[name] = zeros.copy()
    series["cooling_demand"][0] = 1.0
    series["energy_from_cooling_device"][0] = np.where(outage[0] == 1.0, 0.25, 1.0)
    series["non_shiftable_load"][1] = 2.0
    series["energy_to_non_shiftable_load"][1] = 2.0
    return series


#: building KPIs of hand_series worked out by hand (CORRECTED)
HAND_A = {
    # grid import 24 * (1 + 3) = 96 of a 48 * 2.5 = 120 baseline; net sum the same
    "electricity_consumption_total": 96 / 120,
    "zero_net_energy": 96 / 120,
    # emissions are .5 x the energies: the same ratio
    "carbon_emissions_total": 96 / 120,
    # cost 24 * (1 * .1 + 3 * .3) = 24 of a 24 * (2.5 * .1 + 2.5 * .3) = 24 baseline
    "cost_total": 24 / 24,
    # occupied steps 0..23, delta +3 on 6 of them (beyond the 2 degC band), 0 otherwise
    "discomfort_proportion": 6 / 24,
    "discomfort_too_cold_proportion": 0 / 24,
    "discomfort_too_hot_proportion": 6 / 24,
    "discomfort_delta_minimum": 0.0,
    "discomfort_delta_maximum": 3.0,
    "discomfort_delta_average": 6 * 3 / 24,
    # outage steps 2, 3 are occupied and 3 degC too hot
    "one_minus_thermal_resilience_proportion": 2 / 2,
    # outage steps: 2 kWh expected, .5 served
    "power_outage_normalized_unserved_energy_total": (2 - 0.5) / 2,
    "annual_normalized_unserved_energy_total": (2 - 0.5) / 48,
}
HAND_B = {
    # grid import 24 * 2 = 48 of 24 * 4 = 96; net sum 24 * (2 - 1) = 24 of 96
    "electricity_consumption_total": 48 / 96,
    "zero_net_energy": 24 / 96,
    "carbon_emissions_total": 48 / 96,
    # cost: import only at even steps, 24 * 2 * .1 = 4.8, of 24 * 4 * .3 = 28.8
    "cost_total": 4.8 / 28.8,
    # always occupied: 12 steps at -3 (too cold), 36 at +1 (inside the band)
    "discomfort_proportion": 12 / 48,
    "discomfort_too_cold_proportion": 12 / 48,
    "discomfort_too_hot_proportion": 0 / 48,
    "discomfort_delta_minimum": -3.0,
    "discomfort_delta_maximum": 1.0,
    "discomfort_delta_average": (12 * -3 + 36 * 1) / 48,
    # no outage: no step to judge
    "one_minus_thermal_resilience_proportion": math.nan,
    "power_outage_normalized_unserved_energy_total": math.nan,
    "annual_normalized_unserved_energy_total": 0 / 96,
}
#: district KPIs: control a + b = [3, 2] alternating, baseline [2.5, 6.5] alternating
HAND_DISTRICT = {
    "ramping_average": (47 * 1) / (47 * 4),
    # every 24-step day: 1 - 2.5/3 = 1/6 against 1 - 4.5/6.5 = 4/13; the 730-step month is the whole series
    "daily_one_minus_load_factor_average": (1 / 6) / (4 / 13),
    "monthly_one_minus_load_factor_average": (1 / 6) / (4 / 13),
    "daily_peak_average": 3 / 6.5,
    "annual_peak_average": 3 / 6.5,
}


def assert_same(ours: float, expected: float, key: str) -> None:
    if math.isnan(expected):
        assert math.isnan(ours), key
    else:
        assert ours == pytest.approx(expected, rel=1e-12, abs=1e-12), key


def test_building_kpis_by_hand():
    rows = kpis.building_kpis(hand_series(), ["a", "b"], dynamics=[True, False])
    for row, expected in zip(rows, (HAND_A, HAND_B), strict=True):
        assert set(row) == set(expected)
        for key, value in expected.items():
            assert_same(row[key], value, key)


def test_district_kpis_by_hand():
    district = kpis.district_kpis(hand_series(), dynamics=[True, False])
    assert set(district) == set(HAND_DISTRICT)
    for key, value in HAND_DISTRICT.items():
        assert_same(district[key], value, key)


def test_evaluate_by_hand():
    table = kpis.evaluate(hand_series(), ["a", "b"], dynamics=[True, False])
    assert list(table.columns) == ["cost_function", "value", "name", "level"]
    assert len(table) == 13 + 13 + 18  # two buildings' rows, then 13 building means and 5 district KPIs
    values = table.set_index(["name", "cost_function"])["value"]
    for name, expected in (("a", HAND_A), ("b", HAND_B)):
        for key, value in expected.items():
            assert_same(values[(name, key)], value, f"{name} {key}")
    for key, value in HAND_DISTRICT.items():
        assert_same(values[("District", key)], value, key)
    # the District row of a building KPI is the mean over buildings, NaN ignored
    assert_same(values[("District", "cost_total")], (1.0 + 1 / 6) / 2, "cost_total")
    assert_same(values[("District", "zero_net_energy")], (0.8 + 0.25) / 2, "zero_net_energy")
    assert_same(values[("District", "discomfort_delta_minimum")], (0.0 - 3.0) / 2, "delta min")
    assert_same(values[("District", "one_minus_thermal_resilience_proportion")], 1.0, "resilience")
    assert_same(values[("District", "power_outage_normalized_unserved_energy_total")], 0.75, "unserved")
    assert set(table["level"]) == {"district", "building"}


def test_evaluate_window_is_a_slice_of_the_series():
    # the first day only: a's outage and all of its occupied hours fall inside it
    day = kpis.evaluate(hand_series(), ["a", "b"], dynamics=[True, True], window=slice(0, 24))
    values = day.set_index(["name", "cost_function"])["value"]
    assert values[("a", "discomfort_proportion")] == pytest.approx(6 / 24)
    # b: 12 of 24 occupied steps too cold
    assert values[("b", "discomfort_too_cold_proportion")] == pytest.approx(12 / 24)
    assert values[("a", "annual_normalized_unserved_energy_total")] == pytest.approx(1.5 / 24)


def test_evaluate_challenge_by_hand():
    table = kpis.evaluate_challenge(hand_series(), ["a", "b"], dynamics=[True, False])
    values = table.set_index("kpi")["value"]
    # comfort band 1.0: a's +3 still counts, b's +1 is not strictly beyond it -> unchanged proportions
    district = {
        "carbon_emissions_total": (0.8 + 0.5) / 2,
        "discomfort_proportion": (6 / 24 + 12 / 48) / 2,
        "ramping_average": 0.25,
        "daily_one_minus_load_factor_average": 13 / 24,
        "daily_peak_average": 6 / 13,
        "annual_peak_average": 6 / 13,
        "one_minus_thermal_resilience_proportion": 1.0,
        "power_outage_normalized_unserved_energy_total": 0.75,
    }
    for key, value in district.items():
        assert values[key] == pytest.approx(value, rel=1e-12), key
    # weights .10, .30, 4 x .075, .15, .15 sum to 1
    score = (0.10 * 0.65 + 0.30 * 0.25 + 0.075 * (0.25 + 13 / 24 + 6 / 13 + 6 / 13) + 0.15 * 1.0 + 0.15 * 0.75)
    assert values["average_score"] == pytest.approx(score, rel=1e-12)
    assert list(table["kpi"])[-1] == "average_score"


def test_evaluate_citylearn_2_1_preset_on_the_hand_series():
    """The 2.1 preset changes exactly the numbers its quirks touch on this series."""
    table = kpis.evaluate(hand_series(), ["a", "b"], dynamics=[True, False], settings=CITYLEARN_2_1)
    values = table.set_index(["name", "cost_function"])["value"]
    # a's unoccupied deltas count as 0 over all 48 steps: 18 / 48
    assert values[("a", "discomfort_delta_average")] == pytest.approx(18 / 48)
    # b's baseline follows a's condition (_without_storage_and_partial_load); both are equal here
    assert values[("b", "cost_total")] == pytest.approx(4.8 / 28.8)
    corrected = kpis.evaluate(hand_series(), ["a", "b"], dynamics=[True, False], settings=CORRECTED)
    assert corrected.set_index(["name", "cost_function"])["value"][("a", "discomfort_delta_average")] \
        == pytest.approx(0.75)
