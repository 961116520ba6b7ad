"""CityLearn 2.5.0 dynamics references on derived copies with hvac_mode switches, and our 2.5 preset against them.

    .venv/bin/python benchmarks/upstream_2_5_dynamics.py --upstream /tmp/cl250/bin/python   # make the references
    .venv/bin/python benchmarks/upstream_2_5_dynamics.py                                     # compare, print table

The derived copy (:func:`derive_mode_switch_copy`, written to a scratch folder, never committed): the first
:data:`BUILDINGS` buildings of upstream's v2.4.2 ``citylearn_challenge_2023_phase_3_1`` (LSTM dynamics, one
``dynamics`` model per building) over :data:`STEPS` time steps from row :data:`START`, with

* ``hvac_mode`` by hour of day (:func:`mode_of_hour`): heating (2) in hours 1-6, off (0) in hours 23-24, cooling
  (1) otherwise -- three switches a day; a heating row's ideal load is half the row's cooling load, moved to
  ``heating_demand``; an off row has neither;
* a heating set point 2 degC below the cooling one (the source has them equal), so 2.5's cold and hot discomfort
  differ;
* a ``heating_device`` heat pump of the cooling device's nominal power and nothing else: its efficiency and
  target temperatures are drawn by upstream from the device's seed (so is the DHW tank's efficiency, which the
  source leaves out);
* actions ``cooling_or_heating_device``, ``dhw_storage`` and ``electrical_storage``; no power outages.

Upstream runs three episodes on it (one process each, global ``numpy.random``/``random`` seeded with
:data:`SEED`): ``ideal`` (every action inactive: ideal loads, the LSTM predicting throughout), ``zeros`` (the
actions active and 0) and ``random`` (``numpy.random.default_rng(SEED).uniform(low, high, (T, n))``, call k
playing row k). Stored in ``benchmarks/upstream_2_5_0/dynamics_mode_switch.json``: per building and time step
the indoor temperature and net consumption (float32 as upstream holds them), the values the agent observed of
both, the realised drawn device parameters and the KPI table.

Comparison (no ``--upstream``): our 2.5 preset on the same copy, the same actions at the same rows; prints the
largest |dT| per step, the district energy gap and the largest KPI gap per scenario, by 2.5's KPI names.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
V242 = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.4.2"
SOURCE = V242 / "citylearn_challenge_2023_phase_3_1"
REFERENCE = ROOT / "benchmarks" / "upstream_2_5_0" / "dynamics_mode_switch.json"
BUILDINGS, START, STEPS, SEED = 4, 1000, 336, 20251
SCENARIOS = ("ideal", "zeros", "random")
ACTIONS = ("cooling_or_heating_device", "dhw_storage", "electrical_storage")
#: degC between the cooling set point and the heating set point of the copy
DEADBAND_C = 2.0


def mode_of_hour(hour: np.ndarray) -> np.ndarray:
    """hvac_mode of each row from its ``hour`` (1-24, hour-ending): 2 (heating) for 1-6, 0 (off) for 23-24,
    1 (cooling) otherwise."""
    hour = np.asarray(hour)
    return np.where(hour <= 6, 2, np.where(hour >= 23, 0, 1))


def _building_frame(frame: pd.DataFrame) -> pd.DataFrame:
    """A building file with the copy's hvac_mode, loads and heating set point (rows unchanged in number)."""
    out = frame.copy()
    mode = mode_of_hour(out["hour"].to_numpy())
    cooling = out["cooling_demand"].to_numpy()
    out["hvac_mode"] = mode
    out["heating_demand"] = np.where(mode == 2, 0.5 * cooling, 0.0).astype(np.float32)
    out["cooling_demand"] = np.where(mode == 1, cooling, 0.0).astype(np.float32)
    out["indoor_dry_bulb_temperature_heating_set_point"] = \
        (out["indoor_dry_bulb_temperature_cooling_set_point"] - DEADBAND_C).astype(np.float32)
    return out


def _schema(raw: dict, buildings: int, start: int, steps: int) -> dict:
    """The copy's schema: the first ``buildings`` buildings with a heating heat pump and no outages, the
    simulation range ``start .. start + steps - 1``, the three actions active."""
    names = list(raw["buildings"])[:buildings]
    raw["buildings"] = {n: raw["buildings"][n] for n in names}
    raw["root_directory"] = None
    raw["simulation_start_time_step"], raw["simulation_end_time_step"] = start, start + steps - 1
    raw["episode_time_steps"] = None
    raw["central_agent"] = True
    raw["actions"] = {k: {"active": k in ACTIONS} for k in (*raw["actions"], *ACTIONS)}
    for spec in raw["buildings"].values():
        power = spec["cooling_device"]["attributes"]["nominal_power"]
        spec["heating_device"] = {"type": "citylearn.energy_model.HeatPump", "autosize": False,
                                  "attributes": {"nominal_power": power}}
        spec["power_outage"] = {"simulate_power_outage": False, "stochastic_power_outage": False}
    return raw


def derive_mode_switch_copy(target: Path, source: Path = SOURCE, *, buildings: int = BUILDINGS,
                            start: int = START, steps: int = STEPS) -> Path:
    """Write the derived copy of ``source`` (a v2.4.2 LSTM data set) into folder ``target`` and return its
    schema path: see the module docstring. Deterministic: the same inputs give the same files."""
    target.mkdir(parents=True, exist_ok=True)
    raw = _schema(json.loads((source / "schema.json").read_text()), buildings, start, steps)
    shared = {"weather", "carbon_intensity", "pricing"}
    for spec in raw["buildings"].values():
        for key in shared:
            shutil.copyfile(source / spec[key], target / spec[key])
        shutil.copyfile(source / spec["dynamics"]["attributes"]["filename"],
                        target / spec["dynamics"]["attributes"]["filename"])
        frame = pd.read_csv(source / spec["energy_simulation"])
        _building_frame(frame).to_csv(target / spec["energy_simulation"], index=False)
    path = target / "schema.json"
    path.write_text(json.dumps(raw, indent=1))
    return path


def copy_digest(folder: Path) -> str:
    """SHA-256 [hex] over the derived copy's files in ``folder`` (names and bytes, sorted by name): the
    reference records it, so a derivation that drifts from the one upstream ran is caught."""
    digest = hashlib.sha256()
    for path in sorted(folder.iterdir()):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def action_table(low: np.ndarray, high: np.ndarray, steps: int, scenario: str, seed: int = SEED) -> np.ndarray:
    """(steps, n) actions of ``scenario``: zeros, or ``default_rng(seed).uniform(low, high)`` for "random"."""
    if scenario == "random":
        return np.random.default_rng(seed).uniform(low, high, size=(steps, len(low)))
    return np.zeros((steps, len(low)))


# ------------------------------------------------------------------------------------------- upstream side
UPSTREAM = r"""
import json, random, sys, time
import numpy as np
job = json.load(open(sys.argv[1]))
np.random.seed(job["seed"]); random.seed(job["seed"])
from citylearn.citylearn import CityLearnEnv
schema = json.load(open(job["schema"]))
schema["root_directory"] = job["root"]
if job["scenario"] == "ideal":
    schema["actions"] = {k: {"active": False} for k in schema["actions"]}
env = CityLearnEnv(schema, central_agent=True)
obs, _ = env.reset()
names = env.observation_names[0]
space = env.action_space[0]
steps = env.episode_tracker.episode_time_steps
n = space.shape[0]
table = np.zeros((steps, n))
if job["scenario"] == "random":
    table = np.random.default_rng(job["seed"]).uniform(space.low, space.high, size=(steps, n))
def f32(values):
    return [float(str(v)) for v in np.asarray(values, dtype="float32")]
watched = ("indoor_dry_bulb_temperature", "net_electricity_consumption")
observed = {k: [] for k in watched}
def record(o):
    for k in watched:
        observed[k].append(f32([v for name, v in zip(names, o[0]) if name == k]))
record(obs)
calls, done = 0, False
start = time.perf_counter()
while not done:
    obs, _, done, _, _ = env.step([table[calls].tolist()] if n else [[]])
    record(obs)
    calls += 1
ran = time.perf_counter() - start
kpis = env.evaluate()
kpis = kpis.where(kpis.notna(), None).to_dict("records")
b0 = env.buildings
out = {
    "citylearn": __import__("citylearn").__version__, "scenario": job["scenario"], "seed": job["seed"],
    "time_steps": int(steps), "step_calls": calls, "run_s": ran,
    "building_names": [b.name for b in b0], "action_names": list(env.action_names[0]),
    "action_low": f32(space.low), "action_high": f32(space.high),
    "indoor_dry_bulb_temperature": {b.name: f32(b.indoor_dry_bulb_temperature) for b in b0},
    "net_electricity_consumption": {b.name: f32(b.net_electricity_consumption) for b in b0},
    "district_net_electricity_consumption_sum": float(np.sum(env.net_electricity_consumption)),
    "observed": observed,
    "devices": {b.name: {"dhw_storage_efficiency": float(b.dhw_storage.efficiency),
                         "heating_device_efficiency": float(b.heating_device.efficiency),
                         "heating_device_target_heating_temperature": float(b.heating_device.target_heating_temperature),
                         "heating_device_target_cooling_temperature": float(b.heating_device.target_cooling_temperature)}
                for b in b0},
    "kpis": kpis,
}
json.dump(out, open(sys.argv[2], "w"))
"""


def run_upstream(python: str, schema: Path, scenario: str, scratch: Path) -> dict:
    """One upstream episode of ``scenario`` in interpreter ``python`` (citylearn 2.5.0): its JSON record plus
    the subprocess wall time [s]."""
    job, out = scratch / f"{scenario}.job.json", scratch / f"{scenario}.out.json"
    job.write_text(json.dumps({"schema": str(schema), "root": str(schema.parent), "scenario": scenario,
                               "seed": SEED}))
    start = time.perf_counter()
    done = subprocess.run([python, "-c", UPSTREAM, str(job), str(out)], capture_output=True, text=True,
                          env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin", "HOME": str(Path.home())})
    if done.returncode != 0:
        raise RuntimeError(f"upstream {scenario} failed: {done.stderr.strip()[-2000:]}")
    record = json.loads(out.read_text())
    record["wall_s"] = time.perf_counter() - start
    return record


def make_references(python: str) -> dict:
    """Run every scenario upstream on a fresh derived copy and store them in :data:`REFERENCE`."""
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        schema = derive_mode_switch_copy(scratch / "copy")
        digest = copy_digest(schema.parent)
        records = {}
        for scenario in SCENARIOS:
            records[scenario] = run_upstream(python, schema, scenario, scratch)
            print(f"{scenario}: {records[scenario]['district_net_electricity_consumption_sum']:.3f} kWh in "
                  f"{records[scenario]['wall_s']:.1f} s", flush=True)
    recipe = {"source": str(SOURCE.relative_to(ROOT.parent)), "buildings": BUILDINGS, "start": START,
              "steps": STEPS, "seed": SEED, "copy_sha256": digest,
              "made_by": "benchmarks/upstream_2_5_dynamics.py --upstream PY"}
    REFERENCE.write_text(json.dumps({"recipe": recipe, **records}, separators=(",", ":")))
    return records


# ------------------------------------------------------------------------------------------------ our side
def run_ours(schema: Path, scenario: str, settings="citylearn-2.5"):
    """Our env on the copy in ``settings`` with the scenario's actions (call k plays row k): the env after the
    episode and the observations it returned, name -> (calls + 1, B) for the watched observations."""
    from citylearn_env import CityLearnEnv, load_schema

    config = load_schema(schema, settings=settings)
    if scenario == "ideal":
        config = config.with_actions([])
    env = CityLearnEnv(config, settings=settings, central_agent=True)
    obs, _ = env.reset(seed=SEED)
    table = action_table(env.action_space.low, env.action_space.high, env.episode_length, scenario)
    seen = [obs]
    done = False
    k = 0
    while not done:
        obs, _, done, _, _ = env.step(table[k])
        seen.append(obs)
        k += 1
    return env, np.array(seen)


def kpi_gaps(reference: list[dict], ours: pd.DataFrame) -> dict[tuple[str, str], tuple]:
    """(kpi, name) -> (upstream, ours, |difference|) for every row of upstream's table (ours NaN if absent)."""
    mine = {(r.cost_function, r.name): float(r.value) for r in ours.itertuples()}
    out = {}
    for row in reference:
        theirs = np.nan if row["value"] is None else float(row["value"])
        value = mine.get((row["cost_function"], row["name"]), np.nan)
        gap = 0.0 if np.isnan(theirs) and np.isnan(value) else abs(value - theirs)
        out[(row["cost_function"], row["name"])] = (theirs, value, gap)
    return out


def compare(reference: dict, schema: Path) -> dict:
    """Per scenario: largest |dT| over buildings and steps [degC], district energy gap [kWh and relative],
    largest per-step net gap [kWh] and the largest KPI gap with its row."""
    out = {}
    for scenario in SCENARIOS:
        ref = reference[scenario]
        env, _ = run_ours(schema, scenario)
        series = env.series()
        names = ref["building_names"]
        temp = np.array([ref["indoor_dry_bulb_temperature"][n] for n in names])
        net = np.array([ref["net_electricity_consumption"][n] for n in names])
        d_temp = np.abs(series["indoor_dry_bulb_temperature"] - temp)
        energy = float(series["net_electricity_consumption"].sum())
        gaps = kpi_gaps(ref["kpis"], env.evaluate())
        worst = max(gaps, key=lambda k: gaps[k][2])
        out[scenario] = {"max_abs_dT": float(d_temp.max()), "upstream_kwh": ref["district_net_electricity_consumption_sum"],
                         "ours_kwh": energy, "energy_gap_kwh": energy - ref["district_net_electricity_consumption_sum"],
                         "max_step_net_gap_kwh": float(np.abs(series["net_electricity_consumption"] - net).max()),
                         "max_kpi_gap": gaps[worst][2], "max_kpi_gap_row": list(worst)}
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream", help="a Python interpreter with citylearn==2.5.0: remake the references")
    args = parser.parse_args()
    if not SOURCE.is_dir():
        sys.exit(f"{SOURCE} is absent: the upstream data sets live in ../shared")
    if args.upstream:
        make_references(args.upstream)
    reference = json.loads(REFERENCE.read_text())
    with tempfile.TemporaryDirectory() as tmp:
        result = compare(reference, derive_mode_switch_copy(Path(tmp)))
    print("| scenario | max abs dT degC | upstream kWh | ours kWh | gap kWh | max step net gap kWh | max KPI gap (row) |")
    print("|---|---|---|---|---|---|---|")
    for scenario, r in result.items():
        print(f"| {scenario} | {r['max_abs_dT']:.2e} | {r['upstream_kwh']:.4f} | {r['ours_kwh']:.4f} | "
              f"{r['energy_gap_kwh']:+.2e} | {r['max_step_net_gap_kwh']:.2e} | {r['max_kpi_gap']:.2e} "
              f"({', '.join(r['max_kpi_gap_row'])}) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
