"""Receding-horizon model-predictive control over the oracle's LP builder (issue 29, part 3): at every step,
plan the next ``horizon`` steps from the env's *current* storage states (the LP of :mod:`pipeline.optimal.lp`
on a window of the episode's plant), apply the plan's first action, repeat.

With ``forecast="perfect"`` the plan sees the episode's true series over the horizon (nothing beyond it), so
the gap between MPC and the oracle is the value of looking further than the horizon. The other forecasts
(:mod:`pipeline.optimal.forecasts`: persistence, day-ahead profiles, the data set's predicted columns) are what
a controller could know at t; the window's loads, PV, carbon intensity and COPs are rebuilt from them
(:func:`pipeline.optimal.window.forecast_plant`). The states come from the env each step, so model and
forecast errors never accumulate in the state.

Objectives: cost, emissions, consumption, the average daily peak and weighted sums. For the peak, the window's
days are the episode's (blocks of 24 steps from its start): the window starts t mod 24 steps into its first
day, whose peak in the LP is at least the district's running peak of that day so far (the env's nets), and
each day's peak weighs 24 / T of the episode (:func:`pipeline.optimal.window.horizon_plant`); a day the horizon
reaches only in part is planned on the part it sees.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.controllers import run_episode
from pipeline.errors import InputError
from pipeline.optimal import forecasts
from pipeline.optimal import objectives as obj
from pipeline.optimal.oracle import Schedule, solve_plant, storage_keys
from pipeline.optimal.plant import Plant, plant_from_env
from pipeline.optimal.replay import positions, schedule_actions
from pipeline.optimal.window import forecast_plant, horizon_plant

#: LP solves per step: the nominal efficiencies, then once refreshed (the closed loop corrects the rest)
SOLVES_PER_STEP = 2


@dataclass(frozen=True)
class MpcRun:
    """An MPC episode: the env's ``objectives``, the ``horizon`` [steps], LP ``solves``, wall ``seconds``, the
    ``forecast`` used and the ``schedule`` it applied (the actions sent to the env and the states of charge and
    nets the env reported, in the oracle's layout: :func:`pipeline.optimal.optimum.write_schedule` writes it)."""

    objectives: Mapping[str, float]
    horizon: int
    solves: int
    seconds: float
    forecast: str = "perfect"
    schedule: Schedule | None = None


def mpc(env, objective: str | Mapping[str, float] = "cost", *, horizon: int = 24, seed: int = 0,
        solves_per_step: int = SOLVES_PER_STEP, forecast: str = "perfect",
        train: tuple[int, int] | None = None) -> MpcRun:
    """Run one episode of ``env`` (reset with ``seed``) under MPC over ``horizon`` steps; return the env's
    objectives. ``forecast``: how the uncertain series are known (:data:`forecasts.FORECASTS`: "perfect",
    "persistence", "day_ahead", "predicted"); ``train``: inclusive data rows the day-ahead profiles are learned
    from (default: every row before the episode)."""
    weights = obj.weights_of(objective)
    if horizon < 1:
        raise InputError(f"the horizon must be at least 1 step, got {horizon}", column="horizon")
    began = time.perf_counter()
    env.reset(seed=seed)
    full = plant_from_env(env)
    seer = forecasts.forecaster(forecast, env, train)
    count = 0
    applied: list[np.ndarray] = []

    def act(_observation) -> np.ndarray:
        nonlocal count
        t = env.t
        length = min(horizon, env.episode_length - 1 - t)
        window = horizon_plant(full, env, t, length)
        if seer.name != "perfect":
            window = forecast_plant(window, env, seer.window(t, length))
        plan = solve_plant(window, weights, solves=solves_per_step, joint=True, bound=False, polishes=0)
        count += plan.iterations
        applied.append(schedule_actions(env, plan.schedule)[0])
        return applied[-1]

    run_episode(env, act, seed)
    values = {k: float(v) for k, v in env.objectives().items() if k in obj.OBJECTIVES}
    return MpcRun(objectives=values, horizon=horizon, solves=count, seconds=time.perf_counter() - began,
                  forecast=forecast, schedule=applied_schedule(env, full, applied))


def applied_schedule(env, full: Plant, applied: list[np.ndarray]) -> Schedule:
    """What an episode of ``env`` (just run) applied to the storages of ``full`` (its episode plant): row k of
    ``applied`` (action vectors, the env's layout) controlled step k + 1; energies = action x scale [kWh,
    device side, as requested], held energies and states of charge as the env reports them, nets (B, T) [kWh]."""
    keys = storage_keys(full)
    scale = np.array([s.action_scale for s in full.storages])
    action = np.zeros((len(keys), env.episode_length))
    if applied:
        vectors = np.stack(applied)
        for j, row in positions(env, keys):
            action[row, 1:vectors.shape[0] + 1] = vectors[:, j]
    series, names = env.series(), list(env.building_names)
    soc = np.stack([series[f"{slot}_soc"][names.index(b)] for b, slot in keys]) if keys else action.copy()
    capacity = np.array([s.capacity for s in full.storages])
    net = np.asarray(env.district.building_record.net_electricity_consumption, dtype=float)[:, :env.episode_length]
    return Schedule(storages=keys, energy=action * scale[:, None], held=soc * capacity[:, None], action=action,
                    soc=soc, net=net.copy(), scale=scale)
