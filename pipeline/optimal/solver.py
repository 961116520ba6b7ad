"""Solve a :class:`pipeline.optimal.lp.LinearProgram` with HiGHS through ``highspy``.

Why HiGHS/highspy: HiGHS is the open-source LP solver that is actively maintained (MIT licence, released with
binary wheels for every platform, the default LP solver of SciPy and of most modelling layers); its Python
binding takes a row-wise sparse matrix directly, so no modelling layer (Pyomo, PuLP, CVXPY) is needed between
the numpy arrays of :mod:`pipeline.optimal.lp` and the solver; and its dual simplex and interior-point codes
solve a district-year storage LP (about a million variables) in seconds. ``highspy`` is imported here only,
when a problem is solved (it belongs to the ``pipeline`` extra).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from pipeline.optimal.lp import LinearProgram


def new_highs(highspy):
    """A silent ``highspy.Highs``. HiGHS prints a banner to the process's standard output when the first
    instance is made, before any option can be set: that construction runs with file descriptor 1 pointed at
    the null device (nothing else is printed meanwhile)."""
    global _BANNER_SHOWN
    if _BANNER_SHOWN:
        h = highspy.Highs()
    else:
        sys.stdout.flush()
        saved = os.dup(1)
        try:
            with open(os.devnull, "w") as null:
                os.dup2(null.fileno(), 1)
                h = highspy.Highs()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        _BANNER_SHOWN = True
    h.setOptionValue("output_flag", False)
    return h


_BANNER_SHOWN = False


class SolveError(RuntimeError):
    """HiGHS did not find an optimal solution (infeasible, unbounded, time limit ...)."""


@dataclass(frozen=True)
class Solution:
    """``x``: the optimal column values; ``objective``: cost . x without the penalties, plus the constant;
    ``seconds``: wall time of HiGHS (loading the model and solving); ``iterations``: simplex + IPM iterations;
    ``basis``: (columns, rows, HiGHS's final basis), a warm start for an LP of that shape; ``row_dual``: the
    rows' dual values (HiGHS's sign convention: cost - A^T row_dual = the columns' reduced costs)."""

    x: np.ndarray
    objective: float
    seconds: float
    iterations: int
    basis: Any = None
    row_dual: np.ndarray | None = None


def solve(lp: LinearProgram, *, basis: Any = None, solver: str = "choose", time_limit: float = float("inf"),
          threads: int = 1, options: Mapping[str, Any] | None = None) -> Solution:
    """Solve ``lp``; raise :class:`SolveError` unless HiGHS reports an optimum. ``basis``: a previous
    solution's basis (used when its shape fits ``lp``: the simplex restarts from it); ``solver``: HiGHS's
    ``solver`` option ("choose", "simplex", "ipm", "pdlp"); ``threads``: HiGHS's thread count; ``options``:
    further HiGHS options by name (e.g. ``{"simplex_dual_edge_weight_strategy": 1}``)."""
    import highspy  # lazy: the optimal package's only dependency beyond the environment

    h, began = _loaded(highspy, lp, {"solver": solver, "threads": int(threads), **(options or {})}, time_limit)
    n, m = int(lp.cost.size), int(lp.row_lower.size)
    if basis is not None and basis[:2] == (n, m):
        h.setBasis(basis[2])
    h.run()
    seconds = time.perf_counter() - began
    status = h.getModelStatus()
    if status != highspy.HighsModelStatus.kOptimal:
        raise SolveError(f"HiGHS: {h.modelStatusToString(status)} ({lp.cost.size} columns, {lp.row_lower.size} rows)")
    x = np.asarray(h.getSolution().col_value, dtype=float)
    info = h.getInfo()
    return Solution(x=x, objective=float(lp.objective @ x + lp.constant), seconds=seconds,
                    iterations=int(info.simplex_iteration_count + max(info.ipm_iteration_count, 0)),
                    basis=(n, m, h.getBasis()), row_dual=np.asarray(h.getSolution().row_dual, dtype=float))


def mip_bound(lp: LinearProgram, integer: np.ndarray, *, time_limit: float = float("inf"),
              gap: float = 1e-5) -> tuple[float, float]:
    """(dual bound, seconds) of ``lp`` with the columns ``integer`` (bool (n,)) integral: HiGHS's branch and
    bound runs until its relative gap is below ``gap`` or ``time_limit`` [s] passes; the dual bound (no integral
    solution is below it) is valid either way. ``lp.cost`` must equal ``lp.objective`` (no penalties)."""
    import highspy

    # presolve off: on these small block programs it costs more than it saves (2.5x slower with it, 10 blocks
    # of 2022 phase 1, Intel Xeon family 6 model 207)
    options = {"threads": 1, "mip_rel_gap": float(gap), "presolve": "off"}
    h, began = _loaded(highspy, lp, options, time_limit, np.where(integer, 1, 0).astype(np.int32))
    h.run()
    status = h.getModelStatus()
    if status not in (highspy.HighsModelStatus.kOptimal, highspy.HighsModelStatus.kTimeLimit):
        raise SolveError(f"HiGHS: {h.modelStatusToString(status)} ({lp.cost.size} columns, mixed-integer)")
    bound = float(h.getInfo().mip_dual_bound)
    if not np.isfinite(bound):
        raise SolveError(f"HiGHS: no dual bound within {time_limit} s ({lp.cost.size} columns, mixed-integer)")
    return bound + lp.constant, time.perf_counter() - began


def _loaded(highspy, lp: LinearProgram, options: Mapping[str, Any], time_limit: float,
            integrality: np.ndarray | None = None):
    """(a silent Highs holding ``lp`` with ``options``, the time it began): every column continuous unless
    ``integrality`` (n,) (1 = integer) is given."""
    h = new_highs(highspy)
    for name, value in options.items():
        h.setOptionValue(name, value)
    if np.isfinite(time_limit):
        h.setOptionValue("time_limit", float(time_limit))
    n, m = int(lp.cost.size), int(lp.row_lower.size)
    began = time.perf_counter()
    kinds = np.zeros(n, dtype=np.int32) if integrality is None else integrality
    loaded = h.passModel(n, m, int(lp.value.size), int(highspy.MatrixFormat.kRowwise.value),
                int(highspy.ObjSense.kMinimize.value), 0.0, lp.cost, lp.lower, lp.upper, lp.row_lower, lp.row_upper,
                lp.start.astype(np.int32), lp.index.astype(np.int32), lp.value, kinds)
    accepted = (highspy.HighsStatus.kOk,) if integrality is None else (highspy.HighsStatus.kOk, highspy.HighsStatus.kWarning)
    if loaded not in accepted:  # a mixed-integer model warns of tiny coefficients HiGHS then ignores
        raise SolveError(f"HiGHS refused the model ({n} columns, {m} rows: a coefficient or bound beyond its "
                         f"limits): {loaded}")
    return h, began
