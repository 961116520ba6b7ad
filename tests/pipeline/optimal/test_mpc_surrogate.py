"""MPC through the LSTM surrogate (heat-pump control, issue 29 part 3): rollout copies reproduce the env exactly,
CEM MPC is no worse than no control on a short window, and two seeded runs are identical. Needs the upstream
v2.4.2 citylearn_challenge_2023_phase_1 data set (LSTM dynamics) under ../shared; skipped without it."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.example import write_example_district
from pipeline.errors import InputError
from pipeline.optimal import surrogate
from pipeline.optimal.snapshot import Rollouts
from tests.conftest import SHARED, need_shared

SCHEMA = SHARED / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2023_phase_1" / "schema.json"
WINDOW = (312, 359)  # two days after the paper's 13 training days


@pytest.fixture(scope="module")
def config():
    need_shared(SCHEMA)
    district = load_schema(SCHEMA)
    # the paper's heat-pump benchmark (rlc-b1-d_o-hp): building 1, its heat pump's action only, no outages
    return (district.with_buildings(district.building_names[:1]).with_actions(["cooling_device"])
            .with_episode([WINDOW]).without_outages().replace(central_agent=True))


def test_rollout_copies_follow_the_env_exactly(config):
    env = CityLearnEnv(config)
    env.reset(seed=0)
    actions = np.random.default_rng(1).uniform(0.0, 1.0, (30, 1))
    for a in actions[:20]:  # past the LSTM's warm-up
        env.step(a)
    roll = Rollouts(env, 3)
    roll.load(env, 10)
    for a in actions[20:]:
        roll.step(np.tile(a, (3, 1)))
        env.step(a)
    ours, theirs = env.district.building_record, roll.inner.district.building_record
    for name in ("indoor_dry_bulb_temperature", "net_electricity_consumption"):
        np.testing.assert_array_equal(np.tile(getattr(ours, name)[:, 21:31], (3, 1)), getattr(theirs, name)[:, 21:31])


def test_surrogate_mpc_beats_no_control_and_is_reproducible(config):
    first = surrogate.surrogate_mpc(CityLearnEnv(config), horizon=4, seed=3)
    again = surrogate.surrogate_mpc(CityLearnEnv(config), horizon=4, seed=3)
    ideal = surrogate.fixed_policy_value(CityLearnEnv(config), "ideal")
    zero = surrogate.fixed_policy_value(CityLearnEnv(config), "zero")
    assert first.value <= min(ideal, zero)
    assert (first.value, first.cost, first.penalty) == (again.value, again.cost, again.penalty)
    assert first.objectives == again.objectives


def test_surrogate_mpc_needs_heat_pump_actions(tmp_path):
    schema = write_example_district(tmp_path / "example", n_buildings=1, hours=48)
    with pytest.raises(InputError, match="heat pumps of LSTM buildings"):
        surrogate.surrogate_mpc(CityLearnEnv(schema))
    with pytest.raises(InputError, match="horizon"):
        surrogate.surrogate_mpc(CityLearnEnv(schema), horizon=0)


def test_the_penalty_weighs_over_cooling_three_times():
    assert surrogate.penalty(np.array([21.0, 25.0]), np.array([23.0, 23.0])).tolist() == [6.0, 2.0]
