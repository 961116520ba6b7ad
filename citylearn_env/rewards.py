"""Reward functions: callables over the named observations of every building at step t.

A reward is built once (``make_reward(spec, context)``), reset at each episode start with a
:class:`RewardContext`, and called each step with ``obs``: observation name -> (B,) array of raw values (the
full per-building observation dict CityLearn gives its reward functions, e.g. ``net_electricity_consumption``
kWh, ``electricity_pricing`` $/kWh, ``indoor_dry_bulb_temperature`` degC, ``dhw_storage_soc`` 0..1). It returns
``(value, terms)``: a float for a central agent, a (B,) array otherwise, and named per-building components.

Upstream classes (CityLearn 2.1 ``citylearn.reward_function``, plus 2.5's ``Electric_Vehicles_Reward_Function``,
which reads the EV chargers through ``RewardContext.chargers``) and the SimBuild 2024 classes
(``src.reward_function``) are registered under their dotted type strings in :data:`REWARDS`, next to short
names for the paper's four objectives. Upstream's bugs are kept where the :class:`~citylearn_env.settings.Behaviour`
passed as ``settings`` asks for them (``independent_sac_reward_precedence_bug``, ``comfort_reward_float32``,
``storage_signal_reward_multiplies_by_delta``, ``ev_reward_skips_unplugged_chargers``,
``ev_reward_squares_soc_under_weight``; the default :data:`~citylearn_env.settings.CORRECTED` fixes them all;
docs/environment_kpis.md, docs/ev.md).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from citylearn_env.actions import STORAGE_ACTIONS
from citylearn_env.district import District
from citylearn_env.errors import SchemaError
from citylearn_env.ev import NO_EV, plugged_ev
from citylearn_env.settings import CORRECTED, Behaviour

#: what a reward is called with: observation name -> (B,) raw values of every building at the step
Observations = Mapping[str, np.ndarray]
#: a reward's named components: term name -> (B,) per-building values
Terms = dict[str, np.ndarray]
#: storages whose capacity does not exceed this (kWh) count as absent (CityLearn's zero-division placeholder)
ZERO_CAPACITY = 1e-6


@dataclass(frozen=True, eq=False)
class ChargerStep:
    """What a reward sees of every EV charger at one step, (C,) arrays in charger order.

    ``building``: index of the charger's building; ``connected``: an EV is plugged in (row state 1);
    ``action_energy`` [kWh]: the charger-side energy the action asked for (action x max power within the
    charger's limits, before the battery clips it; upstream's ``last_charged_kwh``). For the plugged-in EV (0
    where none): ``previous_soc`` and ``soc`` [0..1] before and after the step (as recorded, docs/ev.md
    section 4), nominal ``capacity`` [kWh], ``min_capacity`` = (1 - depth of discharge) x capacity [kWh],
    ``required_soc`` [0..1, -0.1 missing] and ``hours_until_departure`` [h]: the row's departure time [steps]
    x step hours. ``max_charging_power`` / ``max_discharging_power`` [kW] of the charger."""

    building: np.ndarray
    connected: np.ndarray
    action_energy: np.ndarray
    previous_soc: np.ndarray
    soc: np.ndarray
    capacity: np.ndarray
    min_capacity: np.ndarray
    required_soc: np.ndarray
    hours_until_departure: np.ndarray
    max_charging_power: np.ndarray
    max_discharging_power: np.ndarray


def charger_step(district: District, t: int | None = None) -> ChargerStep:
    """The chargers of ``district`` at step ``t`` (default its current step ``district.t``; the step acted on
    with ``settings.act_then_advance``), after that step's actions, read from its typed state (``ev_data``,
    ``ev_record``, ``charger_record``)."""
    t = district.t if t is None else t
    section, data = district.ev, district.ev_data
    battery = section.vehicles.battery
    ev = plugged_ev(data, t)
    connected = ev != NO_EV
    v = np.maximum(ev, 0)
    soc = district.ev_record.soc
    previous = soc[v, t - 1] if t > 0 else battery.initial_soc[v]
    capacity = battery.capacity[v]

    def plugged(values: np.ndarray) -> np.ndarray:
        return np.where(connected, values, 0.0)

    return ChargerStep(
        building=np.asarray(section.chargers.building), connected=connected,
        action_energy=district.charger_record.action_energy[:, t], previous_soc=plugged(previous),
        soc=plugged(soc[v, t]), capacity=plugged(capacity),
        min_capacity=plugged((1.0 - battery.depth_of_discharge[v]) * capacity),
        required_soc=plugged(data.required_soc_departure[:, t]),
        hours_until_departure=plugged(data.departure_time[:, t] * district.step_hours),
        max_charging_power=section.chargers.max_charging_power,
        max_discharging_power=section.chargers.max_discharging_power)


@dataclass(frozen=True)
class RewardContext:
    """Static facts a reward needs: agent mode, building names, storage capacities (kWh) and initial SOCs
    (0..1) per storage kind as (B,) arrays, and the active-action mask per action name as (B,) bool arrays.
    ``chargers``: returns the EV chargers' :class:`ChargerStep` at the current step (None: no chargers)."""

    central_agent: bool
    building_names: Sequence[str]
    capacity: Mapping[str, np.ndarray] = field(default_factory=dict)
    initial_soc: Mapping[str, np.ndarray] = field(default_factory=dict)
    active_actions: Mapping[str, np.ndarray] = field(default_factory=dict)
    chargers: Callable[[], ChargerStep] | None = None

    @property
    def n_buildings(self) -> int:
        return len(self.building_names)

    def storage_capacity(self, kind: str) -> np.ndarray:
        """Capacity (kWh) of storage ``kind`` per building; zeros when the district has none."""
        return np.asarray(self.capacity.get(kind, np.zeros(self.n_buildings)), dtype=float)

    def storage_initial_soc(self, kind: str) -> np.ndarray:
        return np.asarray(self.initial_soc.get(kind, np.zeros(self.n_buildings)), dtype=float)

    def action_active(self, name: str) -> np.ndarray:
        return np.asarray(self.active_actions.get(name, np.zeros(self.n_buildings, bool)), dtype=bool)


def _get(obs: Mapping[str, np.ndarray], name: str, default: float | None = None) -> np.ndarray:
    try:
        return np.asarray(obs[name], dtype=float)
    except KeyError:
        if default is None:
            raise KeyError(f"reward needs observation {name!r}, which the environment does not provide") from None
    net = np.asarray(obs["net_electricity_consumption"], dtype=float)
    return np.full(net.shape, default)


class Reward:
    """Base class: per-building values aggregated by sum (CityLearn) or mean for a central agent.
    ``settings`` selects which upstream quirks a subclass reproduces (each reads its own field)."""

    central_aggregate = "sum"
    #: the reward of N copies of a district may be computed in one call over all copies' buildings
    #: (:class:`citylearn_env.vector.CityLearnVectorEnv`): its central value is the sum (or mean, per
    #: ``central_aggregate``) of per-building values, each of which depends only on that building's
    #: observations, its own state and data every copy shares. A subclass whose value mixes buildings (a
    #: district total, a central peak) or that overrides ``__call__`` sets False: one reward object per copy.
    batchable: ClassVar[bool] = True

    def __init__(self, *, settings: Behaviour = CORRECTED) -> None:
        if not isinstance(settings, Behaviour):
            raise TypeError(f"settings must be a Behaviour, not {type(settings).__name__}")
        self.settings = settings
        self.context: RewardContext | None = None

    def reset(self, context: RewardContext) -> None:
        self.context = context

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        raise NotImplementedError

    def _check(self) -> None:
        if self.context is None:
            raise RuntimeError(f"{type(self).__name__}: call reset(context) before the first step")

    def __call__(self, obs: Observations) -> tuple[float | np.ndarray, Terms]:
        self._check()
        values, terms = self.building_values(obs)
        return self.aggregate(values), terms

    def aggregate(self, values: np.ndarray) -> float | np.ndarray:
        if not self.context.central_agent:
            return values
        return float(values.mean() if self.central_aggregate == "mean" else values.sum())


# ------------------------------------------------------------------------------------ CityLearn 2.1
class RewardFunction(Reward):
    """Default: -max(e_b, 0) per building; central: -max(sum_b e_b, 0) on the district net (kWh)."""

    batchable = False  # central: the district net, not a sum of building values

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        values = -np.maximum(_get(obs, "net_electricity_consumption"), 0.0)
        return values, {"grid_import": values}

    def __call__(self, obs: Observations) -> tuple[float | np.ndarray, Terms]:
        self._check()
        values, terms = self.building_values(obs)
        if self.context.central_agent:
            return float(min(-_get(obs, "net_electricity_consumption").sum(), 0.0)), terms
        return values, terms


class MARL(Reward):
    """sign(-e_b) * 0.01 * e_b^2 * max(0, sum_b e_b); central: sum."""

    batchable = False  # every building's value scales with the district total

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        e = -_get(obs, "net_electricity_consumption")
        district = -e.sum()
        values = np.sign(e) * 0.01 * e ** 2 * max(0.0, district)
        return values, {"marl": values}


class IndependentSACReward(Reward):
    """-max(e_b, 0)^3 (intended, e_b kWh); with ``settings.independent_sac_reward_precedence_bug``:
    -max(e_b, 0), CityLearn's operator-precedence bug. Central: sum."""

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        e = np.clip(_get(obs, "net_electricity_consumption"), 0.0, None)
        values = -e if self.settings.independent_sac_reward_precedence_bug else -(e ** 3)
        return values, {"grid_import": values}


class SolarPenaltyReward(Reward):
    """Sum over storages with capacity > 1e-6 kWh of -(1 + sign(e_b) * soc) * |e_b|; central: sum."""

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        e = _get(obs, "net_electricity_consumption")
        terms = {}
        for kind in STORAGE_ACTIONS:
            present = self.context.storage_capacity(kind) > ZERO_CAPACITY
            soc = _get(obs, f"{kind}_soc", 0.0)
            terms[kind] = np.where(present, -(1.0 + np.sign(e) * soc) * np.abs(e), 0.0)
        return sum(terms.values()), terms


class ComfortReward(Reward):
    """Comfort penalty around the set point S with band b (degC): heating mode when heating_demand >
    cooling_demand. Below S - b: -|T - S|^(lower if heating else higher); in [S - b, S): 0 if heating else
    -|T - S|; in [S, S + b]: -|T - S| if heating else 0; above S + b: -|T - S|^(higher if heating else lower).
    Central: sum."""

    def __init__(self, band: float | None = None, lower_exponent: float | None = None,
                 higher_exponent: float | None = None, *, settings: Behaviour = CORRECTED) -> None:
        super().__init__(settings=settings)
        self.band = 2.0 if band is None else float(band)
        self.lower_exponent = 2.0 if lower_exponent is None else float(lower_exponent)
        self.higher_exponent = 3.0 if higher_exponent is None else float(higher_exponent)

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        heating = _get(obs, "heating_demand", 0.0) > _get(obs, "cooling_demand", 0.0)
        t = _get(obs, "indoor_dry_bulb_temperature")
        s = _get(obs, "indoor_dry_bulb_temperature_set_point")
        delta = np.abs(t - s)
        if self.settings.comfort_reward_float32:  # CityLearn 2.1 subtracts its float32 observations in float32
            delta = np.abs(t.astype(np.float32) - s.astype(np.float32)).astype(float)
        below = t < s
        outside = (t < s - self.band) | (t > s + self.band)
        # outside the band: the lower exponent on the side the mode pushes towards (too cold while heating,
        # too hot while cooling), the higher one otherwise; inside it only that side costs |T - S|
        exponent = np.where(below == heating, self.lower_exponent, self.higher_exponent)
        values = np.where(outside, -(delta ** exponent), np.where(below != heating, -delta, 0.0))
        return values, {"comfort": values}


class SolarPenaltyAndComfortReward(Reward):
    """coefficients[0] * SolarPenaltyReward + coefficients[1] * ComfortReward (per building; central: the sum
    of each part, added). ``settings.comfort_reward_float32``: each part rounded to float32 first, as
    CityLearn 2.1."""

    def __init__(self, band: float | None = None, lower_exponent: float | None = None,
                 higher_exponent: float | None = None, coefficients: Sequence[float] | None = None, *,
                 settings: Behaviour = CORRECTED) -> None:
        super().__init__(settings=settings)
        self.parts = (SolarPenaltyReward(settings=settings),
                      ComfortReward(band, lower_exponent, higher_exponent, settings=settings))
        self.coefficients = (1.0, 1.0) if coefficients is None else tuple(float(c) for c in coefficients)
        if len(self.coefficients) != 2:
            raise SchemaError(f"needs 2 coefficients, got {len(self.coefficients)}",
                              column="reward_function.attributes.coefficients")

    batchable = False  # central: each part summed (and rounded) before they are added

    def reset(self, context: RewardContext) -> None:
        super().reset(context)
        for part in self.parts:
            part.reset(context)

    def _parts(self, obs: Observations) -> list[np.ndarray]:
        return [part.building_values(obs)[0] for part in self.parts]

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        solar, comfort = self._parts(obs)
        terms = {"solar_penalty": self.coefficients[0] * solar, "comfort": self.coefficients[1] * comfort}
        return terms["solar_penalty"] + terms["comfort"], terms

    def __call__(self, obs: Observations) -> tuple[float | np.ndarray, Terms]:
        self._check()
        parts = self._parts(obs)
        terms = {"solar_penalty": self.coefficients[0] * parts[0], "comfort": self.coefficients[1] * parts[1]}
        if self.context.central_agent:
            parts = [np.array([p.sum()]) for p in parts]
        if self.settings.comfort_reward_float32:
            parts = [p.astype(np.float32).astype(float) for p in parts]
        total = self.coefficients[0] * parts[0] + self.coefficients[1] * parts[1]
        return (float(total[0]) if self.context.central_agent else total), terms


# ------------------------------------------------------------------------------------ CityLearn 2.5
#: Electric_Vehicles_Reward_Function's default weights (score points; upstream's names)
EV_REWARD_WEIGHTS = {"no_car_charging": -5.0, "battery_limits": -2.0, "soc_impossible": -10.0, "soc_under": -5.0,
                     "close_soc": 10.0, "self_ev_consumption": 5.0, "extra_self_production": 5.0}


def ev_charger_scores(step: ChargerStep, net: np.ndarray, multiplier: np.ndarray, weights: Mapping[str, float],
                      *, skip_unplugged: bool, square_soc_under: bool) -> dict[str, np.ndarray]:
    """Electric_Vehicles_Reward_Function's score of every charger (C,), per weight name, in score points.

    ``net`` [kWh] is the net consumption of each charger's building after the step and ``multiplier`` the
    factor every weight is scaled by (1 / (1 + |base reward|)). With E the charger's action energy [kWh], a
    charger with a plugged-in EV scores:

    * ``battery_limits`` when previous SOC x capacity + E is above the capacity or below the minimum capacity;
    * with the SOC gap d = SOC - required SOC and D = d x capacity [kWh], and the most the charger can move
      before departure, C = max charging power x hours to departure and P = the same for discharging [kWh]:
      ``soc_impossible`` when D > C; ``close_soc`` / (hours + 0.1) when |D| <= max(C, P); at departure (0 hours)
      ``close_soc`` when -0.1 < d <= 0.1, 2 ``soc_under`` when -0.25 < d <= -0.1, and when d <= -0.25
      ``soc_under`` x |soc_under| (``square_soc_under``: ``soc_under ** 2``, CityLearn 2.5's sign slip);
    * while the building exports (net < 0): ``extra_self_production`` when charging (E > 0), -0.5 x it when
      discharging; while it imports (net > 0): ``self_ev_consumption`` when discharging, -0.5 x it when charging.

    A charger without an EV scores ``no_car_charging`` when |E| > 0.1 kWh, or nothing when ``skip_unplugged``
    (CityLearn 2.5). Upstream compares the departure time in steps with kW limits: identical for hourly data."""
    on, e = step.connected, step.action_energy
    charging, discharging = e > 0, e < 0
    gap = step.soc - step.required_soc
    gap_kwh = gap * step.capacity
    can_charge = step.max_charging_power * step.hours_until_departure
    can_discharge = step.max_discharging_power * step.hours_until_departure
    stored = step.previous_soc * step.capacity + e
    leaving = on & (step.hours_until_departure == 0)
    under = float(weights["soc_under"])
    far_under = under if square_soc_under else abs(under)  # x the soc_under weight below
    hits = {  # multiples of each weight per charger
        "no_car_charging": ~on & (np.abs(e) > 0.1) & (not skip_unplugged),
        "battery_limits": on & ((stored > step.capacity) | (stored < step.min_capacity)),
        "soc_impossible": on & (gap_kwh > can_charge),
        "soc_under": leaving * np.where(gap <= -0.25, far_under, 2.0 * (gap <= -0.10)),
        "close_soc": (leaving & (gap > -0.10) & (gap <= 0.10))
        + (on & (np.abs(gap_kwh) <= np.maximum(can_charge, can_discharge))) / (step.hours_until_departure + 0.1),
        "extra_self_production": (on & (net < 0)) * (charging - 0.5 * discharging),
        "self_ev_consumption": (on & (net > 0)) * (discharging - 0.5 * charging),
    }
    return {k: float(weights[k]) * multiplier * v for k, v in hits.items()}


def parse_ev_reward_weights(weights: Any) -> dict[str, float]:
    """:data:`EV_REWARD_WEIGHTS` with the entries of ``weights`` (a mapping of weight name -> number, or None)
    replaced; SchemaError naming the attribute for anything else."""
    column = "reward_function.attributes.weights"
    if weights is None:
        return dict(EV_REWARD_WEIGHTS)
    if not isinstance(weights, Mapping):
        raise SchemaError(f"must map weight names to numbers, got {type(weights).__name__}", column=column)
    out = dict(EV_REWARD_WEIGHTS)
    for name, value in weights.items():
        if name not in EV_REWARD_WEIGHTS:
            raise SchemaError(f"unknown EV reward weight {name!r}; known: {', '.join(EV_REWARD_WEIGHTS)}",
                              column=column)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            raise SchemaError(f"weight {name!r} must be a finite number, got {value!r}", column=column)
        out[name] = float(value)
    return out


class ElectricVehiclesReward(MARL):
    """CityLearn 2.5's Electric_Vehicles_Reward_Function: each building with EV chargers gets the sum of its
    chargers' scores (:func:`ev_charger_scores`, score points), every weight scaled by 1 / (1 + |m|) with m the
    building's :class:`MARL` reward (central agent: the district's MARL sum); a building without chargers
    gets 0. The MARL value only scales the scores, as upstream. Central: sum over buildings.

    ``weights`` replace entries of :data:`EV_REWARD_WEIGHTS` by name (upstream needs all seven when it is
    given). Upstream's charging-constraint penalty is 0 here: schemas with ``charging_constraints`` are
    refused at load. Upstream quirks per ``settings``: ``ev_reward_skips_unplugged_chargers``,
    ``ev_reward_squares_soc_under_weight``."""

    def __init__(self, weights: Mapping[str, float] | None = None, *, settings: Behaviour = CORRECTED) -> None:
        super().__init__(settings=settings)
        self.weights = parse_ev_reward_weights(weights)

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        marl, _ = super().building_values(obs)
        base = np.full_like(marl, marl.sum()) if self.context.central_agent else marl
        if self.context.chargers is None:
            zeros = np.zeros_like(marl)
            return zeros, {"marl": marl, **{k: zeros for k in self.weights}}
        step = self.context.chargers()
        net = _get(obs, "net_electricity_consumption")[step.building]
        scores = ev_charger_scores(step, net, 1.0 / (1.0 + np.abs(base[step.building])), self.weights,
                                   skip_unplugged=self.settings.ev_reward_skips_unplugged_chargers,
                                   square_soc_under=self.settings.ev_reward_squares_soc_under_weight)
        per_building = np.array([np.bincount(step.building, weights=v, minlength=marl.size)
                                 for v in scores.values()])  # (terms, B): each building's chargers summed
        return per_building.sum(axis=0), {"marl": marl, **dict(zip(scores, per_building, strict=True))}


# ------------------------------------------------------------------------------------ SimBuild 2024
class SignalReward(Reward):
    """-(max(e_b, 0) * s_b)^exponent with s the observation named ``signal`` ($/kWh, kg/kWh) or 1 when None;
    central: sum. ``window`` is accepted for schema compatibility and unused (as upstream)."""

    default_signal: str | None = None

    def __init__(self, signal: str | None = None, exponent: float | None = None, window: int | None = None, *,
                 settings: Behaviour = CORRECTED) -> None:
        super().__init__(settings=settings)
        self.signal = self.default_signal if signal is None else signal
        self.exponent = 1.0 if exponent is None else float(exponent)
        self.window = window

    def _signal(self, obs: Observations) -> np.ndarray:
        return _get(obs, self.signal) if self.signal else np.ones_like(_get(obs, "net_electricity_consumption"))

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        grid = np.clip(_get(obs, "net_electricity_consumption"), 0.0, None)
        values = -((grid * self._signal(obs)) ** self.exponent)
        return values, {"signal": values}


class StorageSignalReward(SignalReward):
    """Penalises storing energy while importing: when e_b > 0, with D = sum over storages of
    (soc - previous soc) * capacity (kWh), r_b = -(|D| * s)^exponent * sign(D); 0 otherwise.
    ``settings.storage_signal_reward_multiplies_by_delta``: for D <= 0 multiply by D itself instead of its sign
    (CityLearn 2.1 / SimBuild). Central: sum."""

    def __init__(self, signal: str | None = None, exponent: float | None = None, *,
                 settings: Behaviour = CORRECTED) -> None:
        super().__init__(signal, exponent, settings=settings)
        self.kinds = ("dhw_storage", "cooling_storage", "heating_storage", "electrical_storage")
        self.previous_soc: dict[str, np.ndarray] = {}

    def reset(self, context: RewardContext) -> None:
        super().reset(context)
        self.previous_soc = {k: context.storage_initial_soc(k).copy() for k in self.kinds}

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        e = _get(obs, "net_electricity_consumption")
        soc = {k: _get(obs, f"{k}_soc", 0.0) for k in self.kinds}
        stored = sum((soc[k] - self.previous_soc[k]) * self.context.storage_capacity(k) for k in self.kinds)
        self.previous_soc = {k: v.copy() for k, v in soc.items()}
        magnitude = (np.abs(stored) * self._signal(obs)) ** self.exponent
        if self.settings.storage_signal_reward_multiplies_by_delta:
            direction = np.where(stored > 0.0, 1.0, stored)
        else:
            direction = np.sign(stored)
        values = np.where(e > 0.0, -magnitude * direction, 0.0)
        return values, {"stored_energy": stored, "signal": values}


class StorageCostReductionReward(Reward):
    """Price-rank reward for active storage actions. With the distinct prices seen so far sorted (n of them)
    and i the rank of the current price (building 0's observation), each active storage k adds
    -(1 - soc_k) * (n - i) when idle (|consumption| < 1e-6 kWh), +i when discharging, -i when a thermal storage
    charges while its device consumes more than the storage; central: sum. The price list persists across
    episodes, as upstream."""

    batchable = True  # the price ranked is building 0's, data that every copy of a district shares

    def __init__(self, *, settings: Behaviour = CORRECTED, **_unused: Any) -> None:
        super().__init__(settings=settings)
        self.prices: list[float] = []

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        price = float(_get(obs, "electricity_pricing")[0])
        self.prices = sorted(set(self.prices) | {price})
        i, n = self.prices.index(price), len(self.prices)
        terms = {}
        for kind in STORAGE_ACTIONS:
            active = self.context.action_active(kind)
            if not active.any():
                continue
            use = _get(obs, f"{kind}_electricity_consumption", 0.0)
            soc = _get(obs, f"{kind}_soc", 0.0)
            device = _get(obs, f"{kind.split('_')[0]}_electricity_consumption", 0.0)
            charging_on_device = (kind != "electrical_storage") & (use > 0.0) & (device > use)
            value = np.select([np.abs(use) < ZERO_CAPACITY, use < 0.0, charging_on_device],
                              [-(1.0 - soc) * (n - i), float(i), -float(i)], 0.0)
            terms[kind] = np.where(active, value, 0.0)
        values = sum(terms.values()) if terms else np.zeros_like(_get(obs, "net_electricity_consumption"))
        return values, terms


class SetPointDeviationReward(Reward):
    """SimBuild's ComfortReward: -|T - T_set| (degC) per building; central: mean over buildings."""

    central_aggregate = "mean"

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        values = -np.abs(_get(obs, "indoor_dry_bulb_temperature")
                         - _get(obs, "indoor_dry_bulb_temperature_set_point"))
        return values, {"set_point_deviation": values}


class ComfortAndConsumptionReductionReward(Reward):
    """The paper's discomfort & consumption reward: -multiplier * |T - T_set| when T < T_set (over-cooling
    wastes energy), else -|T - T_set| (degC); central: mean over buildings."""

    central_aggregate = "mean"

    def __init__(self, multiplier: float | None = None, *, settings: Behaviour = CORRECTED) -> None:
        super().__init__(settings=settings)
        self.multiplier = 3.0 if multiplier is None else float(multiplier)

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        delta = _get(obs, "indoor_dry_bulb_temperature") - _get(obs, "indoor_dry_bulb_temperature_set_point")
        values = -np.abs(np.where(delta < 0.0, delta * self.multiplier, delta))
        return values, {"over_cooling": np.where(delta < 0.0, values, 0.0),
                        "under_cooling": np.where(delta < 0.0, 0.0, values)}


class PeakReductionReward(Reward):
    """Running peak p of max(e, 0) since reset (kWh; per building, or of the district sum for a central
    agent); reward = p - max(e, 0) >= 0."""

    batchable = False  # central: the peak of the district sum

    def reset(self, context: RewardContext) -> None:
        super().reset(context)
        self.peak = np.zeros(1 if context.central_agent else context.n_buildings)

    def building_values(self, obs: Observations) -> tuple[np.ndarray, Terms]:
        grid = np.clip(_get(obs, "net_electricity_consumption"), 0.0, None)
        return grid, {"grid_import": grid}

    def __call__(self, obs: Observations) -> tuple[float | np.ndarray, Terms]:
        self._check()
        grid, terms = self.building_values(obs)
        load = np.array([grid.sum()]) if self.context.central_agent else grid
        self.peak = np.maximum(self.peak, load)
        values = self.peak - load
        return (float(values[0]) if self.context.central_agent else values), terms


# ------------------------------------------------------------------------------------ the paper's rewards
class CostReward(SignalReward):
    """The paper's cost reward: -max(e_b, 0) * price ($); central: sum."""

    default_signal = "electricity_pricing"


class EmissionsReward(SignalReward):
    """The paper's emissions reward: -max(e_b, 0) * carbon intensity (kg); central: sum."""

    default_signal = "carbon_intensity"


class AverageDailyPeakReward(RewardFunction):
    """The paper's average-daily-peak reward: -max(P, 0) with P the district net demand (kWh per step) for a
    central agent (``aggregate="district"``), or -sum_b max(e_b, 0) (``aggregate="buildings"``: what the
    published SimBuild runs computed with SignalReward and no signal); decentralised: -max(e_b, 0)."""

    def __init__(self, aggregate: str = "district", *, settings: Behaviour = CORRECTED) -> None:
        super().__init__(settings=settings)
        if aggregate not in ("district", "buildings"):
            raise SchemaError(f"aggregate must be 'district' or 'buildings', got {aggregate!r}",
                              column="reward_function.attributes.aggregate")
        self.aggregate_mode = aggregate

    def __call__(self, obs: Observations) -> tuple[float | np.ndarray, Terms]:
        return super().__call__(obs) if self.aggregate_mode == "district" else Reward.__call__(self, obs)


# ------------------------------------------------------------------------------------ registry
_CITYLEARN = "citylearn.reward_function."
_SIMBUILD = "src.reward_function."
#: reward type string (upstream dotted path or short name) -> class; never resolved by importing
REWARDS: dict[str, type[Reward]] = {
    _CITYLEARN + "RewardFunction": RewardFunction,
    _CITYLEARN + "MARL": MARL,
    _CITYLEARN + "IndependentSACReward": IndependentSACReward,
    _CITYLEARN + "SolarPenaltyReward": SolarPenaltyReward,
    _CITYLEARN + "ComfortReward": ComfortReward,
    _CITYLEARN + "SolarPenaltyAndComfortReward": SolarPenaltyAndComfortReward,
    _CITYLEARN + "Electric_Vehicles_Reward_Function": ElectricVehiclesReward,
    _SIMBUILD + "SignalReward": SignalReward,
    _SIMBUILD + "StorageSignalReward": StorageSignalReward,
    _SIMBUILD + "StorageCostReductionReward": StorageCostReductionReward,
    _SIMBUILD + "ComfortReward": SetPointDeviationReward,
    _SIMBUILD + "ComfortandConsumptionReductionReward": ComfortAndConsumptionReductionReward,
    _SIMBUILD + "PeakReductionReward": PeakReductionReward,
    "default": RewardFunction,
    "marl": MARL,
    "independent_sac": IndependentSACReward,
    "solar_penalty": SolarPenaltyReward,
    "comfort": ComfortReward,
    "solar_penalty_and_comfort": SolarPenaltyAndComfortReward,
    "electric_vehicles": ElectricVehiclesReward,
    "signal": SignalReward,
    "storage_signal": StorageSignalReward,
    "storage_cost_reduction": StorageCostReductionReward,
    "setpoint_deviation": SetPointDeviationReward,
    "peak_reduction": PeakReductionReward,
    "cost": CostReward,
    "emissions": EmissionsReward,
    "discomfort_consumption": ComfortAndConsumptionReductionReward,
    "average_daily_peak": AverageDailyPeakReward,
}


def make_reward(spec: Mapping[str, Any] | str | None, context: RewardContext, *,
                settings: Behaviour = CORRECTED) -> Reward:
    """Build and reset the reward of a schema's ``reward_function`` entry (``{"type": ..., "attributes":
    {...}}``), a type string, or None (the default :class:`RewardFunction`), with the upstream quirks that
    ``settings`` selects. Raises SchemaError for an unknown type (listing the known ones) or attributes the
    class does not take."""
    if spec is None:
        spec = {"type": "default"}
    elif isinstance(spec, str):
        spec = {"type": spec}
    elif not isinstance(spec, Mapping):
        raise SchemaError(f"reward function spec must be a mapping or a type string, got {type(spec).__name__}",
                          column="reward_function")
    name = spec.get("type")
    cls = REWARDS.get(name) if isinstance(name, str) else None
    if cls is None:
        raise SchemaError(f"unknown reward function type {name!r}; known: {', '.join(REWARDS)}",
                          column="reward_function.type")
    attributes = dict(spec.get("attributes") or {})
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p not in ("self", "settings", "_unused")]
    if "settings" in attributes:
        raise SchemaError("'settings' is not a reward attribute (pass the environment's settings instead)",
                          column="reward_function.attributes.settings")
    try:
        reward = cls(**attributes, settings=settings)
    except TypeError as error:
        raise SchemaError(f"{name} does not take attributes {sorted(attributes)} ({error}); it takes "
                          f"{', '.join(accepted) or 'none'}", column="reward_function.attributes") from None
    reward.reset(context)
    return reward
