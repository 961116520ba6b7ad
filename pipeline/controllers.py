"""The paper's rule-based controllers, written from their description (reference/paper_application.md).

Hour convention: CityLearn's ``hour`` h is the hour *ending* at h:00 (h = 1 is 00:00-01:00). A rule acts on
the time step it controls: the action passed to ``step`` at time t is applied at t + 1, so the rules read
the hour and day type of t + 1 (the published code read those of t, one hour early). Values are fractions
of storage capacity per hour, the same for every storage of a building.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.actions import DEVICE_ACTIONS
from citylearn_env.config import DistrictConfig

OFF_PEAK = {23, 24, 1, 2, 3, 4, 5, 6, 7}        # 10 PM - 7 AM
ON_PEAK = {16, 17, 18}                           # 3 PM - 6 PM


def cost_rbc(hour: int, day_type: int) -> float:
    """TOU cost rule: weekdays charge fully off-peak, discharge half on-peak and the rest at other hours;
    weekends and holidays (flat cheap rate) charge at a constant 1/24 of capacity per hour."""
    if day_type >= 6:
        return 1.0 / 24.0
    if hour in OFF_PEAK:
        return 1.0 / len(OFF_PEAK)
    if hour in ON_PEAK:
        return -0.5 / len(ON_PEAK)
    return -0.5 / (24 - len(OFF_PEAK) - len(ON_PEAK))


def _charge_then_discharge(hour: int, charge_until: int, discharge_from: int) -> float:
    """Charge evenly over hours ending 1..``charge_until``, discharge evenly over ``discharge_from``..23."""
    if hour <= charge_until:
        return 1.0 / charge_until
    if discharge_from <= hour <= 23:
        return -1.0 / (24 - discharge_from)
    return 0.0


def emission_rbc(hour: int, day_type: int) -> float:
    """Charge fully before 8 AM (hours ending 1-8); discharge at a constant rate 12 PM - 11 PM (13-23)."""
    return _charge_then_discharge(hour, 8, 13)


def peak_rbc(hour: int, day_type: int) -> float:
    """Charge fully before 6 AM (hours ending 1-6); discharge steadily 6 AM - 11 PM (hours ending 7-23)."""
    return _charge_then_discharge(hour, 6, 7)


RULES = {"cost_rbc": cost_rbc, "emission_rbc": emission_rbc, "peak_rbc": peak_rbc}
#: the objective (a key of ``citylearn_env.kpis.objectives``) each rule is written to lower
RULE_OBJECTIVES = {"cost_rbc": "cost", "emission_rbc": "emissions", "peak_rbc": "average_daily_peak"}
#: why a rule can do worse than no control on its own objective (``period``: how the caller names its span)
MISFIT_REASON = "its fixed charge and discharge hours do not pay on this district's signals over the {period}"


# ------------------------------------------------------------------ the rules as the paper's code has them
def published_cost_rbc(hour: int, day_type: int) -> float:
    """SimBuild ``AustinEnergyTOURBC`` as published: "weekdays" are day types 2-6 (Tue-Sat; the data's
    weekdays are 1-5), off-peak is hours >= 22 or < 7, on-peak hours 15-17 (the price peak is 16-18);
    weekends and holidays (day types 1, 7, 8) charge 1/48 per hour."""
    if not 2 <= day_type <= 6:
        return 1.0 / 48.0
    if hour >= 22 or hour < 7:
        return 1.0 / 9.0
    if 15 <= hour < 18:
        return -0.5 / 3.0
    return -0.5 / 12.0


def published_emission_rbc(hour: int, day_type: int) -> float:
    """SimBuild ``AustinEnergyEmissionReductionRBC`` as published: +1/7 for hours <= 7, -1/11 for 12-22."""
    if hour <= 7:
        return 1.0 / 7.0
    if 12 <= hour <= 22:
        return -1.0 / 11.0
    return 0.0


def published_peak_rbc(hour: int, day_type: int) -> float:
    """SimBuild ``PeakReductionRBC`` as published: -1/14 at hour 6 and 11-22, +1/5 before hour 6."""
    if hour == 6 or 11 <= hour <= 22:
        return -1.0 / 14.0
    if hour < 6:
        return 1.0 / 5.0
    return 0.0


PUBLISHED_RULES = {"cost_rbc": published_cost_rbc, "emission_rbc": published_emission_rbc,
                   "peak_rbc": published_peak_rbc}
#: rule set -> (rules by name, which time step's hour/day type a rule reads: 1 = the step it controls,
#: t + 1, as described; 0 = the observation's own step t, as the published code does -- one hour early)
RULE_SETS = {"described": (RULES, 1), "published": (PUBLISHED_RULES, 0)}


def rule_actions(env, rule, lookahead: int = 1) -> np.ndarray:
    """The action vector of ``rule`` for the step that controls t + 1 (storage actions; devices left at 0).

    ``lookahead`` 1: the rule reads the hour and day type of t + 1, the step the action controls (the rules
    as described); 0: those of t, the observation's own step (the published code).
    """
    t = min(env.t + lookahead, env.episode_length - 1)
    hour = int(env.data("hour")[0, t])
    day_type = int(env.data("day_type")[0, t])
    value = rule(hour, day_type)
    return np.array([value if name.endswith("_storage") else 0.0 for name in env.action_names])


def without_device_actions(config: DistrictConfig) -> DistrictConfig:
    """``config`` with the heat-pump and heater actions inactive (the devices then serve the ideal load);
    every other active action of each building is kept."""
    def kept(building) -> tuple[str, ...]:
        return tuple(a for a in building.active_actions if a not in DEVICE_ACTIONS)

    per_building = {kept(b) for b in config.buildings}
    if len(per_building) == 1:
        return config.with_actions(per_building.pop())
    return config.replace(buildings=tuple(dataclasses.replace(b, active_actions=kept(b)) for b in config.buildings))


def run_policy(schema: str | Path | Mapping[str, Any] | DistrictConfig, policy: str, *, seed: int = 0,
               ideal_cooling: bool = True, settings: str | None = None):
    """Run one episode with ``policy`` (no_control, random, cost_rbc, emission_rbc, peak_rbc); return the env.

    ``schema``: a loaded :class:`DistrictConfig` (loaded once by the caller) or a schema path/dict (loaded
    here). ``ideal_cooling`` deactivates heat-pump actions so the heat pump serves the ideal load (the paper's
    storage benchmarks); all actions are 0 under no_control; ``random`` samples the action space (seeded).
    ``settings``: the environment's upstream behaviour (a preset name or Behaviour; default corrected).
    """

    rule = RULES.get(policy)
    if rule is None and policy not in ("no_control", "random"):
        raise ValueError(f"unknown policy {policy!r}; known: no_control, random, {', '.join(RULES)}")
    config = schema if isinstance(schema, DistrictConfig) else load_schema(schema, settings=settings)
    if ideal_cooling:
        config = without_device_actions(config)
    env = CityLearnEnv(config, settings=settings)
    if rule is not None:
        run_episode(env, lambda _: rule_actions(env, rule), seed)
    elif policy == "random":
        run_episode(env, lambda _: env.action_space.sample(), seed)
    else:
        run_episode(env, lambda _: np.zeros(env.action_space.shape), seed)
    return env


def run_episode(env, act: Callable[[np.ndarray], np.ndarray], seed: int = 0) -> list[np.ndarray]:
    """THE episode loop: reset ``env`` (a CityLearnEnv) and its action space with ``seed``, then step with
    ``act(observation)`` until the episode ends; returns the actions taken (action ``k`` controls step ``k + 1``)."""
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = []
    terminated = False
    while not terminated:
        action = act(obs)
        actions.append(action)
        obs, _, terminated, _, _ = env.step(action)
    return actions
