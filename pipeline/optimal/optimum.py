"""The oracle as one call for the CLI: :func:`optimal` loads a schema, plans the storage with perfect foresight,
replays the plan in the environment, prints and returns the result and writes the schedule as CSV. It reports
the best plan found (the env's value, replayed) and a certified lower bound with their gap; "minimum" only where
the LP is the environment's problem (tanks only, :attr:`pipeline.optimal.oracle.Oracle.exact`).

The district is the schema's, with the heat-pump and heater actions inactive (the devices serve the data set's
ideal loads, as in the paper's storage benchmarks: :func:`pipeline.controllers.without_device_actions`) and one
episode over the data rows ``start`` .. ``end``. The environment runs with the given behaviour preset (default:
the corrected one, ``citylearn_env.settings.CORRECTED``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.config import DistrictConfig
from citylearn_env.outputs import output_file, write_output
from citylearn_env.settings import PRESETS, resolve
from pipeline.controllers import run_episode, without_device_actions
from pipeline.errors import InputError
from pipeline.optimal import objectives as obj
from pipeline.optimal.mpc import MpcRun, mpc
from pipeline.optimal.oracle import Oracle, Schedule, oracle
from pipeline.optimal.plant import BATTERY_SLOT, END_USE_SLOTS
from pipeline.optimal.replay import Replay, replay

#: a plan counts as worse than no control when its objective is above no control's by more than this [relative]
WORSE = 1e-9
#: seconds per building group ``districtgen optimal`` spends tightening the certified bound by default
#: (:mod:`pipeline.optimal.certify`)
CERTIFY_SECONDS = 60.0
UNITS = {"cost": "$", "emissions": "kg", "consumption": "kWh", "average_daily_peak": "kW"}


@dataclass(frozen=True)
class Result:
    """What :func:`optimal` found: the ``oracle`` (best plan, certified bound, objectives, schedule), the
    ``replay`` in the env (None when not replayed), the behaviour ``preset`` name, the episode's first and last data rows, the CSV written
    and how the replay followed the plan (``track``)."""

    oracle: Oracle
    replay: Replay | None
    preset: str
    start: int
    end: int
    csv: Path | None = None
    track: str = "soc"
    mpc: MpcRun | None = None
    #: no control replayed in the env, where the plan found is worse (then no control is the best plan)
    no_control: Replay | None = None

    @property
    def bound(self) -> float:
        """The certified lower bound of the objective (weighted sum for weights): no schedule the env can execute
        does better (:mod:`pipeline.optimal.relax`; -inf when not computed)."""
        return self.oracle.bound

    @property
    def value(self) -> float:
        """The best plan's objective (weighted sum for weights): the env's, replayed, or the plan's own when
        not replayed; no control's where the plan found is worse (:attr:`no_control`)."""
        if self.no_control is not None:
            return obj.weighted(self.no_control.objectives, {k: w for k, w in self.oracle.weights.items() if w})
        if self.replay is None:
            return self.oracle.value
        return obj.weighted(self.replay.objectives, {k: w for k, w in self.oracle.weights.items() if w})

    @property
    def gap(self) -> float:
        """(value - bound) / |bound| [-]: the most the best plan could still be improved on (NaN without a
        bound)."""
        bound = self.bound
        return (self.value - bound) / abs(bound) if np.isfinite(bound) and bound else float("nan")

    def summary(self) -> str:
        """A few lines: the best plan found and the certified bound with their gap, each objective of the plan
        vs no control and the env's replay, the solve."""
        o = self.oracle
        used = [k for k, w in o.weights.items() if w]
        name = used[0] if len(used) == 1 else " + ".join(f"{o.weights[k]:.4g} {k}" for k in used)
        unit = f" {UNITS[used[0]]}" if len(used) == 1 else ""
        lines = [f"oracle: best plan found for {name} over data rows {self.start}..{self.end} "
                 f"({o.schedule.net.shape[1]} steps, {o.schedule.net.shape[0]} buildings, "
                 f"{len(o.schedule.storages)} storages; env preset {self.preset})"]
        where = "in the env" if self.replay is not None else "planned, not replayed"
        if self.no_control is not None:
            found = Result(self.oracle, self.replay, self.preset, self.start, self.end).value
            lines.append(f"  warning: the plan found ({found:.6g}{unit}) is worse than no control ({self.value:.6g}"
                         f"{unit}) in the env; the best plan reported is no control (every storage idle)")
            where = "no control, in the env"
        if o.exact and self.no_control is None:
            lines.append(f"  minimum {self.value:.6g}{unit} ({where}): tanks only, the LP is the env's problem "
                         f"(relaxation {self.bound:.6g}{unit})")
        elif np.isfinite(self.bound):
            lines.append(f"  best plan {self.value:.6g}{unit} ({where}); certified lower bound {self.bound:.6g}"
                         f"{unit} (relaxation: no schedule does better); gap {self.gap * 100:.3f} %")
        else:
            lines.append(f"  best plan {self.value:.6g}{unit} ({where}); no bound computed")
        for k in obj.OBJECTIVES:
            base, best = o.baseline[k], o.objectives[k]
            change = f"{(best - base) / abs(base) * 100:+.2f} %" if base else "n/a"
            replayed = "" if self.replay is None else \
                f"; env ({self.track} replay) {self.replay.objectives[k]:.6g} ({_percent(self.replay.gap[k])})"
            lines.append(f"  {k:19s} {best:14.6g} {UNITS[k]:3s} (no control {base:.6g} {UNITS[k]}, {change}){replayed}")
        lines.append(f"  solved in {o.seconds:.2f} s ({o.iterations} LP solves of the largest group, "
                     f"{o.size[0]} columns x {o.size[1]} rows; plan vs physics {o.path_error:.1e} of capacity)")
        if self.mpc is not None:
            lines += _mpc_lines(self.mpc, o)
        if self.csv is not None:
            lines.append(f"  {'MPC actions' if self.mpc is not None else 'schedule'}: {self.csv}")
        return "\n".join(lines)


def _mpc_lines(run: MpcRun, bound: Oracle) -> list[str]:
    """MPC's objectives in the env beside the oracle's best plan and no control."""
    lines = [f"mpc: horizon {run.horizon} steps, {run.forecast} forecasts, {run.solves} LP solves, "
             f"{run.seconds:.2f} s (env values; the oracle's best plan and no control beside them)"]
    for k in obj.OBJECTIVES:
        lines.append(f"  {k:19s} {run.objectives[k]:14.6g} {UNITS[k]:3s} (oracle {bound.objectives[k]:.6g}, "
                     f"no control {bound.baseline[k]:.6g})")
    used = {k: w for k, w in bound.weights.items() if w}
    if len(used) > 1:
        lines.append(f"  weighted            {obj.weighted(run.objectives, used):14.6g}     "
                     f"(oracle {bound.value:.6g}, no control {obj.weighted(bound.baseline, used):.6g})")
    return lines


def _percent(gap: float) -> str:
    return "gap n/a" if not np.isfinite(gap) else f"gap {gap * 100:+.4f} %"


def district(schema: str | Path | Mapping[str, Any] | DistrictConfig, *, start: int | None = None,
             end: int | None = None, settings: Any = None) -> DistrictConfig:
    """The storage-planning district of ``schema``: device actions inactive, one episode over the data rows
    ``start`` .. ``end`` (inclusive; default: the schema's first explicit episode split if it lists them, else
    its simulation range)."""
    config = schema if isinstance(schema, DistrictConfig) else load_schema(schema, settings=resolve(settings))
    first, last = config.simulation_start_time_step, config.simulation_end_time_step
    splits = config.episode_time_steps
    default = splits[0] if isinstance(splits, tuple) and splits else (first, last)
    start = default[0] if start is None else int(start)
    end = default[1] if end is None else int(end)
    if not first <= start < end <= last:
        raise InputError(f"the episode {start}..{end} must lie inside the simulation range {first}..{last} "
                         "with at least two steps", column="start/end")
    return without_device_actions(config).with_episode([(start, end)]).replace(random_episode_split=False)


def preset_name(settings: Any = None) -> str:
    """The preset name of ``settings`` ("custom" for an edited one)."""
    behaviour = resolve(settings)
    return next((name for name, preset in PRESETS.items() if preset == behaviour), "custom")


def optimal(schema: str | Path | Mapping[str, Any] | DistrictConfig, objective: str | Mapping[str, float] = "cost",
            start: int | None = None, end: int | None = None, out: str | Path | None = None, *,
            settings: Any = None, seed: int = 0, normalise: bool = False, check: bool = True, track: str = "soc",
            workers: int = 1, quiet: bool = False, control: Mapping[str, Any] | None = None,
            certify: float = 0.0) -> Result:
    """The best perfect-foresight plan of ``schema``'s storage, and a certified lower bound, for ``objective`` (a name of
    :data:`pipeline.optimal.objectives.OBJECTIVES` or ``{name: weight}``; ``normalise`` divides the weights
    by the no-control values) over the data rows ``start`` .. ``end``.

    ``out``: write the schedule there as CSV (:func:`write_schedule`); ``settings``: the env's behaviour preset
    (default corrected); ``seed``: the reset seed (stochastic outages are drawn from it); ``check``: replay the
    schedule in the env and report the gap, following its states of charge (``track="soc"``) or its energies
    open loop (``"energy"``; :mod:`pipeline.optimal.replay`); ``workers``: processes solving buildings in
    parallel; ``quiet``: print nothing; ``control``: run MPC too (keywords of :func:`pipeline.optimal.mpc.mpc`:
    ``horizon``, ``forecast``, ``train``; the weights as the oracle's) and write its actions to ``out`` instead of
    the schedule; ``certify``: seconds per building for tightening the bound (:mod:`pipeline.optimal.certify`;
    0: the relaxation's own; ``districtgen optimal`` gives :data:`CERTIFY_SECONDS`). Returns a :class:`Result` (its ``value``, ``bound``, ``gap``, ``summary()``, ``mpc``).
    """
    if out is not None:
        output_file(out, column="--output")  # refused before the solve: a link at it, a built district
    config = district(schema, start=start, end=end, settings=settings)
    env = CityLearnEnv(config, settings=settings)
    env.reset(seed=seed)
    solution = oracle(env, objective, normalise=normalise, workers=workers, certify=certify)
    checked = replay(env, solution.schedule, seed=seed, track=track) if check else None
    used = {k: w for k, w in solution.weights.items() if w}
    found = obj.weighted(checked.objectives if checked is not None else solution.objectives, used)
    idle, none = None, None
    if checked is not None or found > obj.weighted(solution.baseline, used):
        idle, none = no_control(env, solution.schedule, seed=seed)
        if not found > obj.weighted(none.objectives, used) + WORSE * abs(obj.weighted(none.objectives, used)):
            idle, none = None, None
    run = mpc(env, solution.weights, seed=seed, **control) if control is not None else None
    first = config.episode_time_steps[0]
    written = (solution.schedule if idle is None else idle) if run is None else run.schedule
    csv = write_schedule(written, out, first=first[0]) if out is not None else None
    result = Result(oracle=solution, replay=checked, preset=preset_name(settings), start=first[0], end=first[1],
                    csv=csv, track=track, mpc=run, no_control=none)
    if not quiet:
        print(result.summary())
    return result


def no_control(env, schedule: Schedule, *, seed: int = 0) -> tuple[Schedule, Replay]:
    """No control (every storage action 0) run in ``env`` (reset with ``seed``): the idle schedule of ``schedule``'s
    storages (SOC and net consumption as the env reports them) and the env's objectives."""
    run_episode(env, lambda _: np.zeros(len(env.action_pairs)), seed)
    objectives = {k: float(v) for k, v in env.objectives().items() if k in obj.OBJECTIVES}
    series, names = env.series(), list(env.building_names)
    soc = np.array([series[f"{slot}_soc"][names.index(b)] for b, slot in schedule.storages]).reshape(
        schedule.soc.shape)
    capacity = np.array([_capacity(env, names.index(b), slot) for b, slot in schedule.storages])
    zero = np.zeros_like(schedule.action)
    idle = dataclasses.replace(schedule, energy=zero, action=zero.copy(), soc=soc, held=soc * capacity[:, None],
                               net=np.asarray(series["net_electricity_consumption"], dtype=float))
    return idle, Replay(objectives=objectives, gap=dict.fromkeys(obj.OBJECTIVES, 0.0), soc_gap=0.0)


def _capacity(env, building: int, slot: str) -> float:
    """The nominal capacity [kWh] of ``building``'s storage in ``slot``."""
    d = env.district
    if slot == BATTERY_SLOT:
        return float(d.battery.capacity[building])
    use = next(u for u in d.end_uses if END_USE_SLOTS[u.params.name].storage == slot)
    return float(use.params.tank.capacity[building])


def write_schedule(schedule: Schedule, path: str | Path, *, first: int = 0) -> Path:
    """Write ``schedule`` as CSV: ``time_step`` (data row, from ``first``), then per storage
    ``<building>.<slot>.action`` (the action applied at that step; 0 at the uncontrolled first step) and
    ``<building>.<slot>.soc`` (state of charge after the step). Written as a new file renamed into place, never
    through a link and never into a built district (:mod:`citylearn_env.outputs`). Returns the path."""
    import pandas as pd  # lazy: only when a file is written

    folder, name = output_file(path, column="--output")
    columns: dict[str, np.ndarray] = {"time_step": first + np.arange(schedule.action.shape[1])}
    for row, (building, slot) in enumerate(schedule.storages):
        columns[f"{building}.{slot}.action"] = schedule.action[row] + 0.0  # + 0.0: no "-0" in the file
        columns[f"{building}.{slot}.soc"] = schedule.soc[row]
    frame = pd.DataFrame(columns)
    return write_output(folder, name, lambda stream: frame.to_csv(stream, index=False, float_format="%.10g"),
                        column="--output")
