"""MPC for the average daily peak: the window's days are the episode's and the day already run carries its
running peak into the LP (issue 29, part 3)."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from pipeline.controllers import run_policy
from pipeline.optimal import lp
from pipeline.optimal import objectives as obj
from pipeline.optimal.mpc import mpc
from pipeline.optimal.optimum import district, optimal
from pipeline.optimal.plant import plant_from_env
from pipeline.optimal.window import horizon_plant

PEAK = obj.PEAK


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    schema = write_example_district(tmp_path_factory.mktemp("peak") / "example", n_buildings=2, hours=72)
    return district(schema)


def test_mpc_peak_between_the_oracle_and_no_control(config):
    best = optimal(config, PEAK, quiet=True).replay.objectives[PEAK]
    none = run_policy(config, "no_control").objectives()[PEAK]
    run = mpc(CityLearnEnv(config), PEAK, horizon=12)
    assert best * (1 - 1e-4) <= run.objectives[PEAK] < none


def test_a_window_inside_a_day_carries_its_running_peak(config):
    env = CityLearnEnv(config)
    env.reset(seed=0)
    for _ in range(30):
        env.step(np.zeros(env.action_space.shape))
    window = horizon_plant(plant_from_env(env), env, env.t, 24)
    net = env.district.building_record.net_electricity_consumption
    assert window.day_offset == 30 % 24 and window.episode_steps == env.episode_length
    assert window.peak_floor == pytest.approx(net[:, 24:31].sum(axis=0).max())
    program = lp.build(window, obj.weights_of(PEAK))
    cols = program.columns
    assert cols.days == 2  # steps 30..54: the rest of day 1 and day 2 up to step 54 (day 2 ends at 71)
    assert program.lower[cols.peak] >= window.peak_floor
    assert program.cost[cols.peak] == pytest.approx(obj.DAY_STEPS / env.episode_length)
