"""The 17 control benchmarks of the SimBuild 2024 CityLearn paper, on any district, with one command.

    districtgen paper artifacts/default/schema.json -o artifacts/default/paper [--sac-episodes 150]

Each benchmark derives its variant from the district, loaded once as a typed configuration (which
buildings, which devices exist, which actions and observations are active, which reward), runs its controller (none, the paper's rule, or SAC trained on the
first 13 days), and reports the paper's objectives over the test period (days 14 to the end): cost,
emissions, discomfort and consumption of the first building, and the district's average daily peak.
Power outages are off in every run, as in the paper.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env.config import DistrictConfig

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


def benchmark_schema(district: DistrictConfig, b: Benchmark, split: tuple[int, int],
                     multiplier: float = 3.0) -> DistrictConfig:
    """The district edited for benchmark ``b`` over the inclusive time-step range ``split`` (typed edits).

    The first ``b.buildings`` buildings; the paper's observations (:func:`observations`, calendar, prices,
    carbon and outdoor temperature shared in the central agent); the storage/heat-pump actions of ``b``;
    devices ``b`` does not use removed; the objective's reward; a central agent; no power outages.
    """
    names = observations(b)
    shared = set(ALWAYS) | {"electricity_pricing", "carbon_intensity", "outdoor_dry_bulb_temperature"}
    actions = [a for a, on in (("dhw_storage", b.dhw), ("electrical_storage", b.bess_pv),
                               ("cooling_device", b.hp)) if on]
    removed = [slot for slot, keep in (("dhw_storage", b.dhw), ("electrical_storage", b.bess_pv), ("pv", b.pv))
               if not keep]
    attributes = {"multiplier": multiplier} if b.objective == "discomfort_consumption" else {}
    return (district.with_buildings(district.building_names[:b.buildings])
            .with_observations(names, shared=[n for n in names if n in shared])
            .with_actions(actions)
            .with_episode([split])
            .with_reward({"type": REWARDS[b.objective], "attributes": attributes})
            .without_devices(*removed)
            .without_outages()
            .replace(central_agent=True))


def load_district(schema_path: str | Path) -> DistrictConfig:
    """The district schema loaded once (data files read and validated); benchmarks derive from it."""
    from citylearn_env import load_schema

    return load_schema(Path(schema_path))


def run_benchmark(district: DistrictConfig, b: Benchmark, *, sac_episodes: int = 150, seed: int = 0,
                  multiplier: float = 3.0) -> dict[str, Any]:
    """Run one benchmark; return its test-period objectives (first building; district peak)."""
    from citylearn_env import CityLearnEnv
    from pipeline.controllers import RULES as RULE_FUNCTIONS
    from pipeline.controllers import rule_actions

    n = district.simulation_end_time_step - district.simulation_start_time_step + 1
    train, test = (0, TRAIN_DAYS * 24 - 1), (TRAIN_DAYS * 24, n - 1)
    env = CityLearnEnv(benchmark_schema(district, b, test, multiplier))
    policy = None
    if b.control == "sac":
        policy = train_sac(CityLearnEnv(benchmark_schema(district, b, train, multiplier)), sac_episodes, seed)
    obs, _ = env.reset(seed=seed)
    rule = RULE_FUNCTIONS[RULES[b.objective]] if b.control == "rbc" else None
    terminated = False
    actions = []
    while not terminated:
        if rule is not None:
            action = rule_actions(env, rule)
        elif policy is not None:
            action = policy(obs)
        else:
            action = np.zeros(env.action_space.shape)
        actions.append(action)
        obs, _, terminated, _, _ = env.step(action)
    result = env.objectives()
    first = {k: float(v[0]) for k, v in result["per_building"].items()}
    series = env.series()
    delta = series["indoor_dry_bulb_temperature"][0] - series["indoor_dry_bulb_temperature_set_point"][0]
    over, under = -delta[delta < 0], delta[delta > 0]  # over-cooling: colder than the set point
    first |= {"overcooling_mean": mean_or_zero(over), "overcooling_std": std_or_zero(over),
              "undercooling_mean": mean_or_zero(under), "undercooling_std": std_or_zero(under)}
    return {"id": b.id, **first, "average_daily_peak": result["average_daily_peak"],
            "steps": int(env.t), "mean_abs_action": float(np.mean(np.abs(actions))) if env.action_names else 0.0}


def train_sac(env, episodes: int, seed: int):
    """SAC with SB3 defaults (MlpPolicy) on normalised observations and [0, 1] actions; returns a policy."""
    import torch
    from stable_baselines3 import SAC

    from citylearn_env.wrappers import NormalizedActionWrapper, NormalizedObservationWrapper

    torch.set_num_threads(1)
    wrapped = NormalizedActionWrapper(NormalizedObservationWrapper(env))
    env.reset(seed=seed)
    steps_per_episode = env.episode_length - 1
    model = SAC("MlpPolicy", wrapped, seed=seed, device="cpu", verbose=0,
                learning_starts=min(100, steps_per_episode))
    model.learn(total_timesteps=max(episodes, 1) * steps_per_episode)
    obs_wrapper = wrapped.env  # NormalizedObservationWrapper
    low, span = wrapped.low, wrapped.span

    def policy(raw_obs: np.ndarray) -> np.ndarray:
        action, _ = model.predict(obs_wrapper.observation(raw_obs), deterministic=True)
        return low + np.asarray(action, dtype=np.float64) * span

    return policy


def run_all(schema_path: str | Path, out_dir: str | Path, *, only: list[str] | None = None,
            sac_episodes: int = 150, seed: int = 0, multiplier: float = 3.0, log=print) -> list[dict]:
    """Run the benchmarks (all 17, or ``only``) on a district schema; write results.csv and results.md."""
    import pandas as pd

    chosen = [b for b in BENCHMARKS if only is None or b.id in only]
    unknown = set(only or ()) - {b.id for b in BENCHMARKS}
    if unknown:
        raise ValueError(f"unknown benchmark id(s) {sorted(unknown)}; known: {', '.join(b.id for b in BENCHMARKS)}")
    district = load_district(schema_path)
    results = []
    for b in chosen:
        log(f"running {b.id} ...")
        results.append(run_benchmark(district, b, sac_episodes=sac_episodes, seed=seed, multiplier=multiplier))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    frame = pd.DataFrame(results)
    frame.to_csv(out / "results.csv", index=False)
    lines = ["| benchmark | cost $ | emissions kg | discomfort C h | consumption kWh | avg daily peak kW |",
             "|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r['id']} | {r['cost']:.3f} | {r['emissions']:.2f} | {r['discomfort']:.1f} | "
                     f"{r['consumption']:.2f} | {r['average_daily_peak']:.3f} |")
    (out / "results.md").write_text("\n".join(lines) + "\n")
    return results


def mean_or_zero(x: np.ndarray) -> float:
    return float(x.mean()) if x.size else 0.0


def std_or_zero(x: np.ndarray) -> float:
    return float(x.std()) if x.size else 0.0


def multiplier_sweep(schema_path: str | Path, out_dir: str | Path, multipliers=(1.0, 3.0, 6.0, 12.0), *,
                     sac_episodes: int = 150, seed: int = 0, log=print) -> list[dict]:
    """The paper's m-sweep of rlc-b1-d_o-hp: discomfort, over/under-cooling, consumption, % change vs m = 1."""
    district = load_district(schema_path)
    bench = next(b for b in BENCHMARKS if b.id == "rlc-b1-d_o-hp")
    rows = []
    for m in multipliers:
        log(f"running rlc-b1-d_o-hp with m = {m:g} ...")
        rows.append({"multiplier": m, **run_benchmark(district, bench, sac_episodes=sac_episodes, seed=seed,
                                                      multiplier=m)})
    base = rows[0]
    lines = ["| m | discomfort C h | over-cooling C (mean +- std) | under-cooling C (mean +- std) | "
             "consumption kWh | discomfort change | consumption change |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['multiplier']:g} | {r['discomfort']:.1f} | {r['overcooling_mean']:.2f} +- "
                     f"{r['overcooling_std']:.2f} | {r['undercooling_mean']:.2f} +- {r['undercooling_std']:.2f} | "
                     f"{r['consumption']:.2f} | {_change(r['discomfort'], base['discomfort'])} | "
                     f"{_change(r['consumption'], base['consumption'])} |")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "multiplier_sweep.md").write_text("\n".join(lines) + "\n")
    return rows


def _change(value: float, base: float) -> str:
    return f"{100.0 * (value - base) / base:+.1f} %" if base else "-"
