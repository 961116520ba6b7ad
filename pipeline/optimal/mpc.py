"""Receding-horizon model-predictive control with perfect forecasts, over the oracle's LP builder (issue 29,
part 3): at every step, plan the next ``horizon`` steps from the env's *current* storage states (the LP of
:mod:`pipeline.optimal.lp` on a window of the episode's plant), apply the plan's first action, repeat.

Forecasts are the episode's true series (perfect foresight over the horizon, nothing beyond it), so the gap
between MPC and the oracle is the value of looking further than the horizon; the gap between MPC and a
learned controller is the value of perfect short-term forecasts. The states come from the env each step, so
model errors never accumulate. Objectives: cost, emissions, consumption and their weighted sums (the daily
peak needs the part of the day already run and days aligned with the episode's: not supported yet).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.controllers import run_episode
from pipeline.errors import InputError
from pipeline.optimal import objectives as obj
from pipeline.optimal.oracle import solve_plant
from pipeline.optimal.plant import Plant, Storage, plant_from_env
from pipeline.optimal.replay import schedule_actions

#: LP solves per step: the nominal efficiencies, then once refreshed (the closed loop corrects the rest)
SOLVES_PER_STEP = 2


@dataclass(frozen=True)
class MpcRun:
    """An MPC episode: the env's ``objectives``, the ``horizon`` [steps], LP ``solves`` and wall ``seconds``."""

    objectives: Mapping[str, float]
    horizon: int
    solves: int
    seconds: float


def mpc(env, objective: str | Mapping[str, float] = "cost", *, horizon: int = 24, seed: int = 0,
        solves_per_step: int = SOLVES_PER_STEP) -> MpcRun:
    """Run one episode of ``env`` (reset with ``seed``) under MPC with a ``horizon``-step perfect forecast;
    return the env's objectives."""
    weights = obj.weights_of(objective)
    if weights[obj.PEAK]:
        raise InputError("MPC plans cost, emissions, consumption and their sums; the daily peak is not supported "
                         "yet", column="objective")
    if horizon < 1:
        raise InputError(f"the horizon must be at least 1 step, got {horizon}", column="horizon")
    began = time.perf_counter()
    env.reset(seed=seed)
    full = plant_from_env(env)
    count = 0

    def act(_observation) -> np.ndarray:
        nonlocal count
        t = env.t
        window = horizon_plant(full, env, t, min(horizon, env.episode_length - 1 - t))
        plan = solve_plant(window, weights, solves=solves_per_step, joint=True)
        count += plan.iterations
        return schedule_actions(env, plan.schedule)[0]

    run_episode(env, act, seed)
    values = {k: float(v) for k, v in env.objectives().items() if k in obj.OBJECTIVES}
    return MpcRun(objectives=values, horizon=horizon, solves=count, seconds=time.perf_counter() - began)


def horizon_plant(full: Plant, env, t: int, length: int) -> Plant:
    """The episode plant ``full`` over steps t .. t + ``length`` (step t is the present, already run), its
    storages starting from the env's states at t."""
    stop = t + length + 1
    return dataclasses.replace(
        full, base_net=full.base_net[:, t:stop], price=full.price[:, t:stop], carbon=full.carbon[:, t:stop],
        outage=full.outage[:, t:stop], surplus=full.surplus[:, t:stop],
        storages=tuple(_window(s, env, t, length) for s in full.storages))


def _window(s: Storage, env, t: int, length: int) -> Storage:
    """Storage ``s`` over the controlled steps t + 1 .. t + ``length``, from its state in the env at t."""
    cut = slice(t, t + length)
    d = env.district
    if s.battery is None:
        end_use = s.slot.removesuffix("_storage")
        soc = float(d.end_use(end_use).record.storage_soc[s.building, t])
        return dataclasses.replace(s, initial_energy=soc * s.capacity, one_way=s.one_way[cut],
                                   electricity=s.electricity[cut], charge_max=s.charge_max[cut],
                                   discharge_max=s.discharge_max[cut])
    r = d.battery_record
    efficiency, capacity = float(r.efficiency[s.building, t]), float(r.capacity[s.building, t])
    one_way = s.one_way[cut]
    terms = dataclasses.replace(s.battery, one_way_prev=np.concatenate([[np.sqrt(efficiency)], one_way[:-1]]),
                                usable_capacity=np.full(length, capacity), initial_efficiency=efficiency)
    return dataclasses.replace(s, initial_energy=float(r.soc[s.building, t]) * s.capacity, one_way=one_way,
                               electricity=s.electricity[cut], charge_max=s.charge_max[cut],
                               discharge_max=s.discharge_max[cut], battery=terms)
