"""Validation of a built district: the environment loads the schema and runs no control and the cost RBC, and
the oracle bounds the storages' schedule; the result is one typed :class:`Validation` that the report
(:mod:`pipeline.builder.report`) formats. Nothing here writes a file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from citylearn_env import load_schema
from pipeline.builder.report_figures import END_USES
from pipeline.controllers import run_policy

#: the policies a validation runs, in report order
POLICIES = ("no_control", "cost_rbc")
#: episode series the report needs (env.series() names), (B, T)
SERIES = ("net_electricity_consumption", "solar_generation", "electricity_pricing", "carbon_intensity",
          "indoor_dry_bulb_temperature", "indoor_dry_bulb_temperature_set_point", "outdoor_dry_bulb_temperature",
          *(key for key, _, _ in END_USES))
#: data columns the report needs for its calendar (env.data() names), (B, T)
CALENDAR = ("hour", "month", "day_type")
#: the oracle bounds of the report: objective (pipeline.optimal.objectives) -> (label, unit, decimals)
ORACLE_BOUNDS = {"cost": ("cost", "$", 2), "emissions": ("emissions", "kg CO2", 1),
                 "average_daily_peak": ("average daily peak", "kW", 3)}


@dataclass(frozen=True)
class PolicyRun:
    """One policy's episode: ``objectives`` (name -> district value in the objective's unit,
    :func:`citylearn_env.kpis.objectives`), ``per_building`` (name -> (B,) array), ``kpis`` (CityLearn's
    ``evaluate`` table: cost_function, value, name, level) and ``series`` (:func:`report_series`)."""

    objectives: Mapping[str, float]
    per_building: Mapping[str, np.ndarray]
    kpis: pd.DataFrame
    series: Mapping[str, np.ndarray]


@dataclass(frozen=True)
class OracleBound:
    """The oracle on one objective [the objective's unit]: the best plan found (its value), the LP's no-control
    value and the certified lower bound (no schedule of the storages can do better; -inf: not computed)."""

    plan: float
    no_control: float
    lower_bound: float = float("-inf")


@dataclass(frozen=True)
class OracleBounds:
    """The perfect-foresight oracle (:func:`oracle_bounds`): objective -> :class:`OracleBound` over the
    ``storages`` scheduled, or, where the oracle does not apply, empty with the one-line ``reason``."""

    bounds: Mapping[str, OracleBound] = field(default_factory=dict)
    storages: int = 0
    reason: str | None = None


@dataclass(frozen=True)
class Validation:
    """What validating a district found: each policy's run (policy -> :class:`PolicyRun`, in
    :data:`POLICIES` order) and the oracle's bounds."""

    runs: Mapping[str, PolicyRun]
    oracle: OracleBounds


def validate_district(schema_path: str | Path) -> Validation:
    """Load the schema once, run no control and the cost RBC on it and bound the storage with the oracle."""
    district = load_schema(schema_path)
    runs, envs = {}, {}
    for policy in POLICIES:
        env = envs[policy] = run_policy(district, policy)
        kpis = env.evaluate()
        objectives = env.objectives()
        runs[policy] = PolicyRun(objectives={k: v for k, v in objectives.items() if np.isscalar(v)},
                                 per_building=objectives["per_building"], kpis=kpis, series=report_series(env))
    return Validation(runs, oracle_bounds(district, env=envs["no_control"]))


def report_series(env: Any) -> dict[str, np.ndarray]:
    """What the report needs of a finished episode of ``env`` (a CityLearnEnv): name -> (B, T) arrays."""
    series = env.series()
    return {**{k: series[k] for k in SERIES}, **{k: env.data(k) for k in CALENDAR}}


def oracle_bounds(district: Any, seed: int = 0, env: Any = None) -> OracleBounds:
    """The perfect-foresight optimum of ``district``'s storage (a loaded DistrictConfig) for each objective of
    :data:`ORACLE_BOUNDS`, over the episode the report's policies run (heat pumps serving the ideal load), or,
    when the oracle does not apply, the reason in one line. ``env``: the report's no-control env of
    ``district`` (reset and reused; default: a new one). The cost and emission LPs are per building; the peak
    is one LP for the district, the slowest (one-month 6-building default district on a shared 2-core AMD
    EPYC: cost 0.5 s, emissions 0.5 s, peak 3.1 s)."""
    from citylearn_env import CityLearnEnv
    from pipeline.controllers import without_device_actions
    from pipeline.errors import InputError
    from pipeline.optimal.oracle import oracle
    from pipeline.optimal.solver import SolveError

    try:
        env = env if env is not None else CityLearnEnv(without_device_actions(district))
        env.reset(seed=seed)
        solved = {k: oracle(env, k) for k in ORACLE_BOUNDS}
    except (InputError, SolveError) as error:
        return OracleBounds(reason=str(error).splitlines()[0])
    storages = len(next(iter(solved.values())).schedule.storages)
    return OracleBounds({k: OracleBound(o.value, o.baseline[k], o.bound) for k, o in solved.items()}, storages)
