"""MPC through the LSTM surrogate for heat-pump configurations (issue 29, part 3): the heat pump's action sets
the cooling (heating) energy, the LSTM turns the delivered energy into the indoor temperature, and the
objective is the electricity cost plus a discomfort penalty -- a nonconvex problem the storage LP cannot hold.

Method: the cross-entropy method (CEM) over the next ``horizon`` actions, each candidate rolled out in the
env's own dynamics (:class:`pipeline.optimal.snapshot.Rollouts`: K copies of the district loaded with the env's
state at t, stepped together). Why sampling and why CEM:

* the env's LSTM runs forward only (numba/numpy kernels, no autodiff), and the step around it is piecewise
  (the device clip min(max(a, 0) x P, P), max(net, 0) in the cost, the kink of the penalty, the warm-up rule),
  so gradient shooting would need a second differentiable copy of the model and would still meet the kinks;
  sampling needs only forward rollouts, in the env's exact dynamics, and K rollouts cost one batched step;
* CEM refits a Gaussian to the best ``elites`` samples: its only scale is the action range, whereas MPPI's
  temperature must match the objective's units (dollars plus weighted degrees) to weigh samples well.

Each step: the mean starts from the last plan shifted by one step; the first candidates of the first round
are that plan, the data set's ideal load (the action that asks the heat pump for the data set's demand,
:func:`ideal_actions`) and doing nothing (0), so the chosen plan is never predicted worse than those; the best
sample seen in any round is applied (its first action). Random numbers come from one
``numpy.random.default_rng(seed)`` per episode: two runs with one seed are identical.

Objective over steps t + 1 .. t + H (and for the episode, :func:`episode_value`): cost [$] = sum of
max(net, 0) x price, plus ``comfort_weight`` [$ per degC-step] x the paper's heat-pump penalty (the
discomfort_consumption reward of pipeline/paper/benchmarks.py, benchmark rlc-b1-d_o-hp): 3 x |T - T_set|
when the building is colder than the set point (over-cooling wastes energy), |T - T_set| when warmer.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.controllers import run_episode
from pipeline.errors import InputError
from pipeline.optimal.snapshot import Rollouts

#: the paper's over-cooling multiplier (ComfortAndConsumptionReductionReward's default, benchmark multiplier 3)
OVER_COOLING = 3.0
#: $ per degC-step of penalty (the objective adds it to the cost); 0.1 makes 1 degC over one hour cost as much
#: as ~3 kWh at the 2023 data sets' prices
COMFORT_WEIGHT = 0.1
SET_POINT = "indoor_dry_bulb_temperature_set_point"
DEVICES = {"cooling_device": "cooling", "heating_device": "heating"}


@dataclass(frozen=True)
class Cem:
    """CEM settings: ``samples`` per round (K rollouts), ``elites`` refitted, ``rounds`` per step, initial
    standard deviation ``spread`` [fraction of the action range], and ``floor`` the least it may shrink to."""

    samples: int = 32
    elites: int = 6
    rounds: int = 3
    spread: float = 0.3
    floor: float = 0.02


@dataclass(frozen=True)
class SurrogateRun:
    """A surrogate-MPC episode: ``value`` (cost + weight x penalty over steps 1 .. T - 1), its ``cost`` [$] and
    ``penalty`` [degC-step], the env's ``objectives``, the ``horizon`` [steps] and wall ``seconds``."""

    value: float
    cost: float
    penalty: float
    objectives: Mapping[str, float]
    horizon: int
    seconds: float


def penalty(temperature: np.ndarray, set_point: np.ndarray) -> np.ndarray:
    """The paper's heat-pump discomfort [degC]: 3 x |T - T_set| below the set point, |T - T_set| above."""
    delta = temperature - set_point
    return np.where(delta < 0.0, -OVER_COOLING * delta, delta)


def step_value(net: np.ndarray, price: np.ndarray, temperature: np.ndarray, set_point: np.ndarray,
               dynamics: np.ndarray, weight: float) -> np.ndarray:
    """Objective of one step per copy: arrays (K, B); the penalty counts in LSTM buildings (``dynamics`` (B,))."""
    cost = (np.maximum(net, 0.0) * price).sum(axis=1)
    return cost + weight * (penalty(temperature, set_point) * dynamics).sum(axis=1)


def episode_value(env, weight: float = COMFORT_WEIGHT) -> tuple[float, float, float]:
    """(value, cost [$], penalty [degC-step]) of ``env``'s episode so far over steps 1 .. t."""
    d, t = env.district, env.t
    cut = slice(1, t + 1)
    net = d.building_record.net_electricity_consumption[:, cut]
    cost = float((np.maximum(net, 0.0) * env.data("electricity_pricing")[:, cut]).sum())
    hurt = penalty(d.building_record.indoor_dry_bulb_temperature[:, cut], env.data(SET_POINT)[:, cut])
    pen = float((hurt * d.dynamics[:, None]).sum())
    return cost + weight * pen, cost, pen


def ideal_actions(env, t: int) -> np.ndarray:
    """The action vector at step ``t`` asking every heat pump for the data set's demand (demand / (nominal
    power x COP), within the action bounds); 0 for every other action."""
    out = np.zeros(len(env.action_pairs))
    d = env.district
    for j, (name, b) in enumerate(env.action_pairs):
        use = DEVICES.get(name)
        if use is not None:
            u = d.end_use(use)
            reach = u.params.nominal_power[b] * u.cop[b, t]
            out[j] = u.demand_data[b, t] / reach if reach > 0 else 0.0
    return np.clip(out, env.action_layout.low, env.action_layout.high)


class Planner:
    """CEM over the next ``horizon`` actions of ``env`` through :class:`Rollouts`."""

    def __init__(self, env, horizon: int, cem: Cem, weight: float, seed: int):
        self.env, self.horizon, self.cem, self.weight = env, horizon, cem, weight
        self.rollouts = Rollouts(env, cem.samples, seed=seed)
        self.rng = np.random.default_rng(seed)
        self.low, self.high = env.action_layout.low, env.action_layout.high
        self.plan = None  # the last plan (H, A)

    def __call__(self, _observation) -> np.ndarray:
        env, t = self.env, self.env.t
        length = min(self.horizon, env.district.length - 1 - t)
        mean = self._start(t, length)
        best, best_value = mean, np.inf
        std = np.broadcast_to(self.cem.spread * (self.high - self.low), mean.shape).copy()
        for r in range(self.cem.rounds):
            samples = np.clip(mean + std * self.rng.standard_normal((self.cem.samples, *mean.shape)),
                              self.low, self.high)
            if r == 0:
                fixed = self._candidates(t, length, mean)
                samples[:len(fixed)] = fixed
            values = self.evaluate(samples)
            order = np.argsort(values, kind="stable")
            if values[order[0]] < best_value:
                best, best_value = samples[order[0]], float(values[order[0]])
            elite = samples[order[:self.cem.elites]]
            mean = elite.mean(axis=0)
            std = np.maximum(elite.std(axis=0), self.cem.floor * (self.high - self.low))
        self.plan = best
        return best[0]

    def _start(self, t: int, length: int) -> np.ndarray:
        """The last plan shifted by one step (its last action repeated), else the ideal load, (length, A)."""
        if self.plan is None:
            return np.stack([ideal_actions(self.env, t + 1 + i) for i in range(length)])
        shifted = np.concatenate([self.plan[1:], self.plan[-1:]])
        return shifted[:length]

    def _candidates(self, t: int, length: int, mean: np.ndarray) -> np.ndarray:
        """Sequences every step tries: the shifted plan, the ideal load and 0, (3, length, A)."""
        ideal = np.stack([ideal_actions(self.env, t + 1 + i) for i in range(length)])
        return np.stack([mean, ideal, np.clip(np.zeros_like(mean), self.low, self.high)])

    def evaluate(self, samples: np.ndarray) -> np.ndarray:
        """Objective of each sequence (K, length, A) over steps t + 1 .. t + length, rolled out from now."""
        env, roll = self.env, self.rollouts
        t = env.t
        roll.load(env, samples.shape[1])
        d = roll.inner.district
        rec = d.building_record
        price, set_point = env.data("electricity_pricing"), env.data(SET_POINT)
        total = np.zeros(samples.shape[0])
        for i in range(samples.shape[1]):
            roll.step(samples[:, i])
            s = t + 1 + i
            total += step_value(roll.column(rec.net_electricity_consumption, s), price[:, s],
                                roll.column(rec.indoor_dry_bulb_temperature, s), set_point[:, s],
                                env.district.dynamics, self.weight)
        return total


def surrogate_mpc(env, *, horizon: int = 6, seed: int = 0, comfort_weight: float = COMFORT_WEIGHT,
                  cem: Cem = Cem()) -> SurrogateRun:
    """Run one episode of ``env`` (reset with ``seed``) under CEM MPC through the env's LSTM dynamics; the
    objective is cost + ``comfort_weight`` x the paper's heat-pump penalty (module docstring)."""
    if horizon < 1:
        raise InputError(f"the horizon must be at least 1 step, got {horizon}", column="horizon")
    if not 1 <= cem.elites <= cem.samples or cem.samples < 3 or cem.rounds < 1:
        raise InputError(f"CEM needs 3 <= samples, 1 <= elites <= samples and rounds >= 1, got {cem}", column="cem")
    began = time.perf_counter()
    env.reset(seed=seed)
    if env.district.thermal is None or not any(name in DEVICES for name, _ in env.action_pairs):
        raise InputError("surrogate MPC controls heat pumps of LSTM buildings: the env has no dynamics building "
                         "or no active cooling_device / heating_device action", column="actions")
    planner = Planner(env, horizon, cem, comfort_weight, seed)
    run_episode(env, planner, seed)
    value, cost, pen = episode_value(env, comfort_weight)
    objectives = {k: float(v) for k, v in env.objectives().items() if k != "per_building"}
    return SurrogateRun(value=value, cost=cost, penalty=pen, objectives=objectives, horizon=horizon,
                        seconds=time.perf_counter() - began)


def fixed_policy_value(env, policy: str, *, seed: int = 0, comfort_weight: float = COMFORT_WEIGHT) -> float:
    """The objective of a reference policy on ``env``: "ideal" (the heat pumps asked for the data set's
    demand, :func:`ideal_actions`) or "zero" (every action 0)."""
    if policy not in ("ideal", "zero"):
        raise InputError(f"policy must be 'ideal' or 'zero', not {policy!r}", column="policy")
    zero = np.zeros(len(env.action_pairs))
    run_episode(env, lambda _: ideal_actions(env, env.t + 1) if policy == "ideal" else zero, seed)
    return episode_value(env, comfort_weight)[0]
