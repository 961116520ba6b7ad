"""Forecasts for MPC: a forecast at t reads only rows <= t, the perfect one rebuilds the episode plant exactly,
the day-ahead profile and persistence are what they say, and MPC runs with each forecast (issue 29, part 3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from pipeline.controllers import run_policy
from pipeline.errors import InputError
from pipeline.optimal import forecasts
from pipeline.optimal.mpc import mpc
from pipeline.optimal.optimum import district
from pipeline.optimal.plant import plant_from_env
from pipeline.optimal.window import forecast_plant, horizon_plant

START, END, TRAIN = 72, 143, (0, 71)


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    schema = write_example_district(tmp_path_factory.mktemp("forecasts") / "example", n_buildings=2, hours=144)
    return district(schema, start=START, end=END)


@pytest.fixture()
def env(config):
    env = CityLearnEnv(config)
    env.reset(seed=0)
    return env


def _make(kind: str, data: forecasts.Data) -> forecasts.Forecaster:
    return {"persistence": lambda: forecasts.Persistence(data), "day_ahead": lambda: forecasts.DayAhead(data, TRAIN),
            "predicted": lambda: forecasts.Predicted(data, TRAIN)}[kind]()


def _future_changed(data: forecasts.Data, now: int, rng: np.random.Generator) -> forecasts.Data:
    """``data`` with every column's rows after ``now`` replaced by noise (the calendar kept)."""
    columns = {}
    for name, values in data.columns.items():
        changed = np.array(values, dtype=float, copy=True)
        changed[:, now + 1:] = rng.normal(size=changed[:, now + 1:].shape) * 100.0
        columns[name] = changed
    return dataclasses.replace(data, columns=columns)


@pytest.mark.parametrize("kind", ["persistence", "day_ahead", "predicted"])
def test_a_forecast_depends_only_on_the_past(env, kind):
    data = forecasts.data_of(env)
    rng = np.random.default_rng(0)
    for t in (0, 5, 30, 47):  # windows inside the data
        before = _make(kind, data).window(t, 24)
        after = _make(kind, _future_changed(data, data.start + t, rng)).window(t, 24)
        for name in forecasts.UNCERTAIN:
            np.testing.assert_array_equal(before[name], after[name], err_msg=f"{kind} {name} at t={t}")


def test_the_past_view_refuses_future_rows(env):
    past = forecasts.Past(forecasts.data_of(env).columns, 10)
    past.rows("non_shiftable_load", np.arange(11))
    with pytest.raises(forecasts.FutureRowError):
        past.rows("non_shiftable_load", np.array([11]))


def test_the_perfect_forecast_rebuilds_the_episode_window(env):
    full = plant_from_env(env)
    for t in (0, 20):
        window = horizon_plant(full, env, t, 24)
        rebuilt = forecast_plant(window, env, forecasts.forecaster("perfect", env).window(t, 24))
        live = ~window.outage
        np.testing.assert_allclose(rebuilt.base_net[live], window.base_net[live], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(rebuilt.carbon, window.carbon)
        for a, b in zip(rebuilt.storages, window.storages, strict=True):
            assert a.initial_energy == b.initial_energy
            for field in ("charge_max", "discharge_max", "electricity", "one_way"):
                np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=1e-12, err_msg=field)


def test_persistence_repeats_yesterday(env):
    data = forecasts.data_of(env)
    window = forecasts.Persistence(data).window(10, 30)
    now = data.start + 10
    load = data.columns["non_shiftable_load"]
    np.testing.assert_array_equal(window["non_shiftable_load"][:, :24], load[:, now + 1 - 24:now + 1])
    np.testing.assert_array_equal(window["non_shiftable_load"][:, 24:], load[:, now + 1 - 24:now + 7 - 24])


def test_day_ahead_is_the_mean_by_hour_and_day_type():
    values = np.array([[1.0, 2.0, 3.0, 5.0]])
    hour, day_type = np.array([1, 1, 2, 1]), np.array([1, 1, 1, 2])
    table = forecasts.profile(values, hour, day_type)
    assert table[0, 1, 0] == 1.5 and table[0, 1, 1] == 3.0 and table[0, 2, 0] == 5.0
    assert table[0, 2, 1] == 3.0  # never seen: the hour's mean over every day type
    assert table[0, 3, 0] == pytest.approx(8.0 / 3.0)


def test_training_rows_must_precede_the_episode(env):
    with pytest.raises(InputError, match="before the episode"):
        forecasts.forecaster("day_ahead", env, (0, START))
    with pytest.raises(InputError, match="unknown forecast"):
        forecasts.forecaster("oracle", env)
    assert forecasts.DayAhead(forecasts.data_of(env), None).train.tolist() == list(range(START))


@pytest.mark.parametrize("kind", ["persistence", "day_ahead", "predicted"])
def test_mpc_with_forecasts_beats_no_control(config, kind):
    none = run_policy(config, "no_control").objectives()["cost"]
    run = mpc(CityLearnEnv(config), "cost", horizon=12, forecast=kind, train=TRAIN)
    assert run.forecast == kind and run.objectives["cost"] < none
