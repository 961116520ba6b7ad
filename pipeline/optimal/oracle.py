"""The perfect-foresight optimum of a district's storage over one episode: solve the LP of
:mod:`pipeline.optimal.lp`, make its battery efficiencies consistent with the schedule, return the schedule.

The env's battery physics that is not linear, and how the oracle makes the LP agree with it:

* round-trip efficiency = power-efficiency curve at |energy| / nominal power, per step. The LP takes one fixed
  efficiency per step (a secant through 0: stored = sqrt(efficiency) x charge). Solve 1 uses the battery's
  nominal efficiency; after every solve the efficiencies (and the previous-step efficiency of the depth-of-
  discharge limit) are recomputed from the schedule's own energies and the LP is solved again. The curve is
  not concave (the default one rises from 0.83 to 0.9 and falls to 0.85), so plain re-solving can flip between
  two plans; from solve :data:`FREE_SOLVES` + 1 on each battery step is kept within a trust radius of the last
  plan that shrinks by :data:`TRUST_SHRINK` per solve, which makes the efficiencies converge. It stops when the
  plan follows the env's physics within :data:`PATH_TOLERANCE` of capacity (``Oracle.path_error``).
* capacity fade (capacity_loss x C x |energy| / (2 x usable capacity) per step): the usable capacity path is
  recomputed from the schedule's throughput in the same loop.
* the capacity-power curve (power limit falling with the state of charge) is linear in E per segment and is
  exact in the LP for a concave curve such as the default one (plant.curve_lines).

Without the peak objective the buildings do not interact and each one is solved on its own (same optimum,
smaller LPs; each building's first solve starts from the previous building's basis when the LPs have the
same shape, and ``workers`` > 1 solves chunks of buildings in parallel processes); with it the district is
one LP -- or, for the peak alone above :data:`LOCKSTEP_SIZE` storage-steps, one LP of the batteries merged in
lockstep (:mod:`pipeline.optimal.lockstep`; not exact: with a power-dependent efficiency, batteries at
different powers can beat the same batteries in lockstep, 1.6 % on the peak of citylearn_challenge_2022_phase_all's
month; the bound says how much at most). Every solve after the first of a group restarts from
the previous basis.

What the result says: ``value`` is the best plan found -- the fixed point, then polished on the batteries'
marginal efficiencies (:mod:`pipeline.optimal.polish`) -- a plan the env executes as planned (replay gaps of
at most 1e-3 % on every upstream dataset). With batteries it is a local optimum of a non-convex problem; the
plant also restricts three rare situations (no tank discharge where the heater or heat pump is undersized;
charging during an outage only from the PV surplus; a battery decays below its depth-of-discharge floor only
through a penalised slack). ``bound`` is certified: the optimum of a relaxation (:mod:`pipeline.optimal.relax`)
that no executable schedule beats; ``gap`` is how far apart they are. With tanks only and none of the
restrictions acting, the LP is the env's problem and ``exact`` is true. For the peak alone, batteries that are
scaled copies run in lockstep above :data:`LOCKSTEP_SIZE` storage-steps (:mod:`pipeline.optimal.lockstep`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pipeline.optimal import checks, relax
from pipeline.optimal import lockstep as steps_lockstep
from pipeline.optimal import objectives as obj
from pipeline.optimal.certify import block_bound
from pipeline.optimal.lp import build
from pipeline.optimal.plant import Plant, battery_path, path_error, plant_from_env, trust
from pipeline.optimal.polish import POLISH_SOLVES, polish
from pipeline.optimal.solver import SolveError, solve

#: stop refreshing the battery efficiencies when the planned path is this close to the env's [fraction of capacity]
PATH_TOLERANCE = 1e-4
#: solves without a trust region; later ones keep each battery step within a radius of the last plan
FREE_SOLVES = 2
#: the first trust radius [fraction of nominal power], and the factor it shrinks by at every later solve
TRUST_RADIUS = 0.1
TRUST_SHRINK = 0.1
MAX_ITERATIONS = 12
#: the LP's largest objective coefficient is kept in this range by scaling the weights (:func:`lp_scale`)
COEFFICIENT_RANGE = (1e-3, 1e3)
#: the polish's time budget: this many times the plan's own wall time (and at least POLISH_MIN_SECONDS)
POLISH_BUDGET = 1.0
POLISH_MIN_SECONDS = 1.0
#: storages x steps above which the peak's district LP merges batteries in lockstep by default (17 x 720 stays
#: one joint LP; 100 x 720 and 17 x 8,760 merge)
LOCKSTEP_SIZE = 20_000


@dataclass(frozen=True, eq=False)
class Schedule:
    """The planned operation of every controllable storage, (S, T) over the episode's T steps: ``energy``
    [kWh, device side, > 0 charging; 0 at step 0], ``held`` [kWh after the step], ``action`` [the env's action:
    energy / action scale], ``soc`` [-]; ``storages`` (building name, slot) per row; ``net`` (B, T) [kWh]: each
    building's planned net consumption; ``scale`` (S,) [kWh per unit of action]."""

    storages: tuple[tuple[str, str], ...]
    energy: np.ndarray
    held: np.ndarray
    action: np.ndarray
    soc: np.ndarray
    net: np.ndarray
    scale: np.ndarray


@dataclass(frozen=True, eq=False)
class Oracle:
    """An oracle solution. ``weights``: the objective; ``value``: the weighted objective of the schedule;
    ``objectives`` / ``baseline``: the four objectives of the schedule / of no control (storages idle);
    ``iterations``: LP solves of the building group that needed most; ``path_error``: how far the planned
    battery paths are from the env's physics at their own powers [fraction of capacity]; ``solve_seconds``:
    HiGHS time summed over the LPs; ``seconds``: the whole oracle (wall); ``size``: (columns, rows, non-zeros)
    of the largest LP; ``bound``: the certified lower bound (the relaxation's optimum, :mod:`pipeline.optimal.relax`:
    no schedule the env can execute has a lower weighted objective; -inf when not computed); ``exact``: the LP is
    the env's problem itself (tanks only, no restriction acting), so ``value`` is the minimum."""

    weights: Mapping[str, float]
    value: float
    objectives: Mapping[str, float]
    baseline: Mapping[str, float]
    schedule: Schedule
    iterations: int
    path_error: float
    solve_seconds: float
    seconds: float
    size: tuple[int, int, int]
    bound: float = float("-inf")
    exact: bool = False

    @property
    def gap(self) -> float:
        """(value - bound) / |bound| [-]: how much better than the plan any schedule could still be (NaN without
        a bound or where it is 0)."""
        if not np.isfinite(self.bound) or self.bound == 0:
            return float("nan")
        return (self.value - self.bound) / abs(self.bound)


@dataclass(frozen=True, eq=False)
class Group:
    """Solved storages of one group of buildings: device-side and held energies (S, n) in the group plant's
    storage order, the number of solves, the plan's distance to the physics [fraction of capacity], HiGHS
    seconds, the LP size and the first solve's basis (a start for the next group of the same shape)."""

    plant: Plant
    energy: np.ndarray
    held: np.ndarray
    iterations: int
    path_error: float
    solve_seconds: float
    size: tuple[int, int, int]
    first_basis: Any = None
    bound: float = float("-inf")


def oracle(env, objective: str | Mapping[str, float] = "cost", *, normalise: bool = False,
           workers: int = 1, runner: Any = None, bound: bool = True, certify: float = 0.0) -> Oracle:
    """The oracle of ``env``'s current episode (call ``env.reset(seed=...)`` first: the outage signal of that
    reset is the one planned for). ``objective``: a name of :data:`objectives.OBJECTIVES` or weights;
    ``normalise``: divide the weights by the no-control values (a sum of ratios); ``workers``: processes
    solving buildings in parallel (objectives without the peak only); ``runner``: a
    :class:`pipeline.runners.Runner` mapping the per-building groups instead (e.g. the build's); ``bound``:
    solve the relaxations for the certified lower bound too; ``certify``: seconds per building group for
    tightening that bound with the power-range choice (:mod:`pipeline.optimal.certify`; 0: the relaxation's own
    bound). Weights outside the range of :func:`pipeline.optimal.checks.check_weights` are refused."""
    checks.check_weights(obj.weights_of(objective))
    return solve_plant(plant_from_env(env), objective, normalise=normalise, workers=workers, runner=runner,
                       bound=bound, certify=certify)


def solve_plant(plant: Plant, objective: str | Mapping[str, float] = "cost", *, normalise: bool = False,
                workers: int = 1, solver: str = "choose", solves: int = MAX_ITERATIONS, joint: bool = False,
                bound: bool = True, runner: Any = None, polishes: int = POLISH_SOLVES,
                lockstep: bool | None = None, certify: float = 0.0) -> Oracle:
    """The oracle of ``plant`` (see :func:`oracle`; ``solver``: HiGHS's solver option; ``solves``: at most
    this many LP solves per building group; ``joint``: one LP for the district even when the buildings do not
    interact -- fewer, larger solves, for short horizons; ``bound``: also solve the relaxation of every group
    for the certified lower bound; ``runner``: a :class:`pipeline.runners.Runner` that maps the building groups
    (default: in this process, or ``workers`` spawned processes); ``polishes``: at most this many LP solves of
    the polish per group (:mod:`pipeline.optimal.polish`; 0: none; a district LP of several storages is not
    polished); ``lockstep``: for the peak alone, merge batteries that are scaled copies
    (:mod:`pipeline.optimal.lockstep`; None: when the district LP would have more than :data:`LOCKSTEP_SIZE`
    storage-steps); ``certify``: see :func:`oracle`). A problem that is not meaningful (a no-control value <= 0 to normalise by, a negative import
    coefficient, an efficiency or retention the LP cannot divide by: :mod:`pipeline.optimal.checks`) is one
    :class:`pipeline.errors.InputError`."""
    began = time.perf_counter()
    weights = obj.weights_of(objective)
    baseline = obj.values(plant.base_net, plant.price, plant.carbon)
    if normalise:
        checks.check_baseline(weights, baseline)
        weights = obj.normalised(weights, baseline)
    checks.check_prices(plant, weights)
    checks.check_devices(plant)
    scale = lp_scale(plant, weights)
    solving = {k: w / scale for k, w in weights.items()}  # the same optimum, coefficients HiGHS resolves
    owners = sorted({s.building for s in plant.storages})
    if (joint or weights[obj.PEAK] > 0) and owners:
        plants = [plant]  # one LP; buildings without storage count in the district's peak
    else:
        plants = [plant.only([b]) for b in owners]
    together = len(plants) == 1 and steps_lockstep.applies(plant, weights)
    merged = groups = None
    if together:  # the peak alone: the merged batteries' relaxation is the joint one, far smaller
        aggregated, groups = steps_lockstep.aggregate(plant)
        if lockstep is not False and (lockstep or len(plant.storages) * plant.steps > LOCKSTEP_SIZE):
            merged = plants[0] = aggregated
    if merged is None and (joint or weights[obj.PEAK] > 0) and len(plant.storages) > 1:
        polishes = 0  # a district LP: each polish solve costs as much as a plan solve (month x 17: ~20 s)
    settings = (solving, solver, solves, bound and not together, polishes, certify)
    solved = _run_groups(plants, settings, runner, workers)
    if together and bound:
        lower, seconds = group_bound(aggregated, solving, solver)
        solved[0] = dataclasses.replace(solved[0], bound=lower, solve_seconds=solved[0].solve_seconds + seconds)
    if merged is not None:  # every battery of a class runs its share of the merged plan
        energy, held = steps_lockstep.spread(plant, groups, solved[0].energy, solved[0].held)
        solved = [dataclasses.replace(solved[0], plant=plant, energy=energy, held=held)]
    schedule = _schedule(plant, solved)
    values = obj.values(schedule.net, plant.price, plant.carbon)
    # the groups' bounds cover their own buildings; a building without storage adds its fixed objective
    lower = scale * (obj.weighted(baseline, solving) + sum(
        g.bound - obj.weighted(obj.values(g.plant.base_net, g.plant.price, g.plant.carbon), solving) for g in solved))
    return Oracle(weights=weights, value=obj.weighted(values, weights), objectives=values, baseline=baseline,
                  schedule=schedule, iterations=max((g.iterations for g in solved), default=0),
                  path_error=max((g.path_error for g in solved), default=0.0),
                  solve_seconds=sum(g.solve_seconds for g in solved), seconds=time.perf_counter() - began,
                  size=max((g.size for g in solved), default=(0, 0, 0)),
                  bound=lower if bound else float("-inf"), exact=bound and exact(plant))


def lp_scale(plant: Plant, weights: Mapping[str, float]) -> float:
    """1, or the power of 10 near the LP's largest objective coefficient when that lies outside
    :data:`COEFFICIENT_RANGE` (the import coefficients [objective per kWh] and the peak's weight x 24 / T): the
    oracle solves with the weights divided by it. HiGHS's tolerances are absolute (1e-7 on reduced costs), so
    prices of 1e-9 $/kWh, or weights normalised by a district-year's cost, would let any plan pass as optimal."""
    coefficient = obj.import_coefficients(weights, plant.price, plant.carbon)
    largest = max(float(np.abs(coefficient).max()) if coefficient.size else 0.0,
                  weights[obj.PEAK] * obj.DAY_STEPS / max(plant.episode_steps or plant.steps, 1))
    low, high = COEFFICIENT_RANGE
    if not largest > 0 or low <= largest <= high:
        return 1.0
    return float(10.0 ** np.round(np.log10(largest)))


def _run_groups(plants: Sequence[Plant], settings: tuple, runner: Any, workers: int) -> list[Group]:
    """:func:`solve_groups` of ``plants`` with ``settings`` (weights, solver, solves, bound, polishes, certify): one call
    per group on ``runner`` (labelled by the group's first building), else chunks on ``workers`` spawned
    processes, else here."""
    if runner is not None:
        calls = {p.building_names[0]: ([p], *settings) for p in plants}
        return [g for chunk in runner.map("oracle", solve_groups, calls).values() for g in chunk]
    if workers > 1 and len(plants) > 1:
        from pipeline.runners import ProcessRunner  # only when asked for: spawns worker processes

        chunks = {str(i): (plants[i::workers], *settings) for i in range(min(workers, len(plants)))}
        done = ProcessRunner(len(chunks)).map("oracle", solve_groups, chunks)
        return [g for chunk in done.values() for g in chunk]
    return solve_groups(plants, *settings)


def exact(plant: Plant) -> bool:
    """Whether the plan's LP is the environment's problem itself (then its optimum is the minimum and the bound
    equals it): no battery, and none of the tank restrictions acts (no undersized device where a tank could
    discharge, no outage at a building with a storage)."""
    if any(s.battery is not None for s in plant.storages):
        return False
    for s in plant.storages:
        if s.relaxed_discharge is not None and np.any(s.relaxed_discharge != s.discharge_max):
            return False
        if plant.outage[s.building, 1:].any():
            return False
    return True


def solve_groups(plants: Sequence[Plant], weights: Mapping[str, float], solver: str = "choose",
                 solves: int = MAX_ITERATIONS, bound: bool = True, polishes: int = POLISH_SOLVES,
                 certify: float = 0.0) -> list[Group]:
    """Solve the building groups ``plants`` one after the other, each first solve starting from the previous
    group's first basis (used only when the LP has the same shape), and (``bound``) each group's relaxation
    (tightened for ``certify`` seconds, :mod:`pipeline.optimal.certify`).
    The bases are dropped from the result (HiGHS objects do not cross process boundaries)."""
    out: list[Group] = []
    for plant in plants:
        group = solve_group(plant, weights, solver, start=out[-1].first_basis if out else None, limit=solves,
                            polishes=polishes)
        if bound:
            value, seconds = group_bound(plant, weights, solver, certify)
            group = dataclasses.replace(group, bound=value, solve_seconds=group.solve_seconds + seconds)
        out.append(group)
    return [dataclasses.replace(g, first_basis=None) for g in out]


def group_bound(plant: Plant, weights: Mapping[str, float], solver: str = "choose",
                certify: float = 0.0) -> tuple[float, float]:
    """(certified lower bound, seconds) of ``plant``'s objective: the optimum of its relaxation
    (:mod:`pipeline.optimal.relax`), which no schedule the environment can execute beats; with ``certify`` > 0
    raised by the blocks' power-range choice within that many seconds (:func:`pipeline.optimal.certify.block_bound`)."""
    if certify > 0:
        return block_bound(plant, weights, certify)
    lp = build(relax.relaxed_plant(plant), weights, relaxed=True)
    try:
        solution = solve(lp, solver=solver)
    except SolveError:  # the relaxation is degenerate (no penalties); the interior point copes where simplex stalls
        solution = solve(lp, solver="ipm")
    return solution.objective, solution.seconds


def solve_group(plant: Plant, weights: Mapping[str, float], solver: str = "choose", start: Any = None,
                limit: int = MAX_ITERATIONS, polishes: int = POLISH_SOLVES) -> Group:
    """Solve, refresh the battery efficiencies and usable capacity from the schedule, and solve again (warm
    started; in a shrinking trust region around the last plan after :data:`FREE_SOLVES` solves) until the plan
    follows the env's physics within :data:`PATH_TOLERANCE` or ``limit`` solves were made; keep
    the plan closest to the physics. A trust region that leaves no feasible plan (the refreshed efficiencies
    moved the last plan out of reach) is widened and the solve repeated. Then at most ``polishes`` LP solves
    polish the batteries on their true marginal efficiency (:func:`pipeline.optimal.polish.polish`), within
    :data:`POLISH_BUDGET` times the time the plan took."""
    began = time.perf_counter()
    seconds, basis, first, best = 0.0, start, None, None
    center, radius, solves = None, None, 0
    while solves < limit:
        solves += 1
        lp = build(_windowed(plant, center, radius), weights)
        try:
            solution = solve(lp, basis=basis, solver=solver)
        except SolveError:
            if best is None or radius is None or radius >= 1.0:
                raise
            radius /= TRUST_SHRINK ** 2
            continue
        seconds, basis = seconds + solution.seconds, solution.basis
        first = basis if first is None else first
        energy, held = _energies(lp.columns, solution.x, len(plant.storages))
        refreshed, error = _refresh(plant, energy, held)
        if best is None or error < best[0]:
            best = (error, plant, energy, held)
        if error <= PATH_TOLERANCE:
            break
        plant, center = refreshed, energy
        if solves >= FREE_SOLVES:
            radius = TRUST_RADIUS if radius is None else radius * TRUST_SHRINK
    error, plant, energy, held = best
    size = (int(lp.cost.size), int(lp.row_lower.size), int(lp.value.size))
    if polishes:
        budget = max(POLISH_BUDGET * (time.perf_counter() - began), POLISH_MIN_SECONDS)
        energy, held, more, spent = polish(plant, weights, energy, held, solver, polishes, basis, budget)
        solves, seconds = solves + more, seconds + spent
        plant, error = _refresh(plant, energy, held)
    return Group(plant, energy, held, solves, error, seconds, size, first)


def _refresh(plant: Plant, energy: np.ndarray, held: np.ndarray) -> tuple[Plant, float]:
    """``plant`` with its batteries' efficiencies and usable capacity recomputed from the planned ``energy``
    (S, n), and how far the plan (``energy``, ``held``) is from the physics [fraction of capacity]."""
    refreshed = tuple(battery_path(s, e) if s.battery is not None else s
                      for s, e in zip(plant.storages, energy, strict=True))
    error = max((path_error(new, e, h) / new.capacity for new, e, h in zip(refreshed, energy, held, strict=True)
                 if new.battery is not None), default=0.0)
    return dataclasses.replace(plant, storages=refreshed), error


def _windowed(plant: Plant, center: np.ndarray | None, radius: float | None) -> Plant:
    """``plant`` with every battery step within ``radius`` x nominal power of ``center`` (S, n) [kWh] (no
    window when ``radius`` is None)."""
    if radius is None:
        return plant
    return dataclasses.replace(plant, storages=tuple(
        trust(s, e, radius * s.battery.nominal_power) if s.battery is not None else s
        for s, e in zip(plant.storages, center, strict=True)))


def _energies(cols, x: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Device-side energy (charge - discharge) and held energy, (count, n), from the LP solution ``x``."""
    n = cols.n
    energy = np.array([x[cols.charge[s]:cols.charge[s] + n] - x[cols.discharge[s]:cols.discharge[s] + n]
                       for s in range(count)]).reshape(count, n)
    held = np.array([x[cols.energy[s]:cols.energy[s] + n] for s in range(count)]).reshape(count, n)
    return energy, held


def _schedule(plant: Plant, solved: Sequence[Group]) -> Schedule:
    """The district's schedule (every storage of ``plant``, in its order) from the solved groups."""
    found: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for g in solved:
        for s, storage in enumerate(g.plant.storages):
            found[(g.plant.building_names[storage.building], storage.slot)] = (g.energy[s], g.held[s])
    keys = storage_keys(plant)
    shape = (len(keys), plant.steps)
    energy, held = np.zeros(shape), np.zeros(shape)
    action, soc = np.zeros(shape), np.zeros(shape)
    net = plant.base_net.copy()
    for row, (key, storage) in enumerate(zip(keys, plant.storages, strict=True)):
        e, h = found[key]
        energy[row, 1:], held[row, 0], held[row, 1:] = e, storage.initial_energy, h
        action[row] = energy[row] / storage.action_scale
        soc[row] = held[row] / storage.capacity
        live = ~plant.outage[storage.building, 1:]
        net[storage.building, 1:] += np.where(live, storage.electricity * e, 0.0)
    return Schedule(storages=keys, energy=energy, held=held, action=action, soc=soc, net=net,
                    scale=np.array([s.action_scale for s in plant.storages]))


def storage_keys(plant: Plant) -> tuple[tuple[str, str], ...]:
    """(building name, slot) of every controllable storage of ``plant``, in its order."""
    return tuple((plant.building_names[s.building], s.slot) for s in plant.storages)

