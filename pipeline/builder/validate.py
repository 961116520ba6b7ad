"""Validation of a built district: the environment loads the schema and runs no control and the cost RBC, and
the oracle bounds the storages' schedule; the result is one typed :class:`Validation` that the report
(:mod:`pipeline.builder.report`) formats. Nothing here writes a file.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from citylearn_env import load_schema
from citylearn_env.settings import resolve as resolve_settings
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


#: buildings per validation chunk: a district of more is validated in chunks of this many buildings on the
#: build's runner (each chunk one environment; the district's KPIs from the chunks' summed series)
CHUNK_BUILDINGS = 64
#: building-steps (buildings x time steps) up to which the build runs the oracle: cost and emissions (one LP
#: per building, split over the chunks) ...
ORACLE_BUILDING_STEPS = 80_000
#: ... and the district peak (one joint LP), only for a district of one chunk
PEAK_ORACLE_BUILDING_STEPS = 50_000
#: buildings whose load and temperature figures the report draws (the first ones of the district)
FIGURE_BUILDINGS = 24


@dataclass(frozen=True)
class PolicyRun:
    """One policy's episode: ``objectives`` (name -> district value in the objective's unit,
    :func:`citylearn_env.kpis.objectives`), ``per_building`` (name -> (B,) array), ``kpis`` (CityLearn's
    ``evaluate`` table: cost_function, value, name, level), ``series`` (:func:`report_series`, (F, T) arrays
    of the F buildings ``series_buildings``: the report's figures) and ``district_net`` (T,), the district's
    net electricity consumption [kWh per step]."""

    objectives: Mapping[str, float]
    per_building: Mapping[str, np.ndarray]
    kpis: pd.DataFrame
    series: Mapping[str, np.ndarray]
    series_buildings: tuple[str, ...]
    district_net: np.ndarray


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
    ``storages`` scheduled, or, where the oracle does not apply, empty with the one-line ``reason``;
    ``skipped``: objective -> why the build did not run it (the district's size)."""

    bounds: Mapping[str, OracleBound] = field(default_factory=dict)
    storages: int = 0
    reason: str | None = None
    skipped: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Validation:
    """What validating a district found: each policy's run (policy -> :class:`PolicyRun`, in
    :data:`POLICIES` order) and the oracle's bounds."""

    runs: Mapping[str, PolicyRun]
    oracle: OracleBounds


@dataclass(frozen=True)
class ChunkRun:
    """One policy over a chunk of buildings (:func:`validate_chunk`): per-building objectives and KPI rows,
    the chunk's sums (T,) of every net-consumption series (the district KPIs' input) and the report series
    of its figure buildings."""

    per_building: Mapping[str, np.ndarray]
    kpi_rows: list[dict]
    sums: Mapping[str, np.ndarray]
    series: Mapping[str, np.ndarray]


@dataclass(frozen=True)
class ChunkValidation:
    """A chunk's validation: its buildings, their dynamics flags, each policy's :class:`ChunkRun`, the figure
    buildings among them and the oracle over the chunk's storages."""

    names: tuple[str, ...]
    dynamics: tuple[bool, ...]
    runs: Mapping[str, ChunkRun]
    figures: tuple[str, ...]
    oracle: OracleBounds


def validate_district(schema_path: str | Path, runner: Any = None,
                      chunk_buildings: int = CHUNK_BUILDINGS) -> Validation:
    """Load the schema, run no control and the cost RBC on it and bound the storage with the oracle.

    A district of up to ``chunk_buildings`` buildings runs in one environment, here; a larger one in
    chunks of that many on ``runner`` (default: in this process), one chunk in memory at a time, the
    district's KPIs and objectives from the chunks' sums (:func:`combine_chunks`). The oracle runs within the
    budgets :data:`ORACLE_BUILDING_STEPS` and :data:`PEAK_ORACLE_BUILDING_STEPS` (the report names what it
    skipped and how to run it)."""
    from pipeline.runners import InProcessRunner

    schema_path = Path(schema_path)
    raw = json.loads(schema_path.read_text())
    names = [n for n, spec in raw["buildings"].items() if spec.get("include", True)]
    steps = schema_steps(raw)
    objectives = oracle_objectives(len(names), steps, one_chunk=len(names) <= chunk_buildings)
    figures = tuple(names[:FIGURE_BUILDINGS])
    if len(names) <= chunk_buildings:
        return combine_chunks([validate_chunk(schema_path, tuple(names), figures, objectives.run)],
                              objectives.skipped)
    chunks = {f"chunk{k // chunk_buildings + 1}": tuple(names[k:k + chunk_buildings])
              for k in range(0, len(names), chunk_buildings)}
    runner = runner or InProcessRunner()
    done = runner.map("validate", validate_chunk, {
        label: (schema_path, chunk, tuple(n for n in chunk if n in figures), objectives.run)
        for label, chunk in chunks.items()})
    return combine_chunks(list(done.values()), objectives.skipped)


@dataclass(frozen=True)
class OracleObjectives:
    """Which oracle objectives the build runs (``run``) and why it skips the others (``skipped``)."""

    run: tuple[str, ...]
    skipped: Mapping[str, str]


def oracle_objectives(buildings: int, steps: int, one_chunk: bool = True) -> OracleObjectives:
    """The oracle objectives a district of ``buildings`` x ``steps`` gets in its build: cost and emissions up
    to :data:`ORACLE_BUILDING_STEPS`, the joint peak LP up to :data:`PEAK_ORACLE_BUILDING_STEPS` and only
    when validated in ``one_chunk``; the reason for each one skipped."""
    size = buildings * steps
    run, skipped = [], {}
    for key in ORACLE_BOUNDS:
        peak = key == "average_daily_peak"
        limit = PEAK_ORACLE_BUILDING_STEPS if peak else ORACLE_BUILDING_STEPS
        if size <= limit and (one_chunk or not peak):
            run.append(key)
        else:
            skipped[key] = (f"not run in the build: {buildings} buildings x {steps} steps is above its budget "
                            f"({limit:,} building-steps{', one joint LP over one validation chunk' if peak else ''}); "
                            f"run `districtgen optimal DISTRICT --objective {key}`")
    return OracleObjectives(tuple(run), skipped)


def schema_steps(raw: Mapping[str, Any]) -> int:
    """The episode's time steps of a parsed schema (``simulation_start/end_time_step``, inclusive)."""
    return int(raw.get("simulation_end_time_step", 0)) - int(raw.get("simulation_start_time_step", 0)) + 1


def validate_chunk(schema_path: Path, names: tuple[str, ...], figures: tuple[str, ...],
                   objectives: tuple[str, ...]) -> ChunkValidation:
    """Validate the buildings ``names`` of the schema at ``schema_path`` in one environment (the others left
    out): both policies, their KPI rows and sums, the report series of ``figures`` and the oracle on
    ``objectives`` (cost and emissions are per building; the peak is the chunk's, so only for one chunk)."""
    from citylearn_env.kpis import NET
    from citylearn_env.paths import dataset_folder

    raw = json.loads(Path(schema_path).read_text())
    folder = dataset_folder(raw.get("root_directory"), Path(schema_path).resolve().parent)  # confined, as a file
    raw["root_directory"] = str(folder.root)
    for name, spec in raw["buildings"].items():
        spec["include"] = name in names and spec.get("include", True)
    district = load_schema(raw)
    rows = [names.index(n) for n in figures]
    runs, envs = {}, {}
    for policy in POLICIES:
        env = envs[policy] = run_policy(district, policy)
        table = env.evaluate()
        objectives_run = env.objectives()
        building = table[table["level"] == "building"]
        kpi_rows = [dict(zip(group["cost_function"], group["value"], strict=True))
                    for _, group in building.groupby("name", sort=False)]
        series = env.series()
        report = {k: v[rows] for k, v in report_series(env).items()}
        runs[policy] = ChunkRun(objectives_run["per_building"], kpi_rows,
                                {k: v.sum(axis=0) for k, v in series.items() if k.startswith(NET)}, report)
    oracle = (oracle_bounds(district, env=envs["no_control"], objectives=objectives) if objectives
              else OracleBounds())
    return ChunkValidation(tuple(names), tuple(bool(d) for d in envs["no_control"].district.dynamics), runs,
                           figures, oracle)


def combine_chunks(chunks: list[ChunkValidation], skipped: Mapping[str, str]) -> Validation:
    """The district's :class:`Validation` from its chunks (in building order): per-building values joined,
    district KPIs (:func:`citylearn_env.kpis.district_values`) and the average daily peak on the summed
    series, the oracle's values summed over the chunks (cost and emissions are sums over buildings)."""
    from citylearn_env import kpis

    names = [n for c in chunks for n in c.names]
    dynamics = [d for c in chunks for d in c.dynamics]
    figures = tuple(n for c in chunks for n in c.figures)
    settings = resolve_settings(None)
    runs = {}
    for policy in POLICIES:
        parts = [c.runs[policy] for c in chunks]
        sums = {k: sum(p.sums[k] for p in parts)[None, :] for k in parts[0].sums}
        rows = [r for p in parts for r in p.kpi_rows]
        district = kpis.district_values(sums, dynamics=dynamics[:1], settings=settings)
        per_building = {k: np.concatenate([p.per_building[k] for p in parts]) for k in parts[0].per_building}
        net = sums[kpis.NET][0]
        objectives = {k: float(v.sum()) for k, v in per_building.items()}
        objectives["average_daily_peak"] = kpis.average_daily_peak(net)
        series = {k: np.concatenate([p.series[k] for p in parts]) for k in parts[0].series}
        runs[policy] = PolicyRun(objectives, per_building, kpis.kpi_frame(rows, names, district), series, figures,
                                 net)
    return Validation(runs, combine_oracles([c.oracle for c in chunks], skipped))


def combine_oracles(parts: list[OracleBounds], skipped: Mapping[str, str]) -> OracleBounds:
    """The district's oracle from its chunks': the first reason, else each objective's values summed."""
    reason = next((p.reason for p in parts if p.reason is not None), None)
    if reason is not None:
        return OracleBounds(reason=reason, skipped=skipped)
    keys = [k for k in ORACLE_BOUNDS if all(k in p.bounds for p in parts)]
    bounds = {k: OracleBound(sum(p.bounds[k].plan for p in parts), sum(p.bounds[k].no_control for p in parts),
                             sum(p.bounds[k].lower_bound for p in parts)) for k in keys}
    return OracleBounds(bounds, sum(p.storages for p in parts), skipped=skipped)


def report_series(env: Any) -> dict[str, np.ndarray]:
    """What the report needs of a finished episode of ``env`` (a CityLearnEnv): name -> (B, T) arrays."""
    series = env.series()
    return {**{k: series[k] for k in SERIES}, **{k: env.data(k) for k in CALENDAR}}


def oracle_bounds(district: Any, seed: int = 0, env: Any = None,
                  objectives: tuple[str, ...] = tuple(ORACLE_BOUNDS)) -> OracleBounds:
    """The perfect-foresight optimum of ``district``'s storage (a loaded DistrictConfig) for each objective of
    :data:`ORACLE_BOUNDS`, over the episode the report's policies run (heat pumps serving the ideal load), or,
    when the oracle does not apply, the reason in one line; ``objectives``: those to solve. ``env``: the report's no-control env of
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
        solved = {k: oracle(env, k) for k in objectives}
    except (InputError, SolveError) as error:
        return OracleBounds(reason=str(error).splitlines()[0])
    storages = len(next(iter(solved.values())).schedule.storages)
    return OracleBounds({k: OracleBound(o.value, o.baseline[k], o.bound) for k, o in solved.items()}, storages)
