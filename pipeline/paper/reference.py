"""Reference controllers on the paper's configurations: the perfect-foresight oracle and receding-horizon MPC
(:mod:`pipeline.optimal`) run on the same test-period environment as the benchmark's RBC and SAC.

Each storage configuration (the benchmark id without its controller, e.g. ``b1-c-bess_pv``) is planned for the
paper's objective of its benchmark (:data:`ORACLE_OBJECTIVES`):

* cost (``c``, reward -max(e, 0) x price) -> the oracle's ``cost`` [$] (B1's imports, exports earn nothing);
* emissions (``e``, reward -max(e, 0) x carbon intensity) -> ``emissions`` [kg CO2e];
* peak (``p``, reward -max(P, 0) of the district) -> ``average_daily_peak`` [kW] of the district (the
  paper's objective; the LP minimises the sum of daily peaks, not the reward's hourly sum).

The oracle plans the whole test period with perfect knowledge and its schedule is replayed in the env (the
row's numbers are the env's, as for RBC and SAC; the certified lower bound is kept as ``bound``). MPC re-plans
every step over the next :data:`HORIZON` steps with perfect forecasts (:func:`pipeline.optimal.mpc.mpc`).
Every reference row also carries the configuration's no-control values (all storage idle, the same env),
the baseline of the regret table (:mod:`pipeline.paper.results`).

Not covered (:func:`unsupported`): the no-control rows (nothing to plan) and heat-pump control
(rlc-b1-d_o-hp: its discomfort-and-consumption objective moves the heat pump through the LSTM surrogate,
which the storage LP does not model). A configuration :func:`pipeline.optimal.mpc.mpc` or the oracle refuses
(an InputError) is recorded as skipped with the one-line reason (a skipped task is retried on the next run).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from citylearn_env import CityLearnEnv
from citylearn_env.errors import InputError
from pipeline.controllers import run_episode
from pipeline.paper.benchmarks import (
    Benchmark,
    RunOptions,
    benchmark_schema,
    configuration,
    episode_result,
    test_period,
)

#: the controllers of ``districtgen paper --controllers`` (default: all): the benchmarks' own, then references
CONTROLLERS = ("rbc", "sac", "oracle", "mpc")
REFERENCES = ("oracle", "mpc")
#: the paper's objective of a benchmark -> the objective the oracle and MPC minimise
ORACLE_OBJECTIVES = {"cost": "cost", "emissions": "emissions", "peak": "average_daily_peak"}
#: the paper's objective -> the run field holding its value, and its unit
OBJECTIVE_FIELDS = {"cost": ("cost", "$"), "emissions": ("emissions", "kg"), "peak": ("average_daily_peak", "kW")}
#: MPC's look-ahead [steps] (one day)
HORIZON = 24


def unsupported(b: Benchmark) -> str | None:
    """Why the oracle and MPC do not apply to benchmark ``b``'s configuration (None when they do)."""
    if b.hp:
        return ("heat-pump control (discomfort and consumption through the LSTM surrogate) is not a storage "
                "decision the LP models")
    if not (b.dhw or b.bess_pv):
        return "no storage to plan"
    if b.objective not in ORACLE_OBJECTIVES:
        return f"no oracle objective for {b.objective}"
    return None


def configurations(benchmarks: Sequence[Benchmark]) -> list[Benchmark]:
    """One benchmark per configuration of ``benchmarks`` that the references apply to (the first of each)."""
    seen: dict[str, Benchmark] = {}
    for b in benchmarks:
        seen.setdefault(configuration(b.id), b)
    return [b for b in seen.values() if unsupported(b) is None]


def run_reference(district, b: Benchmark, controller: str, *, seed: int = 0, multiplier: float = 3.0,
                  options: RunOptions | None = None) -> dict[str, Any]:
    """Run ``controller`` ("oracle" or "mpc") on ``b``'s configuration over the test period; return the row of
    :func:`pipeline.paper.benchmarks.episode_result` plus ``baseline`` (no control: {field: value}),
    ``objective`` (the oracle objective), ``bound`` (the certified lower bound; MPC: NaN), ``seconds``; or, when
    the controller refuses the configuration, {"id", "controller", "skipped": reason}."""
    reason = unsupported(b)
    if reason is not None:
        return {"id": b.id, "controller": controller, "skipped": reason}
    if controller not in REFERENCES:
        raise InputError(f"unknown reference controller {controller!r}; known: {', '.join(REFERENCES)}",
                         column="--controllers")
    options = options or RunOptions()
    started = time.perf_counter()
    env = CityLearnEnv(benchmark_schema(district, b, test_period(district), multiplier, options.roles),
                       settings=options.settings)
    baseline = no_control(env, seed)
    objective = ORACLE_OBJECTIVES[b.objective]
    try:
        actions, bound = (oracle_actions if controller == "oracle" else mpc_actions)(env, objective, seed)
    except InputError as error:
        return {"id": b.id, "controller": controller, "skipped": str(error).splitlines()[0]}
    row = episode_result(env, b, actions, seed=seed, multiplier=multiplier, controller=controller)
    return {**row, "objective": objective, "baseline": baseline, "bound": bound,
            "seconds": time.perf_counter() - started}


def no_control(env, seed: int) -> dict[str, float]:
    """B1's cost [$], emissions [kg] and the district's average daily peak [kW] of one episode of ``env`` with
    every storage idle."""
    run_episode(env, lambda _: np.zeros(env.action_space.shape), seed)
    result = env.objectives()
    return {"cost": float(result["per_building"]["cost"][0]),
            "emissions": float(result["per_building"]["emissions"][0]),
            "average_daily_peak": float(result["average_daily_peak"])}


def oracle_actions(env, objective: str, seed: int) -> tuple[list[np.ndarray], float]:
    """Plan ``env``'s episode with perfect foresight for ``objective`` and replay the plan (following its
    states of charge, :class:`pipeline.optimal.replay.SocTracker`); return the actions and the certified lower
    bound of the objective (:attr:`pipeline.optimal.oracle.Oracle.bound`: no schedule can do better)."""
    from pipeline.optimal.oracle import oracle  # highspy loads only when a reference runs
    from pipeline.optimal.replay import SocTracker

    env.reset(seed=seed)
    plan = oracle(env, objective)
    return run_episode(env, SocTracker(env, plan.schedule), seed), float(plan.bound)


def mpc_actions(env, objective: str, seed: int) -> tuple[list[np.ndarray], float]:
    """Run ``env``'s episode under MPC (:data:`HORIZON` steps, perfect forecasts) for ``objective``; return the
    actions it took and NaN (MPC has no bound)."""
    from pipeline.optimal.mpc import mpc  # highspy loads only when a reference runs

    actions: list[np.ndarray] = []
    with recorded_steps(env, actions.append):
        mpc(env, objective, horizon=HORIZON, seed=seed)
    return actions, float("nan")


class recorded_steps:  # noqa: N801 -- used as a context manager, named like one
    """Within the block, every ``env.step(action)`` also passes a copy of ``action`` to ``record`` (the
    instance's ``step`` is wrapped and restored on exit)."""

    def __init__(self, env, record: Callable[[np.ndarray], Any]):
        self.env, self.record = env, record

    def __enter__(self) -> None:
        step = self.env.step

        def recording(action, *args, **kwargs):
            self.record(np.array(action, dtype=float, copy=True))
            return step(action, *args, **kwargs)

        self.env.step = recording

    def __exit__(self, *_exc) -> None:
        del self.env.step
