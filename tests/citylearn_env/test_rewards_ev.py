"""CityLearn 2.5's Electric_Vehicles_Reward_Function: a hand-computed district, and parity with upstream 2.5.0.

The parity reference is ``benchmarks/upstream_2_5_0/ev_rewards.json`` (``benchmarks/ev_reward_upstream.py``:
citylearn==2.5.0 on citylearn_challenge_2022_phase_all_plus_evs with the schema's own reward, central agent and
one agent per building, the seeded action table of ``ev_actions.json``, first 600 step calls), an independent run
of upstream's code. The 2.5 preset has upstream's step timing (``settings.act_then_advance``): step call k acts on
row k and scores it, so call k here plays table row k and its reward is compared with upstream's call k, from the
first call (``SETTLED`` = 0). What remains is float32 storage upstream: measured at most 2.0e-6 (central) and 3.5e-6
(per building) relative to max(|r|, 1), tolerance 2e-4.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env import rewards as R
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_5, CORRECTED
from tests.conftest import ROOT, SHARED, need_shared

EV_DATASET = SHARED / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2022_phase_all_plus_evs"
REFERENCE = ROOT / "benchmarks" / "upstream_2_5_0" / "ev_rewards.json"
ACTIONS = ROOT / "benchmarks" / "upstream_2_5_0" / "ev_actions.json"
TYPE = "citylearn.reward_function.Electric_Vehicles_Reward_Function"
SETTLED = 0


# ------------------------------------------------------------------------------------------ by hand
def hand_step() -> R.ChargerStep:
    """Four chargers: 0 and 1 in building 0, 2 and 3 in building 2 (building 1 has none)."""
    return R.ChargerStep(
        building=np.array([0, 0, 2, 2]),
        connected=np.array([True, True, False, True]),
        action_energy=np.array([5.0, -3.0, 2.0, 0.0]),
        previous_soc=np.array([0.5, 0.05, 0.0, 0.8]),
        soc=np.array([0.62, 0.02, 0.0, 0.8]),
        capacity=np.array([40.0, 60.0, 0.0, 40.0]),
        min_capacity=np.array([4.0, 6.0, 0.0, 4.0]),
        required_soc=np.array([0.8, 0.9, 0.0, 0.8]),
        hours_until_departure=np.array([2.0, 0.0, 0.0, 0.0]),
        max_charging_power=np.array([7.4, 7.4, 11.0, 11.0]),
        max_discharging_power=np.array([7.4, 7.4, 0.0, 0.0]))


#: net consumption [kWh] of the three buildings
NET = {"net_electricity_consumption": np.array([2.0, 1.0, -1.0])}
# MARL with e = -net = (-2, -1, 1) and district net 2: sign(e) 0.01 e^2 x 2 = (-0.08, -0.02, 0.02);
# multipliers 1 / (1 + |m|): building 0 1/1.08, building 2 1/1.02.
# charger 0: stored 0.5 x 40 + 5 = 25 within 4..40; gap 0.62 - 0.8 = -0.18, -7.2 kWh, within 7.4 x 2 = 14.8
#   -> close_soc 10 / 2.1; importing while charging -> -0.5 x 5 = -2.5
# charger 1: stored 0.05 x 60 - 3 = 0 < 6 -> battery_limits -2; leaving (0 h) 0.88 short -> soc_under -5 x 5
#   (upstream +25); importing while discharging -> self_ev_consumption +5
# charger 2: no EV, asked for 2 kWh > 0.1 -> no_car_charging -5 (upstream: nothing)
# charger 3: leaving exactly at the required SOC -> close_soc 10 + 10 / (0 + 0.1) = 110; no energy moved
CHARGER_0 = 10.0 / 2.1 - 2.5
CORRECTED_B0, UPSTREAM_B0 = (CHARGER_0 - 2.0 - 25.0 + 5.0) / 1.08, (CHARGER_0 - 2.0 + 25.0 + 5.0) / 1.08
CORRECTED_B2, UPSTREAM_B2 = (-5.0 + 110.0) / 1.02, 110.0 / 1.02


def hand_context(central: bool) -> R.RewardContext:
    return R.RewardContext(central_agent=central, building_names=["a", "b", "c"], chargers=hand_step)


@pytest.mark.parametrize(("settings", "b0", "b2"), [(CORRECTED, CORRECTED_B0, CORRECTED_B2),
                                                     (CITYLEARN_2_5, UPSTREAM_B0, UPSTREAM_B2)])
def test_hand_computed_buildings(settings, b0, b2):
    reward = R.make_reward({"type": TYPE, "attributes": {}}, hand_context(False), settings=settings)
    values, terms = reward(NET)
    np.testing.assert_allclose(values, [b0, 0.0, b2], rtol=1e-12)
    np.testing.assert_allclose(terms["marl"], [-0.08, -0.02, 0.02], rtol=1e-12)
    np.testing.assert_allclose(terms["battery_limits"], [-2.0 / 1.08, 0.0, 0.0], rtol=1e-12)
    np.testing.assert_allclose(sum(v for k, v in terms.items() if k != "marl"), values, rtol=1e-12)


def test_hand_computed_central():
    # central: one multiplier from the district's MARL sum -0.08 -> 1 / 1.08 for every building, then the sum
    value, _ = R.make_reward(TYPE, hand_context(True))(NET)
    assert value == pytest.approx((CHARGER_0 - 2.0 - 25.0 + 5.0 - 5.0 + 110.0) / 1.08, rel=1e-12)


def test_weights_replace_defaults_by_name():
    spec = {"type": "electric_vehicles", "attributes": {"weights": {"close_soc": 0.0}}}
    values, _ = R.make_reward(spec, hand_context(False))(NET)
    np.testing.assert_allclose(values, [(-2.5 - 2.0 - 25.0 + 5.0) / 1.08, 0.0, -5.0 / 1.02], rtol=1e-12)
    for weights, message in (({"close": 1.0}, "unknown EV reward weight 'close'"),
                             ({"close_soc": "high"}, "'close_soc' must be a finite number"),
                             ([1.0], "must map weight names to numbers")):
        with pytest.raises(SchemaError, match=message):
            R.make_reward({"type": "electric_vehicles", "attributes": {"weights": weights}}, hand_context(False))


def test_district_without_chargers_scores_zero():
    context = R.RewardContext(central_agent=False, building_names=["a", "b", "c"])
    values, terms = R.make_reward(TYPE, context)(NET)
    np.testing.assert_array_equal(values, np.zeros(3))
    np.testing.assert_allclose(terms["marl"], [-0.08, -0.02, 0.02], rtol=1e-12)


# ------------------------------------------------------------------------------------------ upstream 2.5.0
@pytest.fixture(scope="module")
def reference():
    for path in (REFERENCE, ACTIONS):
        if not path.exists():
            pytest.skip(f"{path} absent: run benchmarks/ev_reward_upstream.py and benchmarks/ev_upstream.py --only ev")
    need_shared(EV_DATASET / "schema.json")
    return json.loads(REFERENCE.read_text()), json.loads(ACTIONS.read_text())


def our_rewards(ref: dict, actions: dict, central: bool) -> tuple[list[str], np.ndarray]:
    """Our rewards of rows 1 .. steps - 1 in the 2.5 preset with the schema's reward: (building names, (steps - 1,)
    central or (steps - 1, B) per building)."""
    config = load_schema(EV_DATASET / "schema.json", settings="citylearn-2.5").with_ev_initial_soc(
        {name: battery["initial_soc"] for name, battery in actions["ev_battery"].items()})
    env = CityLearnEnv(config, settings="citylearn-2.5", central_agent=central)
    table = np.random.default_rng(ref["seed"]).uniform(ref["action_low"], ref["action_high"],
                                                       size=(ref["time_steps"], len(ref["action_low"])))
    env.reset(seed=ref["seed"])
    out = []
    for k in range(ref["steps"]):
        _, reward, _, _, info = env.step(table[k])
        out.append(reward if central else info["building_rewards"].copy())
    return env.building_names, np.array(out)


def test_central_rewards_match_upstream(reference):
    ref, actions = reference
    _, ours = our_rewards(ref, actions, central=True)
    theirs = np.array(ref["central"])
    rows = slice(SETTLED, None)
    np.testing.assert_allclose(ours[rows], theirs[rows], rtol=2e-4, atol=2e-4)
    assert np.abs(theirs[rows]).max() > 10.0  # the comparison sees real scores


def test_per_building_rewards_match_upstream(reference):
    ref, actions = reference
    names, ours = our_rewards(ref, actions, central=False)
    theirs = np.array([ref["decentral"][name] for name in names]).T
    rows = slice(SETTLED, None)
    np.testing.assert_allclose(ours[rows], theirs[rows], rtol=2e-4, atol=2e-4)
    without_chargers = [b for b, name in enumerate(names) if not any(theirs[:, b])]
    assert len(without_chargers) == 10  # 8 chargers in 7 of the 17 buildings; the rest score 0 upstream too
    assert not ours[:, without_chargers].any()
