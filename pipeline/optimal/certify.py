"""A tighter certified lower bound for battery problems: the relaxation cut into blocks of steps, each block a
small mixed-integer program (issue 51).

The relaxation of :mod:`pipeline.optimal.relax` lets every step charge at any power with the efficiency of the
chord over the whole power range, so a battery that can only charge slowly (a small PV surplus, a short cheap
period) is credited the curve's best efficiency. Here each step instead *chooses* one power range (the edges of
:func:`pipeline.optimal.relax.power_regions`) for its charge and one for its discharge, and within that range
stores and removes within the lines of the range alone (:func:`pipeline.optimal.relax.efficiency_lines` over
it, moved out the same way). Every schedule the environment can execute picks, at each step, the range its
power lies in, so the program's optimum is still a lower bound -- and a closer one.

One program of a month or a year is too large to solve, so the relaxation's horizon is cut into blocks of
:data:`BLOCK_STEPS` steps and the blocks decoupled by Lagrangian relaxation: the energy held between two
blocks becomes two columns, one per block, and their equality is priced by a multiplier lambda (block b pays
lambda x its starting energy, block b - 1 earns lambda x its final energy). For *any* lambda the sum of the
blocks' optima is a lower bound (weak duality); with lambda from the relaxation's own optimal duals the blocks'
LP optima sum to the relaxation's optimum exactly, so every block whose program is solved (its
branch-and-bound dual bound, valid at any time limit) can only raise the bound. Blocks are solved in the order
of how much the relaxation's plan leans on the chord in them, until the time budget is spent; the rest count
with their LP value.

Applies to objectives summed over steps (cost, emissions, consumption); with the daily peak the blocks would
share a day's peak column and the relaxation's own bound is kept.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.optimal import relax
from pipeline.optimal.lp import Columns, LinearProgram, RowBuilder, build
from pipeline.optimal.plant import Plant, Storage
from pipeline.optimal.solver import SolveError, mip_bound, solve

#: steps per block (one day of hourly steps: the day's charge-discharge cycle stays inside one program)
BLOCK_STEPS = 24
#: the most one block's branch and bound may take [s]; its dual bound at that time counts
BLOCK_SECONDS = 5.0
#: relative gap at which a block's branch and bound stops
BLOCK_GAP = 1e-5


def column_steps(cols: Columns) -> np.ndarray:
    """The controlled step (0 .. n - 1) of every column of a relaxation's LP (n columns per storage block and
    per building's imports); -1 for a column of no step (a day's peak)."""
    steps = np.full(cols.total, -1, dtype=np.intp)
    n = cols.n
    for kind in (cols.charge, cols.discharge, cols.energy, cols.stored, cols.removed):
        for first in (kind if kind is not None else ()):
            if first >= 0:
                steps[first:first + n] = np.arange(n)
    used = cols.imports >= 0
    steps[cols.imports[used]] = np.nonzero(used)[1]
    return steps


def block_bound(plant: Plant, weights: Mapping[str, float], budget: float) -> tuple[float, float]:
    """(certified lower bound, seconds) of ``plant``'s objective ``weights`` (the scaled weights the oracle
    solves with): the relaxation's optimum raised by the blocks' mixed-integer programs solved within
    ``budget`` [s] (see the module docstring). Falls back to the relaxation's optimum where nothing applies:
    no battery whose curve offers a choice, a peak objective, a budget of 0."""
    began = time.perf_counter()
    relaxed = relax.relaxed_plant(plant)
    lp = build(relaxed, weights, relaxed=True)
    try:
        solution = solve(lp)
    except SolveError:  # degenerate relaxation: the interior point (its duals are as valid a price)
        solution = solve(lp, solver="ipm")
    choices = {i: _regions(s) for i, s in enumerate(relaxed.storages) if s.battery is not None}
    choices = {i: r for i, r in choices.items() if len(r) > 1}
    if budget <= 0 or not choices or lp.columns.days or solution.row_dual is None:
        return solution.objective, time.perf_counter() - began
    blocks = _Blocks(lp, solution.row_dual)
    order = np.argsort(-_chord_use(relaxed, lp.columns, solution.x, choices, blocks))
    values = [_lp_value(blocks.program(b)) for b in range(blocks.count)]
    for b in order:
        left = budget - (time.perf_counter() - began)
        if left <= 0.05:
            break
        program, integer = _with_choices(blocks.program(b), blocks.span(b), lp.columns, choices)
        try:
            value, _ = mip_bound(program, integer, time_limit=min(BLOCK_SECONDS, left), gap=BLOCK_GAP)
        except SolveError:
            continue  # no bound in the time left: the block keeps its LP value
        values[b] = max(values[b], value)
    lower = max(solution.objective, float(sum(values)) + lp.constant)
    return lower, time.perf_counter() - began


@dataclass(frozen=True)
class _Range:
    """One power range [lo, hi] (fraction of nominal power ``power`` [kW]) of a battery and its lines (slope,
    intercept) of stored (``store``) and removed (``remove``) energy per unit of nominal power."""

    lo: float
    hi: float
    power: float
    store: np.ndarray
    remove: np.ndarray


def _regions(s: Storage) -> list[_Range]:
    """The power ranges of battery ``s`` with their lines (one range: no choice to make)."""
    b = s.battery
    top = relax.power_range(s)
    edges = relax.power_regions(b.efficiency, top, b.extrapolate)
    return [_Range(lo, hi, b.nominal_power, *relax.efficiency_lines(b.efficiency, hi, b.extrapolate, xmin=lo))
            for lo, hi in zip(edges[:-1], edges[1:], strict=True)]


class _Blocks:
    """The relaxation's LP cut into blocks of ``block`` steps, with the multipliers of the energies held between
    blocks taken from the LP's optimal ``row_dual`` (see the module docstring)."""

    def __init__(self, lp: LinearProgram, row_dual: np.ndarray, block: int = BLOCK_STEPS) -> None:
        self.lp, self.block = lp, block
        cols = lp.columns
        self.steps = column_steps(cols)
        self.count = -(-cols.n // block)
        counts = np.diff(lp.start)
        entry_row = np.repeat(np.arange(counts.size), counts)
        entry_step = self.steps[lp.index]
        row_step = np.full(counts.size, -1, dtype=np.intp)
        np.maximum.at(row_step, entry_row, entry_step)
        self.row_block = np.where(row_step >= 0, row_step // block, -1)
        self.col_block = np.where(self.steps >= 0, self.steps // block, -1)
        self.energy = np.zeros(cols.total, dtype=bool)
        for first in cols.energy:
            self.energy[first:first + cols.n] = True
        # lambda of the energy column E held before block b: the part of its dual weight that block b's rows carry
        link = self.energy[lp.index] & (self.row_block[entry_row] > 0) & (
            entry_step == self.row_block[entry_row] * block - 1)
        self.price = np.zeros(cols.total)
        np.add.at(self.price, lp.index[link], lp.value[link] * row_dual[entry_row[link]])
        self._programs: dict[int, tuple[LinearProgram, np.ndarray]] = {}

    def span(self, b: int) -> range:
        """The controlled steps of block ``b``."""
        return range(b * self.block, min((b + 1) * self.block, self.lp.columns.n))

    def program(self, b: int) -> tuple[LinearProgram, np.ndarray]:
        """(block ``b``'s LP, the position of every column of the whole LP in it or -1): its own columns, the
        energies held before it (priced +lambda), its last energies priced -lambda of the next block."""
        if b not in self._programs:
            self._programs[b] = self._program(b)
        return self._programs[b]

    def _program(self, b: int) -> tuple[LinearProgram, np.ndarray]:
        lp, span = self.lp, self.span(b)
        own = np.flatnonzero(self.col_block == b)
        before = np.flatnonzero(self.energy & (self.steps == span.start - 1)) if b else own[:0]
        columns = np.concatenate([own, before])
        position = np.full(lp.cost.size, -1, dtype=np.intp)
        position[columns] = np.arange(columns.size)
        cost = lp.cost[columns].copy()
        cost[position[before]] += self.price[before]
        if b + 1 < self.count:
            after = np.flatnonzero(self.energy & (self.steps == span.stop - 1))
            cost[position[after]] -= self.price[after]
        rows = np.flatnonzero(self.row_block == b)
        pieces = [np.arange(lp.start[r], lp.start[r + 1]) for r in rows]
        entries = np.concatenate(pieces) if pieces else np.zeros(0, dtype=np.intp)
        start = np.concatenate([[0], np.cumsum([p.size for p in pieces])]).astype(np.intp)
        index = position[lp.index[entries]]
        if (index < 0).any():
            raise AssertionError("a block row reaches outside its block")  # the layout changed: not decoupled
        program = LinearProgram(cost=cost, objective=cost, lower=lp.lower[columns], upper=lp.upper[columns],
                                row_lower=lp.row_lower[rows], row_upper=lp.row_upper[rows], start=start,
                                index=index, value=lp.value[entries], constant=0.0, columns=lp.columns)
        return program, position


def _lp_value(block: tuple[LinearProgram, np.ndarray]) -> float:
    """The block's LP optimum (its Lagrangian value without the power-range choice)."""
    program = block[0]
    try:
        return solve(program).objective
    except SolveError:
        return solve(program, solver="ipm").objective


def _with_choices(block: tuple[LinearProgram, np.ndarray], span: range, cols: Columns,
                  choices: Mapping[int, list[_Range]]) -> tuple[LinearProgram, np.ndarray]:
    """The block's program with every battery step's power-range choice (binary z per range and direction,
    the perspective form: x_k in [lo P z_k, hi P z_k], its stored energy within range k's lines times z_k, at
    most one range; the step's charge and stored energy are the sums) and the integer columns' mask."""
    program, position = block
    steps = np.arange(span.start, span.stop)
    k = steps.size
    rows = RowBuilder()
    total = program.cost.size
    integer: list[np.ndarray] = [np.zeros(total, dtype=bool)]
    upper: list[np.ndarray] = [program.upper]
    for i, ranges in choices.items():
        for amount, energy, store in ((cols.charge[i], cols.stored[i], True), (cols.discharge[i], cols.removed[i], False)):
            picks, xs, es = [], [], []
            for r in ranges:
                z, x, e = (total + j * k + np.arange(k) for j in range(3))
                total += 3 * k
                integer.append(np.repeat([True, False, False], k))
                upper.append(np.concatenate([np.ones(k), np.full(2 * k, np.inf)]))
                rows.add(np.full(k, -np.inf), 0.0, (x, 1.0), (z, -r.hi * r.power))
                rows.add(np.zeros(k), np.inf, (x, 1.0), (z, -r.lo * r.power))
                for slope, intercept in (r.store if store else r.remove):
                    lower, upper_ = (-np.inf, 0.0) if store else (0.0, np.inf)
                    rows.add(np.full(k, lower), upper_, (e, 1.0), (x, -slope), (z, -intercept * r.power))
                picks.append(z)
                xs.append(x)
                es.append(e)
            rows.add(np.full(k, -np.inf), 1.0, *[(z, 1.0) for z in picks])
            rows.add(np.zeros(k), 0.0, (position[amount + steps], 1.0), *[(x, -1.0) for x in xs])
            rows.add(np.zeros(k), 0.0, (position[energy + steps], 1.0), *[(e, -1.0) for e in es])
    start, index, value = rows.csr()
    grown = total - program.cost.size
    zeros = np.zeros(grown)
    merged = LinearProgram(
        cost=np.concatenate([program.cost, zeros]), objective=np.concatenate([program.objective, zeros]),
        lower=np.concatenate([program.lower, zeros]), upper=np.concatenate(upper),
        row_lower=np.concatenate([program.row_lower, *rows.lower]),
        row_upper=np.concatenate([program.row_upper, *rows.upper]),
        start=np.concatenate([program.start, program.start[-1] + start[1:]]),
        index=np.concatenate([program.index, index]), value=np.concatenate([program.value, value]),
        constant=0.0, columns=program.columns)
    return merged, np.concatenate(integer)


def _chord_use(plant: Plant, cols: Columns, x: np.ndarray, choices: Mapping[int, list[_Range]],
               blocks: _Blocks) -> np.ndarray:
    """Per block, how much the relaxation's plan ``x`` stores beyond and removes short of what its batteries'
    curves allow at the planned powers [kWh]: where the power-range choice can raise the bound most."""
    use = np.zeros(blocks.count)
    n = cols.n
    for i in choices:
        b = plant.storages[i].battery
        p = b.nominal_power
        charge, discharge = x[cols.charge[i]:cols.charge[i] + n], x[cols.discharge[i]:cols.discharge[i] + n]
        stored, removed = x[cols.stored[i]:cols.stored[i] + n], x[cols.removed[i]:cols.removed[i] + n]
        one_way = np.sqrt(relax.round_trip(b.efficiency, np.concatenate([charge, discharge]) / p, b.extrapolate))
        excess = np.maximum(stored - charge * one_way[:n], 0.0) + np.maximum(discharge / one_way[n:] - removed, 0.0)
        np.add.at(use, np.arange(n) // blocks.block, excess)
    return use
