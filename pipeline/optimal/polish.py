"""Polish an oracle plan by sequential linear programming on the battery's true efficiency (issue 51).

The oracle's fixed point (:mod:`pipeline.optimal.oracle`) gives every step the *average* efficiency of the
plan's power (a secant through 0). At that point the plan is the best one for those frozen efficiencies, not a
local optimum of the environment's problem: charging harder where the curve rises stores each extra kWh at a
*marginal* efficiency above the average, which the secant never sees. The polish linearises the stored energy
at the plan's own energies -- charging c stores phi(c0) + phi'(c0) (c - c0), discharging d removes psi(d0) +
psi'(d0) (d - d0), phi(c) = c sqrt(eff(c / P)), psi(d) = d / sqrt(eff(d / P)) -- solves the LP within a trust
region around the plan, runs the new plan through the env's battery step (:func:`executed`: the tangents are
approximate, so the env may clip a request at a full or empty battery) and keeps what the env executes if its
objective is lower. The trust region grows after a kept step and shrinks after a refused one.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from citylearn_env import devices
from pipeline.optimal import objectives as obj
from pipeline.optimal.lp import build
from pipeline.optimal.plant import Plant, Storage, battery_path, trust
from pipeline.optimal.solver import SolveError, solve

#: LP solves the polish may make per group
POLISH_SOLVES = 12
#: the first trust radius [fraction of nominal power]; kept steps double it, refused ones quarter it
POLISH_RADIUS = 0.2
#: the smallest radius tried [fraction of nominal power]
POLISH_FLOOR = 1e-3


def slopes(storage: Storage, energy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(phi, phi', psi, psi') of a battery at the charges max(energy, 0) and discharges max(-energy, 0) [kWh,
    per kWh]: phi' = sqrt(eff) + x eff' / (2 sqrt(eff)), psi' = 1 / sqrt(eff) - x eff' / (2 eff^1.5), x = |e| / P,
    eff' the slope of the curve's segment at x (the env's segment choice)."""
    b = storage.battery
    curve = b.efficiency
    c, d = np.maximum(energy, 0.0), np.maximum(-energy, 0.0)
    out = []
    for e in (c, d):
        x = e / b.nominal_power
        rows = np.zeros(x.size, dtype=np.intp)
        one = devices.Curve(curve.xs[rows], curve.ys[rows], curve.slopes[rows])
        eff = devices.interpolate_curve(x, one, extrapolate_first_segment=b.extrapolate)
        segment = (curve.xs[0][None, :] >= x[:, None]).argmax(axis=1)
        segment = np.maximum(segment - (segment > 0), 0)
        rise = curve.slopes[0][np.minimum(segment, curve.slopes.shape[1] - 1)]
        rise = np.where((x > curve.xs[0, -1]) & ~b.extrapolate, 0.0, rise)
        out.append((eff, rise, x))
    (ec, rc, xc), (ed, rd, xd) = out
    phi, psi = c * np.sqrt(ec), d / np.sqrt(ed)
    return phi, np.sqrt(ec) + xc * rc / (2 * np.sqrt(ec)), psi, 1 / np.sqrt(ed) - xd * rd / (2 * ed ** 1.5)


def tangent(storage: Storage, energy: np.ndarray) -> Storage:
    """``storage`` (a battery, its efficiencies refreshed from ``energy``) with its balance linearised at the
    device-side ``energy`` (n,) [kWh]."""
    phi, dphi, psi, dpsi = slopes(storage, energy)
    c, d = np.maximum(energy, 0.0), np.maximum(-energy, 0.0)
    return dataclasses.replace(storage, tangent=(dphi, dpsi, phi - dphi * c - psi + dpsi * d))


def executed(storage: Storage, request: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What the env makes of the device-side ``request`` (n,) [kWh] to the battery ``storage``, step by step as
    :func:`citylearn_env.devices.battery_charge` does it: the request clipped to the capacity-power curve, the
    nominal power, the free faded capacity and the depth-of-discharge limit (at the previous step's efficiency),
    stored at the efficiency of the clipped energy, capacity fading with the throughput. Returns (the energy it
    exchanged [kWh, device side], the energy it holds after each step [kWh]), (n,) each."""
    b, a, cap = storage.battery, storage.retention, storage.capacity
    xs, ys, rises = (list(map(float, v[0])) for v in (b.efficiency.xs, b.efficiency.ys, b.efficiency.slopes))
    level, usable, one_way_prev = storage.initial_energy, float(b.usable_capacity[0]), np.sqrt(b.initial_efficiency)
    energy, held = np.empty_like(request), np.empty_like(request)
    for i, want in enumerate(request):
        start = max(0.0, a * level)
        power = max(0.0, b.nominal_power * float((b.lines[:, 0] + b.lines[:, 1] * start / cap).min()))
        floor = -max((level - b.floor) * one_way_prev, 0.0)
        e = min(want, power, b.nominal_power, usable - start) if want >= 0 else max(want, -power, floor)
        one_way = math.sqrt(_curve_at(abs(e) / b.nominal_power, xs, ys, rises, b.extrapolate))
        level = min(start + e * one_way, cap) if e >= 0 else max(0.0, start + e / one_way)
        change = level - start
        energy[i] = change / one_way if change >= 0 else change * one_way
        held[i] = level
        usable = max(usable - b.capacity_loss * cap * abs(energy[i]) / (2 * usable), 0.0) if usable > 0 else 0.0
        one_way_prev = one_way
    return energy, held


def _curve_at(x: float, xs: list[float], ys: list[float], rises: list[float], extrapolate: bool) -> float:
    """One point of a piecewise-linear curve, as :func:`citylearn_env.devices.interpolate_curve` computes it
    (the segment ending at the first x_k >= x; segment 0 below x_0 and, with ``extrapolate``, beyond the last)."""
    if x > xs[-1]:
        return ys[0] + (x - xs[0]) * rises[0] if extrapolate else ys[-1]
    k = bisect.bisect_left(xs, x)
    k -= k > 0
    return ys[k] + (x - xs[k]) * rises[k]


def value(plant: Plant, energy: np.ndarray, weights: Mapping[str, float]) -> float:
    """The weighted objective of ``plant`` with its storages' device-side ``energy`` (S, n) [kWh]."""
    net = plant.base_net.copy()
    for s, e in zip(plant.storages, energy, strict=True):
        net[s.building, 1:] += np.where(plant.outage[s.building, 1:], 0.0, s.electricity * e)
    return obj.weighted(obj.values(net, plant.price, plant.carbon), weights)


def polish(plant: Plant, weights: Mapping[str, float], energy: np.ndarray, held: np.ndarray,
           solver: str = "choose", limit: int = POLISH_SOLVES, basis: Any = None,
           budget: float = float("inf")) -> tuple[np.ndarray, np.ndarray, int, float]:
    """Improve the plan (``energy``, ``held``: (S, n) [kWh]) of ``plant`` by trust-region sequential LP on its
    batteries; returns (energy, held, LP solves, HiGHS seconds). Tanks are re-planned exactly in every LP;
    every solve starts from the previous one's basis (the first from ``basis``: the plan's last, same shape);
    no new solve starts after ``budget`` seconds (wall, the polish's own)."""
    if not any(s.battery is not None for s in plant.storages):
        return energy, held, 0, 0.0
    best = value(plant, energy, weights)
    radius, solves, seconds = POLISH_RADIUS, 0, 0.0
    began = time.perf_counter()
    while solves < limit and radius >= POLISH_FLOOR and time.perf_counter() - began < budget:
        solves += 1
        storages = tuple(
            trust(tangent(battery_path(s, e), e), e, radius * s.battery.nominal_power) if s.battery is not None
            else s for s, e in zip(plant.storages, energy, strict=True))
        lp = build(dataclasses.replace(plant, storages=storages), weights)
        try:
            solution = solve(lp, solver=solver, basis=basis)
        except SolveError:
            radius /= 4
            continue
        seconds, basis = seconds + solution.seconds, solution.basis
        cols = lp.columns
        n = cols.n
        new = np.array([solution.x[cols.charge[s]:cols.charge[s] + n] - solution.x[cols.discharge[s]:cols.discharge[s] + n]
                        for s in range(len(storages))]).reshape(energy.shape)
        new_held = np.array([solution.x[cols.energy[s]:cols.energy[s] + n] for s in range(len(storages))])
        for row, s in enumerate(plant.storages):
            if s.battery is not None:  # what the env executes of the LP's plan (its tangents are approximate)
                new[row], new_held[row] = executed(s, new[row])
        candidate = value(plant, new, weights)
        if candidate < best - 1e-12 * max(1.0, abs(best)):
            energy, held, best = new, new_held.reshape(held.shape), candidate
            radius *= 2
        else:
            radius /= 4
    return energy, held, solves, seconds
