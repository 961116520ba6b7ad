"""The relaxation behind the oracle's certified lower bound: a linear program whose feasible set contains every
battery and tank schedule the environment can execute, so that its optimum is at most the objective of any
policy (issue 51).

What the environment does that the plan's LP restricts or linearises, and what the relaxation keeps of it:

* battery efficiency (a curve of the power, not concave): charging ``c`` [kWh] stores phi(c) = c x
  sqrt(eff(c / P)) and discharging ``d`` removes psi(d) = d / sqrt(eff(d / P)). The relaxation stores at most a
  concave piecewise-linear majorant of phi and removes at least a convex piecewise-linear minorant of psi
  (:func:`efficiency_lines`), and its balance is an inequality, E_i <= a E_(i-1) + stored - removed (energy may
  be thrown away). Any executed step satisfies it, whatever efficiency the step had;
* capacity fade: the usable capacity is held at its value at the episode start (fade only lowers it);
* depth of discharge: the env's d_i <= r_(i-1) (E_(i-1) - floor) when E_(i-1) >= floor (else no discharge) is
  not convex; its convex hull over E in [0, C] is the chord d_i <= r_max (C - floor) / C x E_(i-1), r_max the
  best one-way efficiency;
* capacity-power curve: its concave majorant (the upper hull of its points; the curve itself when concave);
* tanks: a discharge where the device is undersized is allowed (up to the demand); charging during an outage
  is not capped by the PV surplus.

Functions here are pure; :func:`pipeline.optimal.lp.build` writes the rows (``relaxed=True``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from citylearn_env import devices
from pipeline.optimal.plant import Plant, Storage

#: samples per piece of the efficiency curve whose hull gives the lines (more: tighter, more rows)
HULL_SAMPLES = 12
#: points of the dense grid on which the lines are checked against the exact function
CHECK_POINTS = 20001


def upper_hull(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(slope, intercept) lines of the upper concave hull of the points (x, y) (x sorted, distinct), (K, 2):
    min_k(intercept_k + slope_k x) is the smallest concave function >= every point on [x_0, x_-1]."""
    hull: list[int] = []
    for i in range(x.size):
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            if (y[b] - y[a]) * (x[i] - x[a]) <= (y[i] - y[a]) * (x[b] - x[a]):  # b is on or below a -> i
                hull.pop()
            else:
                break
        hull.append(i)
    idx = np.array(hull)
    if idx.size == 1:
        return np.array([[0.0, float(y[idx[0]])]])
    slope = np.diff(y[idx]) / np.diff(x[idx])
    return np.stack([slope, y[idx[:-1]] - slope * x[idx[:-1]]], axis=1)


def _efficiency(curve: devices.Curve, x: np.ndarray, extrapolate: bool) -> np.ndarray:
    """Round-trip efficiency [-] of one battery's curve at x = |energy| / nominal power (the env's function)."""
    rows = np.zeros(x.size, dtype=np.intp)
    one = devices.Curve(curve.xs[rows], curve.ys[rows], curve.slopes[rows])
    return devices.interpolate_curve(x, one, extrapolate_first_segment=extrapolate)


def round_trip(curve: devices.Curve, x: np.ndarray, extrapolate: bool = False) -> np.ndarray:
    """Round-trip efficiency [-] of one battery's power-efficiency curve at x = |energy| / nominal power."""
    return _efficiency(curve, np.asarray(x, dtype=float), extrapolate)


def efficiency_lines(curve: devices.Curve, xmax: float, extrapolate: bool = False,
                     xmin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Lines bounding a battery's stored and removed energy per unit of nominal power, for x = |energy| / P in
    [``xmin``, ``xmax``]: ``store`` (K, 2) (slope, intercept) with x sqrt(eff(x)) <= min_k(intercept + slope
    x), and ``remove`` (J, 2) with x / sqrt(eff(x)) >= max_j(intercept + slope x).

    The lines are the hull of the function sampled at the curve's points and :data:`HULL_SAMPLES` points per
    piece, moved out by the largest miss on a grid of :data:`CHECK_POINTS` points plus the most the function can
    bend between two grid points (max |f''| h^2 / 8, from the piece's linear efficiency u + v x), so that they
    hold at every x, not only at the samples."""
    xs = np.unique(np.clip(np.concatenate([[xmin, xmax], curve.xs[0]]), xmin, xmax))
    grid = np.unique(np.concatenate([np.linspace(xmin, xmax, CHECK_POINTS), xs]))
    pieces = zip(xs[:-1], xs[1:], strict=True)
    samples = np.unique(np.concatenate([np.linspace(a, b, HULL_SAMPLES + 1) for a, b in pieces] + [xs]))
    eff_grid, eff_samples = _efficiency(curve, grid, extrapolate), _efficiency(curve, samples, extrapolate)
    if eff_grid.min() <= 0:
        raise ValueError("a battery's power-efficiency curve reaches 0 on [0, its largest power]")
    bend = np.array(_bend(curve, xs, extrapolate)) * ((xmax - xmin) / (CHECK_POINTS - 1)) ** 2 / 8.0
    store = _merged(upper_hull(samples, samples * np.sqrt(eff_samples)))
    miss = grid * np.sqrt(eff_grid) - (store[:, :1] * grid + store[:, 1:]).min(axis=0)
    store[:, 1] += max(float(miss.max()), 0.0) + bend[0] + 1e-12
    remove = -_merged(upper_hull(samples, -samples / np.sqrt(eff_samples)))
    miss = (remove[:, :1] * grid + remove[:, 1:]).max(axis=0) - grid / np.sqrt(eff_grid)
    remove[:, 1] -= max(float(miss.max()), 0.0) + bend[1] + 1e-12
    return store, remove


def _merged(lines: np.ndarray, tolerance: float = 1e-7) -> np.ndarray:
    """Hull lines (slope, intercept) in order with the nearly collinear neighbours merged (slopes within
    ``tolerance``): the highest intercept of each run (near-copies of a row make the simplex stall). The caller
    moves the lines out by their miss afterwards, so merging never makes them invalid."""
    keep = [lines[0].copy()]
    for line in lines[1:]:
        if abs(line[0] - keep[-1][0]) <= tolerance * max(1.0, abs(line[0])):
            keep[-1][1] = max(keep[-1][1], line[1])
        else:
            keep.append(line.copy())
    return np.array(keep)


def _bend(curve: devices.Curve, xs: np.ndarray, extrapolate: bool) -> tuple[float, float]:
    """Upper bounds of |phi''| and |psi''| on [xs_0, xs_-1] for phi = x sqrt(eff), psi = x / sqrt(eff), eff
    linear (u + v x) between consecutive ``xs``: phi'' = v (4u + 3vx) / (4 eff^1.5), psi'' = -v (u + vx / 4) /
    eff^2.5."""
    e = _efficiency(curve, xs, extrapolate)
    v = np.diff(e) / np.maximum(np.diff(xs), 1e-300)
    u = e[:-1] - v * xs[:-1]
    low = np.minimum(e[:-1], e[1:])
    top = float(xs[-1])
    phi = np.abs(v) * (4 * np.abs(u) + 3 * np.abs(v) * top) / (4 * low ** 1.5)
    psi = np.abs(v) * (np.abs(u) + np.abs(v) * top / 4) / low ** 2.5
    return float(phi.max(initial=0.0)), float(psi.max(initial=0.0))


def power_regions(curve: devices.Curve, xmax: float, extrapolate: bool = False) -> np.ndarray:
    """Edges (K + 1,) of the power ranges x = |energy| / P in [0, ``xmax``] that a tighter relaxation treats as
    a discrete choice per step (:mod:`pipeline.optimal.certify`): the curve's points below the first power of
    its best efficiency, and the middle of every piece where the efficiency rises (where x sqrt(eff) bends
    upward, so that one chord over it is loose). Above that power the curve no longer rises to a better
    efficiency and one range keeps it. Just [0, ``xmax``] (no choice) for a curve that never rises."""
    xs = np.unique(np.clip(np.concatenate([[0.0, xmax], curve.xs[0]]), 0.0, xmax))
    eff = _efficiency(curve, xs, extrapolate)
    top = float(xs[int(np.argmax(eff >= eff.max() - 1e-12))])
    rising = np.flatnonzero(np.diff(eff) > 1e-12)
    inner = np.concatenate([xs[(xs > 0.0) & (xs < top)], (xs[rising] + xs[rising + 1]) / 2])
    return np.unique(np.concatenate([[0.0, xmax], inner[inner < top]]))


def best_efficiency(curve: devices.Curve, xmax: float, extrapolate: bool = False) -> float:
    """The highest round-trip efficiency [-] the curve reaches on [0, ``xmax``] (at a point: it is linear between)."""
    xs = np.unique(np.clip(np.concatenate([[0.0, xmax], curve.xs[0]]), 0.0, xmax))
    return float(_efficiency(curve, xs, extrapolate).max())


def relaxed_plant(plant: Plant) -> Plant:
    """``plant`` with every storage relaxed (:func:`relaxed_storage`); the LP of it needs ``relaxed=True``."""
    return dataclasses.replace(plant, storages=tuple(relaxed_storage(s) for s in plant.storages))


def relaxed_storage(s: Storage) -> Storage:
    """A tank may discharge up to its demand where the device is undersized (``relaxed_discharge``); a battery
    gets the concave majorant of its capacity-power curve, its usable capacity of the first step throughout,
    and its best one-way efficiency for the depth-of-discharge chord."""
    if s.battery is None:
        if s.relaxed_discharge is None:
            return s
        return dataclasses.replace(s, discharge_max=s.relaxed_discharge)
    b = s.battery
    points = b.power_points
    lines = b.lines if points is None else upper_hull(*_distinct(points))[:, ::-1]
    xmax = _top(lines)
    best = np.sqrt(best_efficiency(b.efficiency, xmax, b.extrapolate))
    n = s.one_way.size
    start = float(b.usable_capacity[0]) if b.usable_capacity.size else s.capacity
    terms = dataclasses.replace(b, lines=lines, usable_capacity=np.full(n, start), one_way_prev=np.full(n, best))
    return dataclasses.replace(s, one_way=np.full(n, best), battery=terms, low=None, high=None)


def _distinct(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The curve points (2, K) sorted by x, one per x (the highest y: a curve padded with its last point)."""
    xs = np.unique(points[0])
    return xs, np.array([points[1][points[0] == x].max() for x in xs])


def power_range(s: Storage) -> float:
    """The largest |energy| / nominal power a (relaxed) battery can reach (:func:`_top` of its lines)."""
    return _top(s.battery.lines)


def _top(lines: np.ndarray) -> float:
    """1 (charging is capped at the nominal power) or the most the capacity-power lines (intercept, slope) allow
    at a state of charge in [0, 1], whichever is larger."""
    return max(1.0, float((lines[:, 0] + np.maximum(lines[:, 1], 0.0)).max()))
