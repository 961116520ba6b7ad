"""Replay an oracle schedule in the environment: schedule -> the env's action vectors -> one episode through
:func:`pipeline.controllers.run_episode` -> the env's own objectives (``CityLearnEnv.objectives``).

Two ways to follow a plan:

* ``track="soc"`` (default): at every step each storage is asked for the device-side energy that takes it from
  the state of charge the env reports to the plan's next one (through the env's own storage model: standing
  loss, one-way efficiency, the battery's power-efficiency curve). Where env and plan agree, that is the
  planned energy; a small difference (the plan's tolerance on the battery efficiencies) is corrected at the
  next step instead of carried along.
* ``track="energy"``: the planned device-side energies, open loop (the schedule's ``action`` column as is).
  Exact for tanks; for batteries a plan that discharges at the state-of-charge-dependent power limit (above
  80 % SOC on CityLearn's curve) amplifies a tiny SOC difference each time (a fuller battery may discharge
  less, so it stays fuller), which shows as a gap of up to ~0.1 % on the peak objective.

The action of a storage is a device-side energy divided by its action scale (capacity, or for a battery
under ``battery_action_fraction_of_nominal_power`` its nominal power x step hours): the env turns it back into
the same request, and the LP keeps every planned request inside the limits the env clips to (device headroom,
demand, capacity-power curve, free capacity, depth of discharge).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from citylearn_env import devices
from pipeline.controllers import run_episode
from pipeline.optimal import objectives as obj
from pipeline.optimal.oracle import Schedule
from pipeline.optimal.plant import BATTERY_SLOT

#: fixed-point steps solving energy = stored change / sqrt(efficiency(energy)) for a battery
EFFICIENCY_STEPS = 4


@dataclass(frozen=True)
class Replay:
    """The env's objectives under the schedule and the relative gap (env - plan) / |plan| per objective
    (NaN where the plan is 0); ``soc_gap``: largest |env SOC - planned SOC| over storages and steps."""

    objectives: Mapping[str, float]
    gap: Mapping[str, float]
    soc_gap: float


def schedule_actions(env, schedule: Schedule) -> np.ndarray:
    """The open-loop action vectors of ``schedule`` for ``env``, (T - 1, A): row k is passed to the k-th
    ``step`` call (it controls step k + 1). Actions the schedule does not plan (inactive storages, devices) are 0."""
    out = np.zeros((schedule.action.shape[1] - 1, len(env.action_pairs)))
    for j, row in positions(env, schedule.storages):
        out[:, j] = schedule.action[row, 1:]
    return out


def positions(env, storages) -> list[tuple[int, int]]:
    """(action vector position, row) of every storage of ``storages`` ((building name, slot) per row)."""
    rows = {key: i for i, key in enumerate(storages)}
    names = env.building_names
    return [(j, rows[(names[b], name)]) for j, (name, b) in enumerate(env.action_pairs) if (names[b], name) in rows]


class SocTracker:
    """The ``track="soc"`` policy: called with an observation, returns the action vector that moves every
    planned storage from its current env state to the plan's state at the next step."""

    def __init__(self, env, schedule: Schedule):
        self.env, self.schedule = env, schedule
        pairs = env.action_pairs
        self.groups: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for j, row in positions(env, schedule.storages):
            slot, b = pairs[j]
            position, rows, buildings = self.groups.get(slot, ((), (), ()))
            self.groups[slot] = ((*position, j), (*rows, row), (*buildings, b))
        self.groups = {k: tuple(np.array(v, dtype=np.intp) for v in g) for k, g in self.groups.items()}

    def __call__(self, _observation) -> np.ndarray:
        t = self.env.t
        out = np.zeros(len(self.env.action_pairs))
        for slot, (position, rows, buildings) in self.groups.items():
            energy = self._energy(slot, rows, buildings, t)
            out[position] = energy / self.schedule.scale[rows]
        return out

    def _energy(self, slot: str, rows: np.ndarray, buildings: np.ndarray, t: int) -> np.ndarray:
        """Device-side energy [kWh] taking the storages from their state at t to the plan's at t + 1."""
        d = self.env.district
        if slot == BATTERY_SLOT:
            bat = d.battery
            soc, capacity, loss = d.battery_record.soc[buildings, t], bat.capacity[buildings], \
                bat.loss_coefficient[buildings]
        else:
            use = d.end_use(slot.removesuffix("_storage"))
            soc, capacity, loss = use.record.storage_soc[buildings, t], use.params.tank.capacity[buildings], \
                use.params.tank.loss_coefficient[buildings]
        change = self.schedule.held[rows, t + 1] - np.maximum(0.0, soc * capacity * (1.0 - loss))
        if slot != BATTERY_SLOT:
            one_way = use.params.tank.one_way_efficiency[buildings]
            return np.where(change >= 0, change / one_way, change * one_way)
        energy = self.schedule.energy[rows, t + 1]
        for _ in range(EFFICIENCY_STEPS):
            one_way = np.sqrt(self._efficiency(energy, buildings))
            energy = np.where(change >= 0, change / one_way, change * one_way)
        return energy

    def _efficiency(self, energy: np.ndarray, buildings: np.ndarray) -> np.ndarray:
        """The env's round-trip efficiency of each battery at device-side ``energy`` [kWh]."""
        bat = self.env.district.battery
        x = np.zeros(len(bat.capacity))
        x[buildings] = np.abs(energy) * bat.inverse_nominal_power[buildings]
        flag = self.env.settings.battery_curve_extrapolates_first_segment
        return devices.interpolate_curve(x, bat.power_efficiency, extrapolate_first_segment=flag)[buildings]


def replay(env, schedule: Schedule, *, seed: int = 0, track: str = "soc") -> Replay:
    """Run one episode of ``env`` (reset with ``seed``: the same seed the schedule was planned for) following
    the schedule (``track``: "soc" or "energy", see the module docstring); return the env's objectives and
    their gap to the plan."""
    if track == "energy":
        steps = iter(schedule_actions(env, schedule))
        run_episode(env, lambda _: next(steps), seed)
    elif track == "soc":
        run_episode(env, SocTracker(env, schedule), seed)
    else:
        raise ValueError(f"track must be 'soc' or 'energy', not {track!r}")
    objectives = {k: float(v) for k, v in env.objectives().items() if k in obj.OBJECTIVES}
    price, carbon = env.data("electricity_pricing"), env.data("carbon_intensity")
    planned = obj.values(schedule.net, price, carbon)
    gap = {k: (objectives[k] - planned[k]) / abs(planned[k]) if planned[k] else float("nan") for k in obj.OBJECTIVES}
    return Replay(objectives=objectives, gap=gap, soc_gap=_soc_gap(env, schedule))


def _soc_gap(env, schedule: Schedule) -> float:
    """Largest |env SOC - planned SOC| over the scheduled storages and steps."""
    series = env.series()
    names = list(env.building_names)
    worst = 0.0
    for row, (building, slot) in enumerate(schedule.storages):
        soc = series[f"{slot}_soc"][names.index(building)]
        worst = max(worst, float(np.abs(soc - schedule.soc[row]).max()))
    return worst
