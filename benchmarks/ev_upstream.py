"""Reference runs of upstream CityLearn 2.5.0 on the v2.4.2 datasets (EV parity and the 2.5 fidelity table).

    .venv/bin/python benchmarks/ev_upstream.py --upstream /tmp/cl250/bin/python            # both parts
    .venv/bin/python benchmarks/ev_upstream.py --upstream /tmp/cl250/bin/python --only ev
    .venv/bin/python benchmarks/ev_upstream.py --upstream /tmp/cl250/bin/python --only no-control [--zeros]
    .venv/bin/python benchmarks/ev_upstream.py --table [--zeros]       # the markdown table of the results

Upstream runs in its own interpreter (a scratch venv, reference/ecosystem_recipes.md section 6, with the
offline sizing-table cache); this script only prepares schemas, starts one subprocess per run and collects
JSON. Outputs (under ``--out``, default ``benchmarks/upstream_2_5_0/``):

* ``ev_actions.json`` -- citylearn_challenge_2022_phase_all_plus_evs, central agent, a seeded action table
  ``numpy.random.default_rng(SEED).uniform(low, high, size=(steps, n_actions))`` in ``action_names`` order
  with the declared bounds (low = -1 for EV chargers that can discharge, 0 for the washing machine), global
  ``numpy.random`` and ``random`` seeded with SEED before construction. Per step: district and per-building
  net consumption (kWh), each charger's consumption (kWh), each EV's battery SOC array (0..1) and the SOC
  the agent observed; the raw ``numpy.random.normal`` draws upstream made for unplugged-EV SOC drift, per
  step call; the EVs' realised battery parameters; the KPI table (``env.evaluate()``).
* ``no_control.json`` -- every v2.4.2 dataset, all actions inactive (``env.step([[]])``, ideal loads):
  district net consumption sum (kWh), per-building sums, the KPI table and the wall time.
* ``zero_actions.json`` (``--zeros``) -- the same with the schema's actions active and all 0 (the
  convention of benchmarks/fidelity.py for 2.1.2); it differs from the above only where a ``cooling_device``
  action is active (baeda_3dem and the 2023 sets: 0 turns the device off, inactive serves the ideal load).

Upstream 2.5.0 reads a charger CSV by position into six fields; the v2.4.2 EV files carry eight columns
(``electric_vehicle_battery_capacity_khw`` and ``current_soc`` in third and fourth place) and crash 2.5.0
(a RecursionError at reset). The runner writes six-column copies of those files to a temporary folder and
points the schema at them; nothing else changes. See docs/ev.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
V242 = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.4.2"
EV_DATASET = "citylearn_challenge_2022_phase_all_plus_evs"
SEED = 20250
DROPPED_CHARGER_COLUMNS = ("electric_vehicle_battery_capacity_khw", "current_soc")

UPSTREAM = r"""
import json, random, sys, time
import numpy as np
job = json.load(open(sys.argv[1]))
np.random.seed(job["seed"]); random.seed(job["seed"])
draws, step_draws = [], []
_normal = np.random.normal
def _recording_normal(*args, **kwargs):
    value = _normal(*args, **kwargs)
    draws.append(float(value))
    return value
np.random.normal = _recording_normal
from citylearn.citylearn import CityLearnEnv
start = time.perf_counter()
env = CityLearnEnv(job["schema"], central_agent=True)
observations, _ = env.reset()
built = time.perf_counter()
names = env.action_names[0]
space = env.action_space[0]
obs_names = env.observation_names[0]
steps = env.episode_tracker.episode_time_steps
n = space.shape[0]
if job["mode"] == "actions":
    table = np.random.default_rng(job["seed"]).uniform(space.low, space.high, size=(steps, n))
evs = list(env.electric_vehicles)
chargers = [(b.name, c) for b in env.buildings for c in (b.electric_vehicle_chargers or [])]
soc_keys = {c.charger_id: f"connected_electric_vehicle_at_charger_{c.charger_id}_soc" for _, c in chargers}
observed = {k: [] for k in soc_keys}
def record_observation(obs):
    row = dict(zip(obs_names, obs[0]))
    for cid, key in soc_keys.items():
        if key in row:
            observed[cid].append(float(row[key]))
record_observation(observations)
calls, terminated = 0, False
while not terminated:
    action = {"actions": lambda: [table[calls].tolist()], "no_control": lambda: [[]],
              "zeros": lambda: [[0.0] * n]}[job["mode"]]()
    del draws[:]
    observations, _, terminated, _, _ = env.step(action)
    step_draws.append(list(draws))
    record_observation(observations)
    calls += 1
ran = time.perf_counter()
kpis = env.evaluate()
kpis = kpis.where(kpis.notna(), None)
def f32(values):  # the shortest text that reads back as the same float32 (upstream stores float32)
    return [float(str(v)) for v in np.asarray(values, dtype="float32")]
out = {
    "citylearn": __import__("citylearn").__version__, "numpy": np.__version__, "seed": job["seed"],
    "mode": job["mode"], "time_steps": int(steps), "step_calls": calls,
    "construct_s": built - start, "run_s": ran - built,
    "building_names": [b.name for b in env.buildings], "action_names": list(names),
    "action_low": f32(space.low), "action_high": f32(space.high),
    "district_net_electricity_consumption_sum": float(np.sum(env.net_electricity_consumption)),
    "building_net_electricity_consumption_sum": {b.name: float(np.sum(b.net_electricity_consumption))
                                                 for b in env.buildings},
    "kpis": kpis.to_dict("records"),
}
if job.get("detail"):
    out["district_net_electricity_consumption"] = f32(env.net_electricity_consumption)
    out["building_net_electricity_consumption"] = {b.name: f32(b.net_electricity_consumption)
                                                   for b in env.buildings}
    out["charger_electricity_consumption"] = {c.charger_id: f32(c.electricity_consumption) for _, c in chargers}
    out["charger_building"] = {c.charger_id: name for name, c in chargers}
    out["ev_soc"] = {ev.name: f32(ev.battery.soc) for ev in evs}
    out["observed_connected_soc"] = observed
    out["drift_normal_draws_per_step_call"] = step_draws
    out["ev_battery"] = {ev.name: {
        "capacity": float(ev.battery.capacity), "nominal_power": float(ev.battery.nominal_power),
        "initial_soc": float(ev.battery.initial_soc), "depth_of_discharge": float(ev.battery.depth_of_discharge),
        "efficiency": float(ev.battery.efficiency_history[0]),
        "loss_coefficient": float(ev.battery.loss_coefficient),
        "capacity_loss_coefficient": float(ev.battery.capacity_loss_coefficient),
        "power_efficiency_curve": np.asarray(ev.battery.power_efficiency_curve, dtype=float).T.tolist(),
        "capacity_power_curve": np.asarray(ev.battery.capacity_power_curve, dtype=float).T.tolist(),
    } for ev in evs}
json.dump(out, open(sys.argv[2], "w"))
"""


def six_column_charger_copies(dataset: Path, schema: dict, scratch: Path) -> dict:
    """Point every charger of ``schema`` at a six-column copy of its CSV in ``scratch`` (absolute paths).

    Upstream 2.5.0 reads a charger file by position into (state, EV id, departure time, required SOC at
    departure, estimated arrival time, estimated SOC at arrival); the v2.4.2 files have two more columns in
    third and fourth place, which are dropped here. Other files are read in place."""
    for building in schema["buildings"].values():
        for charger in (building.get("chargers") or {}).values():
            source = dataset / charger["charger_simulation"]
            table = pd.read_csv(source, dtype=str, keep_default_na=False)
            target = scratch / source.name
            table.drop(columns=[c for c in DROPPED_CHARGER_COLUMNS if c in table.columns]).to_csv(target, index=False)
            charger["charger_simulation"] = str(target)
    return schema


def no_control_schema(schema: dict) -> dict:
    """All actions inactive: upstream's no-control baseline (ideal loads, no storage use, no EV charging)."""
    for action in schema["actions"].values():
        action["active"] = False
    return schema


def run_upstream(python: str, schema: dict, mode: str, detail: bool, scratch: Path, tag: str) -> dict:
    """Run one upstream episode in ``python`` and return its JSON record plus the subprocess wall time (s)."""
    job, out = scratch / f"{tag}.job.json", scratch / f"{tag}.out.json"
    job.write_text(json.dumps({"schema": schema, "mode": mode, "seed": SEED, "detail": detail}))
    start = time.perf_counter()
    done = subprocess.run([python, "-c", UPSTREAM, str(job), str(out)], capture_output=True, text=True,
                          env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin", "HOME": str(Path.home())})
    wall = time.perf_counter() - start
    if done.returncode != 0:
        return {"error": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed", "wall_s": wall}
    record = json.loads(out.read_text())
    record["wall_s"] = wall
    return record


def load_schema(dataset: Path, scratch: Path) -> dict:
    """The dataset's schema.json with an absolute root directory and six-column charger copies."""
    schema = json.loads((dataset / "schema.json").read_text())
    schema["root_directory"] = str(dataset)
    schema["central_agent"] = True
    return six_column_charger_copies(dataset, schema, scratch)


def markdown_table(results: dict) -> str:
    """The no-control results as a markdown table: steps, buildings, district net consumption [kWh], wall
    time [s] and a few district KPIs (blank where upstream returns none)."""
    keys = ("cost_total", "carbon_emissions_total", "daily_peak_average", "discomfort_proportion")
    lines = ["| dataset | steps | buildings | district net kWh | wall s | " + " | ".join(keys) + " |",
             "|---|---|---|---|---|" + "---|" * len(keys)]
    for name, r in sorted(results.items()):
        if "error" in r:
            lines.append(f"| {name} | failed: {r['error']} |")
            continue
        district = {k["cost_function"]: k["value"] for k in r["kpis"] if k["name"] == "District"}
        cells = ["" if district.get(k) is None else f"{district[k]:.4f}" for k in keys]
        lines.append(f"| {name} | {r['time_steps']} | {len(r['building_names'])} | "
                     f"{r['district_net_electricity_consumption_sum']:.1f} | {r['wall_s']:.0f} | " + " | ".join(cells)
                     + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream", help="a Python interpreter with citylearn==2.5.0")
    parser.add_argument("--only", choices=("ev", "no-control"), help="run one part only")
    parser.add_argument("--datasets", nargs="*", help="no-control: these v2.4.2 datasets (default: all)")
    parser.add_argument("--zeros", action="store_true",
                        help="no-control part: the schema's actions stay active and are all 0 (zero_actions.json)")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "upstream_2_5_0")
    parser.add_argument("--table", action="store_true", help="print the no-control table of --out and stop")
    args = parser.parse_args()
    if args.table:
        print(markdown_table(json.loads((args.out / ("zero_actions.json" if args.zeros else "no_control.json"))
                                        .read_text())))
        return
    if not args.upstream:
        parser.error("--upstream is required to run")
    if not V242.is_dir():
        sys.exit(f"{V242} is absent: the upstream datasets live in ../shared")
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        if args.only in (None, "ev"):
            record = run_upstream(args.upstream, load_schema(V242 / EV_DATASET, scratch), "actions", True,
                                  scratch, "ev")
            (args.out / "ev_actions.json").write_text(json.dumps(record))
            print(f"ev actions: {record.get('error') or 'ok'} in {record['wall_s']:.1f} s")
        if args.only in (None, "no-control"):
            names = args.datasets or sorted(p.name for p in V242.iterdir() if (p / "schema.json").is_file())
            path = args.out / ("zero_actions.json" if args.zeros else "no_control.json")
            results = json.loads(path.read_text()) if path.is_file() else {}
            for name in names:
                schema = load_schema(V242 / name, scratch)
                schema = schema if args.zeros else no_control_schema(schema)
                record = run_upstream(args.upstream, schema, "zeros" if args.zeros else "no_control", False,
                                      scratch, name)
                total = record.get("district_net_electricity_consumption_sum", float("nan"))
                results[name] = record
                path.write_text(json.dumps(results, indent=1))
                print(f"{name}: {record.get('error') or f'{total:.1f} kWh'} in {record['wall_s']:.1f} s",
                      flush=True)


if __name__ == "__main__":
    main()
