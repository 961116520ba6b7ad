"""Receding-horizon MPC with perfect forecasts over the oracle's LP: it runs closed loop in the env, never beats
the perfect-foresight oracle of the whole episode (up to the oracle's own tolerance) and beats no control."""

from __future__ import annotations

import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from pipeline.controllers import run_policy
from pipeline.errors import InputError
from pipeline.optimal.mpc import mpc
from pipeline.optimal.optimum import district, optimal


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    schema = write_example_district(tmp_path_factory.mktemp("mpc") / "example", n_buildings=2, hours=72)
    return district(schema)


def test_mpc_between_the_oracle_and_no_control(config):
    best = optimal(config, "cost", quiet=True).replay.objectives["cost"]
    none = run_policy(config, "no_control").objectives()["cost"]
    run = mpc(CityLearnEnv(config), "cost", horizon=12)
    assert best * (1 - 1e-4) <= run.objectives["cost"] < none
    assert run.horizon == 12 and run.solves >= 71  # at least one LP per controlled step


def test_a_longer_horizon_is_not_worse(config):
    short = mpc(CityLearnEnv(config), "cost", horizon=2).objectives["cost"]
    long = mpc(CityLearnEnv(config), "cost", horizon=24).objectives["cost"]
    assert long <= short * (1 + 1e-4)


def test_mpc_refuses_a_bad_horizon(config):
    with pytest.raises(InputError, match="at least 1 step"):
        mpc(CityLearnEnv(config), "cost", horizon=0)
