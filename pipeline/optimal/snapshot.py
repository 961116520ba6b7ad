"""Copies of an env's running state for rollouts: K copies of its district stepped together, each loaded with the
env's state at step t, then run forward under K action sequences (sampling MPC through the LSTM surrogate,
:mod:`pipeline.optimal.surrogate`).

The copies live in one inner :class:`citylearn_env.CityLearnEnv` of K x B buildings (as
:class:`citylearn_env.vector.CityLearnVectorEnv` builds them: building b of copy c is building c x B + b), so
every device, storage and LSTM update of a rollout step is one array operation over all copies. What the state
of an env at step t is, and what :meth:`Rollouts.load` copies through
:meth:`citylearn_env.district.District.load_tiled` (nothing in the env is edited):

* the episode records (end uses, batteries, buildings; (B, T) arrays): only the columns t .. t + H a rollout
  of H steps reads or writes -- the env's later columns still hold their reset values, which also undoes the
  previous rollout;
* the LSTM bank (:class:`citylearn_env.dynamics.LSTMBank`): per architecture group the input window ``buf``,
  the window fill ``count`` and the hidden and cell states ``h`` / ``c`` (slot s of copy c is c x group size +
  s), which model each building ran last (instance indices shifted by c x instances per copy)
  and whether it was warm; the cached mode key is cleared so the next step re-derives its groups;
* the district's step counter; once, the episode's outage signal (the copies would draw their own).

Refused (one :class:`pipeline.errors.InputError`): districts with EV chargers, washing machines or occupant
models (their state is not copied).
"""

from __future__ import annotations

import dataclasses

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
        inner.use_outage(np.tile(d.episode.outage, (copies, 1)))  # the env's drawn outages, not the copies' own
        self.copies, self.n = copies, d.n
        self.actions_per_copy = len(env.action_pairs)
        if self.inner.district.length != d.length:
            raise InputError("the rollout copies did not get the env's episode", column="episode_time_steps")

    def load(self, env: CityLearnEnv, steps: int) -> None:
        """Put every copy in ``env``'s state at its current step t, for a rollout of ``steps`` steps."""
        self.inner.district.load_tiled(env.district, self.copies, steps)

    def step(self, actions: np.ndarray) -> None:
        """Advance every copy one step; ``actions`` (K, A): copy k's action vector (the env's layout)."""
        inner = self.inner
        inner.district.step(inner.action_layout.actions(np.asarray(actions, dtype=np.float64).reshape(-1)))

    def column(self, record: np.ndarray, t: int) -> np.ndarray:
        """(K, B) values of an inner record (K x B, T) at step ``t``."""
        return record[:, t].reshape(self.copies, self.n)

