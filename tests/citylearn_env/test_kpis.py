"""KPIs: CityLearn 2.1.2's ``evaluate`` and challenge score on the golden traces, the corrected default
behaviours, and the SimBuild paper objectives against hand computations."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from citylearn_env import kpis
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_1
from tests.conftest import GOLDEN, need_shared

SCENARIOS = ("no_control", "storage_pv_random", "full_random", "full_random_outage")


def close(ours: float, reference: float, tol: float = 1e-4) -> bool:
    """Equal within 1e-4 absolute or relative; NaN equals NaN."""
    if math.isnan(reference) or math.isnan(ours):
        return math.isnan(reference) and math.isnan(ours)
    return abs(ours - reference) <= tol or abs(ours - reference) <= tol * abs(reference)


@pytest.fixture(scope="module")
def golden():
    """scenario -> (series as (B, T) arrays from trace.parquet, building names); read once per module."""
    out = {}
    for scenario in SCENARIOS:
        need_shared(GOLDEN / scenario / "trace.parquet")
        trace = pd.read_parquet(GOLDEN / scenario / "trace.parquet").sort_values(["building", "time_step"])
        names = list(dict.fromkeys(trace["building"]))
        steps = int(trace["time_step"].max()) + 1
        series = {c: trace[c].to_numpy(dtype=float).reshape(len(names), steps)
                  for c in trace.columns if c not in ("building", "time_step")}
        out[scenario] = series, names
    return out


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_evaluate_matches_citylearn_212(golden, scenario):
    series, names = golden[scenario]
    ours = kpis.evaluate(series, names, dynamics=[True] * len(names), settings=CITYLEARN_2_1)
    assert list(ours.columns) == ["cost_function", "value", "name", "level"]
    reference = pd.read_csv(GOLDEN / scenario / "kpis.csv")
    assert len(ours) == len(reference) == 6 * 13 + 18
    ours = ours.set_index(["name", "cost_function"])
    for row in reference.itertuples():
        value = ours.loc[(row.name, row.cost_function)]
        assert value["level"] == row.level
        assert close(float(value["value"]), float(row.value)), (row.name, row.cost_function, value["value"],
                                                                row.value)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_challenge_score_matches_citylearn_212(golden, scenario):
    series, names = golden[scenario]
    ours = kpis.evaluate_challenge(series, names, dynamics=[True] * len(names), settings=CITYLEARN_2_1)
    reference = pd.read_csv(GOLDEN / scenario / "kpis_challenge.csv")
    assert list(ours["kpi"]) == list(reference["kpi"])
    assert list(ours["display_name"]) == list(reference["display_name"])
    for a, b in zip(ours["value"], reference["value"], strict=True):
        assert close(a, b), (a, b)


def test_headline_numbers_of_the_readme(golden):
    """README §8: cost_total, discomfort_proportion and challenge score per scenario (4 decimals)."""
    headline = {"no_control": (1.0, 0.1470, 0.5404), "storage_pv_random": (1.1600, 0.1470, 0.6202),
                "full_random": (2.0350, 0.9372, 0.9318), "full_random_outage": (2.0242, 0.9268, 1.1772)}
    for scenario, (cost, comfort, score) in headline.items():
        series, names = golden[scenario]
        table = kpis.evaluate(series, names, dynamics=[True] * 6, settings=CITYLEARN_2_1)
        district = table[table["name"] == "District"].set_index("cost_function")["value"]
        assert district["cost_total"] == pytest.approx(cost, abs=5e-5)
        assert district["discomfort_proportion"] == pytest.approx(comfort, abs=5e-5)
        challenge = kpis.evaluate_challenge(series, names, dynamics=[True] * 6, settings=CITYLEARN_2_1)
        assert challenge["value"].iloc[-1] == pytest.approx(score, abs=5e-5)


def test_window_equals_evaluating_the_sliced_series(golden):
    series, names = golden["full_random_outage"]
    window = slice(313, 720)
    a = kpis.evaluate(series, names, dynamics=[True] * 6, window=window)
    b = kpis.evaluate({k: v[:, window] for k, v in series.items()}, names, dynamics=[True] * 6)
    pd.testing.assert_frame_equal(a, b)
    whole = kpis.evaluate(series, names, dynamics=[True] * 6)
    assert not np.allclose(a["value"], whole["value"], equal_nan=True)


def test_corrected_discomfort_deltas_ignore_unoccupied_steps(golden):
    """§12 #11: CityLearn 2.1 averages T - S with zeros on unoccupied steps; the fix averages occupied steps only."""
    series, names = golden["no_control"]
    occupied = series["occupant_count"][0] > 0
    assert 0 < occupied.sum() < occupied.size
    delta = (series["indoor_dry_bulb_temperature"] - series["indoor_dry_bulb_temperature_set_point"])[0]
    fixed = kpis.evaluate(series, names, dynamics=[True] * 6).set_index(["name", "cost_function"])["value"]
    upstream = kpis.evaluate(series, names, dynamics=[True] * 6, settings=CITYLEARN_2_1).set_index(
        ["name", "cost_function"])["value"]
    b1 = names[0]
    assert fixed[(b1, "discomfort_delta_average")] == pytest.approx(delta[occupied].mean())
    assert upstream[(b1, "discomfort_delta_average")] == pytest.approx(delta[occupied].sum() / delta.size)
    assert fixed[(b1, "discomfort_proportion")] == upstream[(b1, "discomfort_proportion")]


# ---------------------------------------------------------------------------------------- hand-made inputs
def test_primitives_by_hand():
    assert kpis.ramping(np.array([1.0, 3.0, 2.0, 2.0])) == 3.0
    # blocks [1, 3] and [2, 2]: 1 - 2/3 and 1 - 1 -> mean 1/6
    assert kpis.one_minus_load_factor(np.array([1.0, 3.0, 2.0, 2.0]), 2) == pytest.approx(1 / 6)
    assert kpis.peak(np.array([1.0, 3.0, 2.0, 2.0, 5.0]), 2) == pytest.approx((3 + 2 + 5) / 3)
    assert kpis.positive_sum(np.array([1.0, -3.0, 2.5])) == 3.5
    assert kpis.normalized_unserved_energy(np.array([2.0, 4.0, 1.0]), np.array([2.0, 1.0, 0.0]),
                                           np.array([0, 1, 1])) == pytest.approx(4 / 5)
    assert math.isnan(kpis.normalized_unserved_energy(np.ones(3), np.ones(3), np.zeros(3)))


def test_division_plain_and_safe():
    assert kpis.divide(1.0, 0.0, plain=True) == math.inf
    assert math.isnan(kpis.divide(0.0, 0.0, plain=True))
    assert kpis.divide(0.0, 0.0) == 1.0
    assert math.isnan(kpis.divide(1.0, 0.0))
    assert kpis.divide(3.0, 4.0) == 0.75


def test_discomfort_by_hand():
    temperature = np.array([20.0, 25.5, 23.0, 18.0, 30.0, 21.0])
    set_point = np.full(6, 23.0)
    occupants = np.array([1, 2, 0, 1, 1, 1])  # step 2 unoccupied; step 5 sits exactly on the band edge
    stats = kpis.discomfort(temperature, set_point, 2.0, occupants)
    # occupied deltas -3, 2.5, -5, 7, -2: four strictly beyond the 2 C band, two of them too cold
    assert stats["discomfort_proportion"] == pytest.approx(4 / 5)
    assert stats["discomfort_too_cold_proportion"] == pytest.approx(2 / 5)
    assert stats["discomfort_too_hot_proportion"] == pytest.approx(2 / 5)
    assert stats["discomfort_delta_minimum"] == -5.0 and stats["discomfort_delta_maximum"] == 7.0
    assert stats["discomfort_delta_average"] == pytest.approx(-0.5 / 5)
    all_steps = kpis.discomfort(temperature, set_point, 2.0, occupants, over_all_steps=True)
    assert all_steps["discomfort_delta_average"] == pytest.approx(-0.5 / 6)
    empty = kpis.discomfort(temperature, set_point, 2.0, np.zeros(6))
    assert math.isnan(empty["discomfort_proportion"]) and math.isnan(empty["discomfort_delta_average"])


def _small_series() -> dict[str, np.ndarray]:
    return {
        "net_electricity_consumption": np.array([[1.0, -2.0, 3.0, 0.5], [0.5, 1.0, -1.0, 2.0]]),
        "electricity_pricing": np.tile([0.1, 0.2, 0.1, 0.3], (2, 1)),
        "carbon_intensity": np.tile([0.5, 0.5, 1.0, 1.0], (2, 1)),
        "indoor_dry_bulb_temperature": np.array([[24.0, 22.5, 23.0, 25.0], [23.0, 23.0, 22.0, 23.0]]),
        "indoor_dry_bulb_temperature_set_point": np.full((2, 4), 23.0),
    }


def test_objectives_by_hand():
    out = kpis.objectives(_small_series(), steps_per_day=2)
    # cost: B1 1*.1 + 3*.1 + .5*.3 = .55, B2 .5*.1 + 1*.2 + 2*.3 = .85
    assert out["per_building"]["cost"] == pytest.approx([0.55, 0.85])
    assert out["cost"] == pytest.approx(1.40)
    # emissions: B1 .5 + 3 + .5 = 4, B2 .25 + .5 + 2 = 2.75
    assert out["emissions"] == pytest.approx(6.75)
    assert out["consumption"] == pytest.approx(4.5 + 3.5)
    # |T - S|: B1 1 + .5 + 0 + 2, B2 0 + 0 + 1 + 0
    assert out["per_building"]["discomfort"] == pytest.approx([3.5, 1.0])
    # district P = [1.5, -1, 2, 2.5]; day maxima 1.5 and 2.5 -> 4 * 2 / 4
    assert out["average_daily_peak"] == pytest.approx(2.0)


def test_objectives_window_aligns_days_to_its_start():
    out = kpis.objectives(_small_series(), window=slice(1, 4), steps_per_day=2)
    # P = [-1, 2, 2.5]: days [-1, 2] and [2.5] -> (2 + 2.5) * 2 / 3
    assert out["average_daily_peak"] == pytest.approx(3.0)
    assert out["cost"] == pytest.approx(0.45 + 0.80)


def test_citylearn_2_1_takes_the_first_buildings_condition():
    """CityLearn 2.1 fixes the baseline on the first building; the fix uses each building's own."""
    ones = np.ones((2, 4))
    series = {k: ones.copy() for k in ("indoor_dry_bulb_temperature", "indoor_dry_bulb_temperature_set_point",
                                       "occupant_count", "electricity_pricing", "carbon_intensity")}
    series["power_outage"] = np.zeros((2, 4))
    for k in (*kpis.DEMANDS, *kpis.DELIVERED):
        series[k] = ones.copy()
    for kind in ("", "_cost", "_emission"):
        series[f"net_electricity_consumption{kind}"] = np.full((2, 4), 2.0)
        series[f"net_electricity_consumption{kind}_without_storage"] = np.full((2, 4), 4.0)
        series[f"net_electricity_consumption{kind}_without_storage_and_partial_load"] = np.full((2, 4), 1.0)
    fixed = kpis.building_kpis(series, ["a", "b"], dynamics=[False, True])
    upstream = kpis.building_kpis(series, ["a", "b"], dynamics=[False, True], settings=CITYLEARN_2_1)
    assert [r["cost_total"] for r in fixed] == [0.5, 2.0]
    assert [r["cost_total"] for r in upstream] == [0.5, 0.5]


def test_missing_series_is_named():
    series = _small_series()
    del series["carbon_intensity"]
    with pytest.raises(SchemaError, match="carbon_intensity"):
        kpis.objectives(series)


def test_corrected_agrees_with_citylearn_2_1_where_no_correction_applies(golden):
    """On the outage scenario no division is by zero, so only the delta statistics (#11) may differ."""
    series, names = golden["full_random_outage"]
    key = ["name", "cost_function"]
    fixed = kpis.evaluate(series, names, dynamics=[True] * 6).set_index(key)["value"]
    upstream = kpis.evaluate(series, names, dynamics=[True] * 6, settings=CITYLEARN_2_1).set_index(key)["value"]
    deltas = fixed.index.get_level_values("cost_function").str.startswith("discomfort_delta")
    assert all(close(a, b, 1e-12) for a, b in zip(fixed[~deltas], upstream[~deltas], strict=True))
    assert not np.allclose(fixed[deltas], upstream[deltas])
