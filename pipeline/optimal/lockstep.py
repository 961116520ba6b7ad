"""Batteries in lockstep: the district-peak oracle at scale (issue 48).

The average daily peak ties every building together, so its LP is one program over the district; the simplex
time grows much faster than that LP (17 batteries x a year: 1,063 s). Batteries that are scaled copies of one
another -- the same curves, power-to-capacity ratio, standing loss, depth of discharge, initial state of
charge, fade and initial efficiency -- are merged into one battery of their summed capacity and power
(:func:`aggregate`):

* the plan: every member follows the merged battery's schedule scaled by its share of the capacity
  (:func:`spread`). Its power fraction, state of charge, efficiency and fade are then the merged battery's
  exactly, so the plan is executable as planned. Lockstep can lose to batteries run at different powers (the
  efficiency curve is not concave); the certified bound says how much at most;
* the bound: the merged battery's relaxation (:mod:`pipeline.optimal.relax`) is a relaxation of the members'
  together: the store lines are concave and the remove lines convex in the power fraction, so the members'
  summed stored energy is at most the merged battery's at the summed charge (Jensen), and every other row is
  linear in the members' sums. The bound is the same as the joint relaxation's.

Only for objectives that see the district's net alone (the peak with no per-building import weight) and plants
without outage steps (an outage is per building). Tanks stay as they are.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from pipeline.optimal import objectives as obj
from pipeline.optimal.plant import BATTERY_SLOT, BatteryTerms, Plant, Storage


def applies(plant: Plant, weights: Mapping[str, float]) -> bool:
    """Whether ``plant`` and ``weights`` allow merging (the peak alone, no outage step, some battery shared)."""
    only_peak = weights[obj.PEAK] > 0 and not any(weights[k] for k in obj.IMPORT_OBJECTIVES)
    return only_peak and not plant.outage[:, 1:].any() and any(len(m) > 1 for m in classes(plant))


def _key(s: Storage) -> tuple:
    """What two batteries must share to run in lockstep (rounded: data sets repeat one battery's values)."""
    b = s.battery

    def r(x) -> tuple:
        return tuple(np.round(np.asarray(x, dtype=float).ravel(), 9))

    return (r(b.efficiency.xs), r(b.efficiency.ys), r(b.lines), r(b.nominal_power / s.capacity), r(s.retention),
            r(b.floor / s.capacity), r(s.initial_energy / s.capacity), r(b.capacity_loss), r(b.initial_efficiency),
            b.extrapolate, r(b.usable_capacity[:1] / s.capacity), r(s.one_way[:1]), r(s.action_scale / s.capacity))


def classes(plant: Plant) -> list[tuple[int, ...]]:
    """Storage indices of ``plant`` grouped: one class per set of batteries that are scaled copies; a tank is
    a class of its own."""
    found: dict[tuple, list[int]] = {}
    out: list[list[int]] = []
    for i, s in enumerate(plant.storages):
        if s.battery is None:
            out.append([i])
            continue
        key = _key(s)
        if key not in found:
            found[key] = []
            out.append(found[key])
        found[key].append(i)
    return [tuple(c) for c in out]


def aggregate(plant: Plant) -> tuple[Plant, list[tuple[int, ...]]]:
    """``plant`` with every class of batteries merged into one (at its first member's building), and the
    classes (storage indices of ``plant`` per storage of the merged plant)."""
    groups = classes(plant)
    storages = tuple(_merged([plant.storages[i] for i in g]) for g in groups)
    return dataclasses.replace(plant, storages=storages), groups


def _merged(members: Sequence[Storage]) -> Storage:
    """One battery of the members' summed capacity, power, energy and floor (a tank alone: itself)."""
    first = members[0]
    if len(members) == 1:
        return first
    b = first.battery
    capacity = sum(s.capacity for s in members)
    terms: BatteryTerms = dataclasses.replace(
        b, nominal_power=sum(s.battery.nominal_power for s in members), floor=sum(s.battery.floor for s in members),
        usable_capacity=sum(s.battery.usable_capacity for s in members))
    return dataclasses.replace(
        first, slot=BATTERY_SLOT, capacity=capacity, initial_energy=sum(s.initial_energy for s in members),
        charge_max=sum(s.charge_max for s in members), action_scale=first.action_scale * capacity / first.capacity,
        battery=terms, low=None, high=None)


def spread(plant: Plant, groups: Sequence[tuple[int, ...]], energy: np.ndarray,
           held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The merged plan (``energy``, ``held``: (len(groups), n) [kWh]) as every storage of ``plant`` runs it:
    each member its share of the class's capacity."""
    n = energy.shape[1]
    out_energy, out_held = np.zeros((len(plant.storages), n)), np.zeros((len(plant.storages), n))
    for row, members in enumerate(groups):
        total = sum(plant.storages[i].capacity for i in members)
        for i in members:
            share = plant.storages[i].capacity / total
            out_energy[i], out_held[i] = share * energy[row], share * held[row]
    return out_energy, out_held
