"""Upstream CityLearn 2.5.0's per-step ``Electric_Vehicles_Reward_Function`` on the EV dataset (parity reference).

    nice -n 19 .venv/bin/python benchmarks/ev_reward_upstream.py --upstream /tmp/cl250/bin/python [--steps 600]

Runs citylearn==2.5.0 (a scratch venv, ../shared/reference/ecosystem_recipes.md section 6, with the offline
sizing cache) on citylearn_challenge_2022_phase_all_plus_evs twice -- central agent and one agent per building --
with the schema's own reward and the action table of ``benchmarks/ev_upstream.py``
(``numpy.random.default_rng(SEED).uniform(low, high, size=(time_steps, 26))`` over the central action space,
global ``numpy.random`` and ``random`` seeded with SEED before construction; a decentralised row is the central
row cut into the buildings' action counts, in building order). Both runs use the six-column charger copies of
``ev_upstream.py``. The first ``--steps`` step calls are recorded in ``benchmarks/upstream_2_5_0/ev_rewards.json``:

* ``central``: the reward of each step call (one number; step call k acts on row k);
* ``decentral``: per building, the reward of each step call;
* ``decentral_base`` / ``decentral_penalty``: upstream's own split per building (the EV part and the charging
  constraint penalty, 0 on this dataset), for diagnosis.

Upstream runs in its own interpreter; this script writes the job, starts it under the caller's priority and
collects the JSON. ``--speed`` instead times citylearn_env on the same dataset with the EV reward and with the
default reward (2,000 steps, median of 5 alternated repeats):

    .venv/bin/python benchmarks/ev_reward_upstream.py --speed
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ev_upstream import EV_DATASET, ROOT, SEED, V242, six_column_charger_copies  # noqa: E402

UPSTREAM = r"""
import json, random, sys
import numpy as np
job = json.load(open(sys.argv[1]))
from citylearn.citylearn import CityLearnEnv
def compact(value):
    return float(f"{float(value):.9g}")
out = {"citylearn": __import__("citylearn").__version__, "numpy": np.__version__, "seed": job["seed"]}
for central in (True, False):
    np.random.seed(job["seed"]); random.seed(job["seed"])
    schema = dict(job["schema"], central_agent=central)
    env = CityLearnEnv(schema, central_agent=central)
    env.reset()
    names = [b.name for b in env.buildings]
    sizes = [len(b.active_actions) for b in env.buildings]
    low = np.concatenate([s.low for s in env.action_space]) if not central else env.action_space[0].low
    high = np.concatenate([s.high for s in env.action_space]) if not central else env.action_space[0].high
    steps = env.episode_tracker.episode_time_steps
    table = np.random.default_rng(job["seed"]).uniform(low, high, size=(steps, low.size))
    cuts = np.cumsum(sizes)[:-1]
    rewards, base, penalty = [], [], []
    for k in range(job["steps"]):
        row = table[k]
        action = [row.tolist()] if central else [part.tolist() for part in np.split(row, cuts)]
        _, reward, _, _, _ = env.step(action)
        rewards.append([compact(r) for r in np.ravel(reward)])
        if not central:
            base.append([compact(r) for r in env.reward_function._last_base_rewards_per_building])
            penalty.append([compact(r) for r in env.reward_function._last_penalties_per_building])
    out["building_names"] = names
    out["reward_type"] = type(env.reward_function).__module__ + "." + type(env.reward_function).__name__
    out["time_steps"] = int(steps)
    if central:
        out["central"] = [r[0] for r in rewards]
        out["action_low"] = [float(v) for v in low]
        out["action_high"] = [float(v) for v in high]
    else:
        out["decentral"] = {n: [r[b] for r in rewards] for b, n in enumerate(names)}
        out["decentral_base"] = {n: [r[b] for r in base] for b, n in enumerate(names)}
        out["decentral_penalty"] = {n: [r[b] for r in penalty] for b, n in enumerate(names)}
json.dump(out, open(sys.argv[2], "w"))
"""


def our_speed(steps: int, repeats: int) -> dict[str, float]:
    """Median steps/s of citylearn_env on the EV dataset (2.5 preset, random actions) with the schema's EV reward
    and with the default RewardFunction, the two alternated in one run."""
    import numpy as np

    sys.path.insert(0, str(ROOT))
    from citylearn_env import CityLearnEnv

    schema = V242 / EV_DATASET / "schema.json"
    rewards = {"Electric_Vehicles_Reward_Function": None, "RewardFunction": "citylearn.reward_function.RewardFunction"}
    envs = {k: CityLearnEnv(schema, settings="citylearn-2.5", reward_function=v) for k, v in rewards.items()}
    table = np.random.default_rng(SEED).uniform(-1.0, 1.0, size=(steps, envs["RewardFunction"].action_space.shape[0]))
    times: dict[str, list[float]] = {k: [] for k in envs}
    for _ in range(repeats):
        for name, env in envs.items():
            env.reset(seed=SEED)
            start = time.perf_counter()
            for k in range(steps):
                env.step(table[k])
            times[name].append(time.perf_counter() - start)
    return {name: steps / float(np.median(t)) for name, t in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speed", action="store_true", help="only time citylearn_env with and without the EV reward")
    parser.add_argument("--upstream", help="a Python interpreter with citylearn==2.5.0")
    parser.add_argument("--steps", type=int, default=600, help="step calls to record (from the episode start)")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "upstream_2_5_0" / "ev_rewards.json")
    args = parser.parse_args()
    if args.speed:
        print(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
        for name, rate in our_speed(2000, 5).items():
            print(f"{name}: {rate:,.0f} steps/s")
        return
    if not args.upstream:
        parser.error("--upstream is required to run")
    dataset = V242 / EV_DATASET
    if not dataset.is_dir():
        sys.exit(f"{dataset} is absent: the upstream datasets live in ../shared")
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        schema = json.loads((dataset / "schema.json").read_text())
        schema["root_directory"] = str(dataset)
        job, out = scratch / "job.json", scratch / "out.json"
        job.write_text(json.dumps({"schema": six_column_charger_copies(dataset, schema, scratch), "seed": SEED,
                                   "steps": args.steps}))
        start = time.perf_counter()
        done = subprocess.run([args.upstream, "-c", UPSTREAM, str(job), str(out)], capture_output=True, text=True,
                              env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin", "HOME": str(Path.home())})
        if done.returncode != 0:
            sys.exit(done.stderr.strip() or "upstream run failed")
        record = json.loads(out.read_text())
    record["steps"] = args.steps
    record["wall_s"] = round(time.perf_counter() - start, 1)
    args.out.write_text(json.dumps(record))
    print(f"{args.out}: {args.steps} step calls x 2 runs in {record['wall_s']} s")


if __name__ == "__main__":
    main()
