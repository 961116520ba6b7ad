"""Copies of an env's running state for rollouts: K copies of its district stepped together, each loaded with the
env's state at step t, then run forward under K action sequences (sampling MPC through the LSTM surrogate,
:mod:`pipeline.optimal.surrogate`).

The copies live in one inner :class:`citylearn_env.CityLearnEnv` of K x B buildings (as
:class:`citylearn_env.vector.CityLearnVectorEnv` builds them: building b of copy c is building c x B + b), so
every device, storage and LSTM update of a rollout step is one array operation over all copies. What the state
of an env at step t is, and what :meth:`Rollouts.load` copies (nothing in the env is edited):

* the episode records (end uses, batteries, buildings; (B, T) arrays): only the columns t .. t + H a rollout
  of H steps reads or writes -- the env's later columns still hold their reset values, which also undoes the
  previous rollout;
* the LSTM bank (:class:`citylearn_env.dynamics.LSTMBank`): per architecture group the input window ``buf``,
  the window fill ``count`` and the hidden and cell states ``h`` / ``c`` (slot s of copy c is c x group size +
  s), which model each building ran last (``_current``, instance indices shifted by c x instances per copy)
  and whether it was warm; the cached mode key is cleared so the next step re-derives its groups;
* the district's step counter; once, the episode's outage signal (the copies would draw their own).

Refused (one :class:`pipeline.errors.InputError`): districts with EV chargers, washing machines or occupant
models (their state is not copied).
"""

from __future__ import annotations

import dataclasses
from dataclasses import fields

import numpy as np

from citylearn_env import CityLearnEnv
from pipeline.errors import InputError


class Rollouts:
    """``copies`` copies of ``env``'s district (after ``env.reset(seed=seed)``, same episode)."""

    def __init__(self, env: CityLearnEnv, copies: int, *, seed: int = 0):
        d = env.district
        if d.ev is not None or d.machines is not None or d.occupants is not None:
            raise InputError("rollouts copy storages, devices and the LSTM; districts with EV chargers, washing "
                             "machines or occupant models are not supported", column="buildings")
        config = env.config
        buildings = tuple(dataclasses.replace(b, name=f"{b.name}#{c}") for c in range(copies)
                          for b in config.buildings)
        self.inner = CityLearnEnv(config.replace(buildings=buildings), settings=env.settings,
                                  reward_function="default", central_agent=True)
        self.inner.reset(seed=seed)
        inner = self.inner.district
        outage = np.tile(d.episode.outage, (copies, 1))  # the env's drawn outages, not the copies' own draws
        inner.episode = dataclasses.replace(inner.episode, outage=outage)
        inner._outage_steps = (outage > 0).any(axis=0)
        self.copies, self.n = copies, d.n
        self.actions_per_copy = len(env.action_pairs)
        if self.inner.district.length != d.length:
            raise InputError("the rollout copies did not get the env's episode", column="episode_time_steps")

    def load(self, env: CityLearnEnv, steps: int) -> None:
        """Put every copy in ``env``'s state at its current step t, for a rollout of ``steps`` steps."""
        src, dst = env.district, self.inner.district
        t = src.t
        cut = slice(t, min(t + steps + 1, src.length))
        for a, b in _records(src, dst):
            for f in fields(a):
                getattr(b, f.name)[:, cut] = np.tile(getattr(a, f.name)[:, cut], (self.copies, 1))
        if src.thermal is not None:
            _load_bank(src.thermal.bank, dst.thermal.bank, self.copies)
        dst.t = t

    def step(self, actions: np.ndarray) -> None:
        """Advance every copy one step; ``actions`` (K, A): copy k's action vector (the env's layout)."""
        inner = self.inner
        inner.district.step(inner.action_layout.actions(np.asarray(actions, dtype=np.float64).reshape(-1)))

    def column(self, record: np.ndarray, t: int) -> np.ndarray:
        """(K, B) values of an inner record (K x B, T) at step ``t``."""
        return record[:, t].reshape(self.copies, self.n)


def _records(src, dst) -> list[tuple[object, object]]:
    """(env record, inner record) pairs: every end use's, the batteries' and the buildings'."""
    pairs = [(a.record, b.record) for a, b in zip(src.end_uses, dst.end_uses, strict=True)]
    return pairs + [(src.battery_record, dst.battery_record), (src.building_record, dst.building_record)]


def _load_bank(src, dst, copies: int) -> None:
    """Copy an LSTM bank's state into the bank of ``copies`` copies of its buildings."""
    for a, b in zip(src._groups, dst._groups, strict=True):
        b.buf[:] = np.tile(a.buf, (copies, 1, 1))
        b.count[:] = np.tile(a.count, copies)
        b.h[:] = np.tile(a.h, (copies, 1, 1))
        b.c[:] = np.tile(a.c, (copies, 1, 1))
    per_copy = len(src._inst_group)
    shift = (np.arange(copies) * per_copy)[:, None]
    dst._current = np.where(src._current >= 0, src._current[None, :] + shift, -1).reshape(-1)
    dst._warm_flags = np.tile(src._warm_flags, copies)
    dst._modes_key = b""  # the next step re-derives the group members from the modes
    dst._members = []
