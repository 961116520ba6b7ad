"""The 17 control benchmarks of the SimBuild 2024 CityLearn paper, on any district, with one command.

    districtgen paper artifacts/default/schema.json -o artifacts/default/paper [--buildings B1 B2]
        [--rules described|published] [--compat] [--sac fast|torch|torch-bf16|sbx|sb3]
        [--precision auto|float32|bfloat16] [--seeds N] [--workers W]

Each benchmark derives its variant from the district, loaded once as a typed configuration (which
buildings play the paper's B1 and B2, which devices exist, which actions and observations are active,
which reward), runs its controller (none, the paper's rule, or SAC trained on the first 13 days), and
reports the paper's objectives over the test period (days 14 to the end): cost, emissions, discomfort and
consumption of B1, and the district's average daily peak. Power outages are off in every run, as in the
paper. The runs are independent tasks (:mod:`pipeline.paper.tasks`); tables in :mod:`pipeline.paper.results`, figures in
:mod:`pipeline.paper.figures`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.config import BuildingConfig, DistrictConfig
from citylearn_env.errors import InputError
from citylearn_env.wrappers import NormalizedActionWrapper, NormalizedObservationWrapper
from pipeline.controllers import RULE_SETS, rule_actions, run_episode
from pipeline.paper import seasons
from pipeline.paper.sac.train import sac_threads, train_sac
from pipeline.paper.seasons import DEVICE_OF, SIDES_OF, Season
from pipeline.paper.seasons import season as season_of

TRAIN_DAYS = 13


#: the paper's RL observations, always / per DER / per objective
ALWAYS = ("hour", "day_type")


@dataclass(frozen=True)
class Benchmark:
    id: str
    buildings: int
    objective: str  # none | cost | emissions | peak | discomfort_consumption
    control: str  # none | rbc | sac
    dhw: bool = False
    bess_pv: bool = False
    pv: bool = False
    hp: bool = False


def _bench(id_: str) -> Benchmark:
    algo, bldgs, objective, ders = id_.split("-")
    objective = {"x": "none", "c": "cost", "e": "emissions", "p": "peak", "d_o": "discomfort_consumption"}[objective]
    parts = set(ders.split("_")) if ders != "x" else set()
    bess = "bess" in parts
    return Benchmark(id_, 2 if bldgs == "b1_b2" else 1, objective, {"x": "none", "rbc": "rbc", "rlc": "sac"}[algo],
                     dhw="dhw" in parts, bess_pv=bess, pv=bess or "pv" in parts, hp="hp" in parts)


BENCHMARKS = tuple(_bench(i) for i in (
    "x-b1_b2-x-x", "x-b1_b2-x-pv",
    "rbc-b1-c-dhw", "rbc-b1-e-dhw", "rbc-b1-c-bess_pv", "rbc-b1-e-bess_pv", "rbc-b1-c-dhw_bess_pv",
    "rbc-b1-e-dhw_bess_pv", "rbc-b1_b2-p-bess_pv",
    "rlc-b1-c-dhw", "rlc-b1-e-dhw", "rlc-b1-c-bess_pv", "rlc-b1-e-bess_pv", "rlc-b1-c-dhw_bess_pv",
    "rlc-b1-e-dhw_bess_pv", "rlc-b1-d_o-hp", "rlc-b1_b2-p-bess_pv",
))


REWARDS = {"cost": "cost", "emissions": "emissions", "peak": "average_daily_peak",
           "discomfort_consumption": "discomfort_consumption", "none": "default"}


RULES = {"cost": "cost_rbc", "emissions": "emission_rbc", "peak": "peak_rbc"}


def observations(b: Benchmark) -> list[str]:
    names = list(ALWAYS)
    if not b.hp:
        names.append("net_electricity_consumption")
    if b.objective == "cost":
        names.append("electricity_pricing")
    if b.objective == "emissions":
        names.append("carbon_intensity")
    if b.bess_pv:
        names += ["solar_generation", "electrical_storage_soc"]
    if b.dhw:
        names.append("dhw_storage_soc")
    if b.hp:
        names += ["outdoor_dry_bulb_temperature", "indoor_dry_bulb_temperature",
                  "indoor_dry_bulb_temperature_set_point", "indoor_dry_bulb_temperature_delta"]
    return names


ROLES = ("B1", "B2")


def resolve_roles(district: DistrictConfig, names: Sequence[str] | None = None) -> tuple[str, ...]:
    """The schema buildings playing B1 (and B2): ``names`` (one or two) or the district's first two."""

    names = tuple(names) if names else district.building_names[:2]
    if not 1 <= len(names) <= 2 or len(set(names)) != len(names):
        raise InputError(f"give one or two distinct buildings for B1 [B2], got {list(names)}", column="--buildings")
    unknown = [n for n in names if n not in district.building_names]
    if unknown:
        raise InputError(f"unknown building(s) {unknown}; the district has {', '.join(district.building_names)}",
                         file=district.source, column="--buildings")
    return names


def missing_devices(building: BuildingConfig, b: Benchmark, season: Season = "cooling") -> list[str]:
    """The devices benchmark ``b`` needs that ``building`` lacks (empty when it has them all); the heat pump of
    ``season`` (:data:`pipeline.paper.seasons.DEVICE_OF`)."""
    slot = DEVICE_OF[season]
    needs = {"DHW storage (dhw_storage capacity > 0)": b.dhw and building.dhw_storage.capacity <= 0,
             "battery (electrical_storage capacity > 0)": b.bess_pv and building.electrical_storage.capacity <= 0,
             "PV (pv nominal_power > 0)": b.pv and building.pv_nominal_power <= 0,
             f"heat pump ({slot} nominal_power > 0, {season} period)":
                 b.hp and getattr(building, slot).nominal_power <= 0,
             "LSTM temperature model (dynamics)": b.hp and not building.has_dynamics}
    return [device for device, missing in needs.items() if missing]


def check_devices(district: DistrictConfig, b: Benchmark, roles: Sequence[str], season: Season = "cooling") -> None:
    """Raise one clear InputError when a building playing a role in ``b`` lacks a device ``b`` needs."""

    by_name = dict(zip(district.building_names, district.buildings, strict=True))
    for role, name in zip(ROLES, roles[:b.buildings], strict=False):
        missing = missing_devices(by_name[name], b, season)
        if missing:
            raise InputError(f"{b.id} needs {', '.join(missing)} in {role} = {name}; pick another building "
                             "with --buildings", file=district.source, column=f"buildings.{name}")


def season_of_test_period(district: DistrictConfig, roles: Sequence[str] | None = None) -> Season:
    """The season of the test period (days 14 to the end) of the building playing B1."""
    roles = resolve_roles(district, roles)
    b1 = dict(zip(district.building_names, district.buildings, strict=True))[roles[0]]
    return season_of(b1, test_period(district))


def test_period(district: DistrictConfig) -> tuple[int, int]:
    """The paper's test period: inclusive steps from the simulation start, days 14 to the end."""
    n = district.simulation_end_time_step - district.simulation_start_time_step + 1
    return TRAIN_DAYS * 24, n - 1


def benchmark_notes(district: DistrictConfig, b: Benchmark, roles: Sequence[str] | None = None) -> list[str]:
    """One line per part of ``b`` that the district's test period cannot exercise (:func:`seasons.notes`)."""
    roles = resolve_roles(district, roles)
    by_name = dict(zip(district.building_names, district.buildings, strict=True))
    return seasons.notes([by_name[n] for n in roles[:b.buildings]], test_period(district), objective=b.objective,
                         dhw=b.dhw, bess_pv=b.bess_pv, hp=b.hp)


def benchmark_schema(district: DistrictConfig, b: Benchmark, split: tuple[int, int],
                     multiplier: float = 3.0, roles: Sequence[str] | None = None,
                     season: Season | None = None) -> DistrictConfig:
    """The district edited for benchmark ``b`` over the inclusive time-step range ``split`` (typed edits).

    The buildings playing B1 (and B2) (``roles``, default the first two); the paper's observations
    (:func:`observations`, calendar, prices, carbon and outdoor temperature shared in the central agent); the
    storage/heat-pump actions of ``b``; devices ``b`` does not use removed; the objective's reward; a
    central agent; no power outages. The heat pump controlled is the one of ``season`` (default: the season of
    the test period, :func:`season_of_test_period`).
    """
    roles = resolve_roles(district, roles)
    if len(roles) < b.buildings:

        raise InputError(f"{b.id} needs two buildings (B1 and B2), got only {list(roles)}", column="--buildings")
    season = season or season_of_test_period(district, roles)
    check_devices(district, b, roles, season)
    names = observations(b)
    shared = set(ALWAYS) | {"electricity_pricing", "carbon_intensity", "outdoor_dry_bulb_temperature"}
    actions = [a for a, on in (("dhw_storage", b.dhw), ("electrical_storage", b.bess_pv),
                               (DEVICE_OF[season], b.hp)) if on]
    removed = [slot for slot, keep in (("dhw_storage", b.dhw), ("electrical_storage", b.bess_pv), ("pv", b.pv))
               if not keep]
    attributes = {"multiplier": multiplier} if b.objective == "discomfort_consumption" else {}
    return (district.with_buildings(roles[:b.buildings])
            .with_observations(names, shared=[n for n in names if n in shared])
            .with_actions(actions)
            .with_episode([split])
            .with_reward({"type": REWARDS[b.objective], "attributes": attributes})
            .without_devices(*removed)
            .without_outages()
            .replace(central_agent=True))


def load_district(schema_path: str | Path, settings: str | None = None) -> DistrictConfig:
    """The district schema loaded once (data files read and validated); benchmarks derive from it.
    ``settings``: the environment's upstream behaviour preset (None = corrected, "citylearn-2.1")."""

    return load_schema(Path(schema_path), settings=settings)


SWEEP_ID = "rlc-b1-d_o-hp"


@dataclass(frozen=True)
class Task:
    """One run: benchmark ``id`` with over-cooling multiplier ``multiplier`` and seed ``seed``, under the
    benchmark's own controller (``controller`` = "") or a reference controller of its configuration ("oracle",
    "mpc"; :mod:`pipeline.paper.reference`)."""

    id: str
    multiplier: float
    seed: int
    controller: str = ""

    @property
    def key(self) -> str:
        if self.controller:
            return f"{self.controller}-{configuration(self.id)}-s{self.seed}"
        return f"{self.id}-m{self.multiplier:g}-s{self.seed}"


def configuration(benchmark_id: str) -> str:
    """The configuration of a benchmark id (buildings, objective, devices): the id without its controller,
    e.g. "b1-c-dhw" for rbc-b1-c-dhw and rlc-b1-c-dhw."""
    return benchmark_id.split("-", 1)[1]


@dataclass(frozen=True)
class RunOptions:
    """How the benchmarks run. ``roles``: buildings playing B1 [B2] (None = the first two); ``rules``:
    "described" or "published" (:data:`pipeline.controllers.RULE_SETS`); ``compat``: the CityLearn 2.1
    preset (``settings="citylearn-2.1"``); ``sac``: the SAC back end (:data:`pipeline.paper.sac.train.BACKENDS`);
    ``sac_threads``: torch threads of one SAC training (None: chosen per task by
    :func:`pipeline.paper.sac.train.sac_threads` over the ``cores`` the runner leaves each task); ``precision``: the
    SAC update's numeric mode, ``auto``, ``float32`` or ``bfloat16`` (:func:`pipeline.paper.sac.train.sac_precision`);
    ``cores``: CPU cores one task may use (set by :func:`pipeline.paper.tasks.run_paper` from its runner; not
    part of a result's identity)."""

    sac_episodes: int = 150
    roles: tuple[str, ...] | None = None
    rules: str = "described"
    compat: bool = False
    sac: str = "fast"
    sac_threads: int | None = None
    precision: str = "auto"
    cores: int = 1

    @property
    def settings(self) -> str | None:
        return "citylearn-2.1" if self.compat else None


#: time steps of the trace kept for the figures: the first 7 test days
TRACE_STEPS = 7 * 24


def run_benchmark(district: DistrictConfig, b: Benchmark, *, seed: int = 0, multiplier: float = 3.0,
                  options: RunOptions = RunOptions()) -> dict[str, Any]:
    """Run one benchmark; return its test-period objectives (B1; district peak) and a trace for the figures."""
    if options.rules not in RULE_SETS:
        raise InputError(f"unknown rule set {options.rules!r}; known: {', '.join(RULE_SETS)}", column="--rules")
    started = time.perf_counter()
    train, test = (0, TRAIN_DAYS * 24 - 1), test_period(district)
    season = season_of_test_period(district, options.roles)
    env = CityLearnEnv(benchmark_schema(district, b, test, multiplier, options.roles, season),
                       settings=options.settings)
    policy, train_seconds, train_cpu, precision, threads = None, 0.0, 0.0, "-", 0
    if b.control == "sac":
        threads = options.sac_threads or sac_threads(options.cores)[0]
        trained = sac_policy(
            CityLearnEnv(benchmark_schema(district, b, train, multiplier, options.roles, season),
                         settings=options.settings),
            options.sac_episodes, seed, options.sac, threads, options.precision)
        policy, train_seconds, train_cpu, precision = trained
    rules, lookahead = RULE_SETS[options.rules]
    rule = rules[RULES[b.objective]] if b.control == "rbc" else None
    if rule is not None:
        actions = run_episode(env, lambda _: rule_actions(env, rule, lookahead), seed)
    elif policy is not None:
        actions = run_episode(env, policy, seed)
    else:
        actions = run_episode(env, lambda _: np.zeros(env.action_space.shape), seed)
    return {**episode_result(env, b, actions, seed=seed, multiplier=multiplier, controller=b.control),
            "notes": benchmark_notes(district, b, options.roles),
            "precision": precision, "sac_threads": threads, "train_seconds": train_seconds,
            "train_cpu_seconds": train_cpu, "seconds": time.perf_counter() - started}


def episode_result(env, b: Benchmark, actions: Sequence[np.ndarray], *, seed: int, multiplier: float,
                   controller: str) -> dict[str, Any]:
    """The test-period objectives of a finished episode of ``env`` under benchmark ``b``'s configuration: cost
    [$], emissions [kg], discomfort [C h] and consumption [kWh] of B1, over-/under-cooling statistics [C], the
    district's average daily peak [kW], the ``controller`` that ran and the trace for the figures."""
    result = env.objectives()
    first = {k: float(v[0]) for k, v in result["per_building"].items()}
    series = env.series()
    delta = series["indoor_dry_bulb_temperature"][0] - series["indoor_dry_bulb_temperature_set_point"][0]
    over, under = -delta[delta < 0], delta[delta > 0]  # over-cooling: colder than the set point
    first |= {"overcooling_mean": mean_or_zero(over), "overcooling_std": std_or_zero(over),
              "undercooling_mean": mean_or_zero(under), "undercooling_std": std_or_zero(under)}
    kind = "heating" if b.hp and any(n.endswith(".heating_device") for n in env.action_names) else "cooling"
    return {"id": b.id, "controller": controller, "buildings": "+".join(env.building_names), "season": kind,
            "below_above": "/".join(SIDES_OF[kind]),
            "multiplier": multiplier, "seed": seed, **first, "average_daily_peak": result["average_daily_peak"],
            "steps": int(env.t), "mean_abs_action": float(np.mean(np.abs(actions))) if env.action_names else 0.0,
            "trace": trace(env, series, actions)}


def trace(env, series: Mapping[str, np.ndarray], actions: Sequence[np.ndarray]) -> dict[str, Any]:
    """What the figures need, as JSON-ready lists: the first :data:`TRACE_STEPS` steps of B1's actions
    (action ``k`` controls step ``k + 1``), storage SOCs, price, carbon intensity, hour and day type; and the
    district's daily peak [kW] per whole test day (max over the day of the summed net consumption)."""
    k = min(TRACE_STEPS, len(actions))
    district = series["net_electricity_consumption"].sum(axis=0)
    days = len(district) // 24
    out = {"action_names": list(env.action_names),
           "actions": np.asarray(actions[:k]).reshape(k, -1).round(5).tolist(),
           "daily_peak": district[:days * 24].reshape(days, 24).max(axis=1).round(4).tolist()}
    for name in ("dhw_storage_soc", "electrical_storage_soc"):
        out[name] = series[name][0, :k + 1].round(5).tolist()
    for name in ("electricity_pricing", "carbon_intensity", "hour", "day_type"):
        out[name] = env.data(name)[0, :k + 1].round(5).tolist()
    return out


def sac_policy(env, episodes: int, seed: int, backend: str, threads: int = 1, precision: str = "auto"):
    """SAC trained on ``env`` (the paper's normalisation: periodic encoding, min-max; [0, 1] actions);
    returns (raw observation -> environment action, training wall seconds, training CPU seconds, the
    precision the updates ran in)."""

    # the paper's (upstream's) scaling: unclipped, so its SAC numbers stay comparable
    wrapped = NormalizedActionWrapper(NormalizedObservationWrapper(env, clip=False))
    trained = train_sac(wrapped, episodes, seed, backend, threads, precision)
    obs_wrapper = wrapped.env
    low, span = wrapped.low, wrapped.span

    def policy(raw_obs: np.ndarray) -> np.ndarray:
        return low + trained.act(obs_wrapper.observation(raw_obs)) * span

    return policy, trained.seconds, trained.cpu_seconds, trained.precision.precision


def mean_or_zero(x: np.ndarray) -> float:
    return float(x.mean()) if x.size else 0.0


def std_or_zero(x: np.ndarray) -> float:
    return float(x.std()) if x.size else 0.0
