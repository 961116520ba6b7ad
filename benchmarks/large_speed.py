"""Speed and peak memory on large districts: citylearn_env vs upstream CityLearn 2.1.2, side by side in one run.

    .venv/bin/python benchmarks/large_speed.py --upstream-python /tmp/cl212/bin/python \
        [--steps 2000] [--synthetic-steps 500] [--repeats 1] [--cases phase_all 2021 synthetic_100] [--json OUT]

Cases (upstream's datasets from ../shared/data/citylearn/upstream/v2.1.2/, read in place, unchanged):

* ``phase_all``: citylearn_challenge_2022_phase_all, 17 buildings (battery + PV), one year (8,760 steps);
* ``2021``: citylearn_challenge_2021, 9 buildings (autosized heat pumps, DHW heaters, tanks; battery, PV),
  four years (35,040 steps);
* ``synthetic_100``: 100 buildings, one year: phase_all's 17 buildings repeated (renamed copies
  ``Building_1_c0`` ... until 100). Ours builds it through the typed config
  (``cfg.replace(buildings=...)`` of ``load_schema``); upstream gets the same repeated buildings as a schema
  dict whose ``root_directory`` is the dataset folder.

Upstream needs minutes per year of steps on these, so each side times the same fixed number of ``step`` calls
(``--steps``, from the episode start), not the whole episode; ours also reports its whole first episode.
Actions: ``numpy.random.default_rng(0).uniform(low, high)`` of the action space, one row per step, the same
table on both sides. Each side runs in a fresh subprocess with one thread (OMP/MKL/OPENBLAS/NUMBA = 1,
torch 1 thread), ours with the CityLearn 2.1 preset (``compat=True``); sides alternate per repeat. Reported:
construction + reset seconds, steps/s of the timed loop (wall and CPU), and the child's peak resident memory
(``resource.getrusage(RUSAGE_SELF).ru_maxrss``: interpreter, imports, data and state).
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2"
CASES = {"phase_all": "citylearn_challenge_2022_phase_all", "2021": "citylearn_challenge_2021",
         "synthetic_100": "citylearn_challenge_2022_phase_all"}
THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
SYNTHETIC_BUILDINGS = 100


def repeated_names(names: list[str], n: int) -> list[tuple[str, str]]:
    """(source building, copy name) for ``n`` copies cycling through ``names``: ``Building_1_c0``, ..."""
    return [(names[i % len(names)], f"{names[i % len(names)]}_c{i // len(names)}") for i in range(n)]


# --------------------------------------------------------------------------- child side
def _ours(case: str, schema: Path):
    """(env, action space, buildings, step(a) -> terminated) of citylearn_env with the CityLearn 2.1 preset."""
    # lazy: only the "ours" child loads citylearn_env (the upstream child's peak memory must not include it)
    from citylearn_env import CityLearnEnv, load_schema

    config = load_schema(schema, settings="citylearn-2.1")
    if case == "synthetic_100":
        by_name = {b.name: b for b in config.buildings}
        copies = repeated_names(list(by_name), SYNTHETIC_BUILDINGS)
        config = config.replace(buildings=tuple(dataclasses.replace(by_name[src], name=new) for src, new in copies))
    env = CityLearnEnv(config, compat=True)
    env.reset(seed=0)
    return env, env.action_space, len(config.buildings), lambda a: env.step(a)[2]


def _upstream(case: str, schema: Path):
    """(env, action space, buildings, step(a) -> terminated) of upstream CityLearn 2.1.2, one torch thread."""
    import torch  # lazy: upstream's packages exist only in the upstream interpreter
    from citylearn.citylearn import CityLearnEnv

    torch.set_num_threads(1)
    source: object = str(schema)
    if case == "synthetic_100":
        raw = json.loads(schema.read_text())
        raw["root_directory"] = str(schema.parent)
        copies = repeated_names(list(raw["buildings"]), SYNTHETIC_BUILDINGS)
        raw["buildings"] = {new: copy.deepcopy(raw["buildings"][src]) for src, new in copies}
        source = raw
    env = CityLearnEnv(source, central_agent=True)
    env.reset()
    return env, env.action_space[0], len(env.buildings), lambda a: env.step([a.tolist()])[2]


def _whole_episode(env, space, step) -> dict:
    """Ours only: the rest of the first episode, then one whole episode of zero actions, timed."""
    done = False
    while not done:
        done = step(np.zeros(space.shape))
    env.reset(seed=0)
    zeros, n, t0 = np.zeros(space.shape), 0, time.perf_counter()
    done = False
    while not done:
        done, n = step(zeros), n + 1
    return {"episode_steps": n, "episode_s": time.perf_counter() - t0}


def _child(side: str, case: str, steps: int, out: str) -> None:
    schema = DATA / CASES[case] / "schema.json"
    t0 = time.perf_counter()
    env, space, n_buildings, step = (_ours if side == "ours" else _upstream)(case, schema)
    build_s = time.perf_counter() - t0
    table = np.random.default_rng(0).uniform(space.low, space.high, size=(steps, space.shape[0]))
    t0, c0 = time.perf_counter(), time.process_time()
    for a in table:
        if step(a):
            raise RuntimeError(f"{side}: episode ended before {steps} steps")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    result = {"side": side, "case": case, "buildings": n_buildings, "actions": int(space.shape[0]),
              "build_s": build_s, "steps": steps, "steps_per_s": steps / wall, "steps_per_cpu_s": steps / cpu}
    if side == "ours":
        result.update(_whole_episode(env, space, step))
    result["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    Path(out).write_text(json.dumps(result))


# --------------------------------------------------------------------------- parent side
def run_child(python: str, side: str, case: str, steps: int) -> dict:
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as handle:
        out = handle.name
    env = {**os.environ, **THREADS, "PYTHONPATH": str(ROOT)}
    subprocess.run([python, __file__, "--child", side, case, str(steps), out], check=True, env=env,
                   stdout=subprocess.DEVNULL)
    return json.loads(Path(out).read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream-python", default="/tmp/cl212/bin/python")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--synthetic-steps", type=int, default=500, help="timed steps of synthetic_100")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--cases", nargs="*", default=list(CASES))
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    runs: dict[str, dict[str, list[dict]]] = {c: {"ours": [], "upstream": []} for c in args.cases}
    for case in args.cases:
        for r in range(args.repeats):
            order = ("ours", "upstream") if r % 2 == 0 else ("upstream", "ours")
            for side in order:
                python = sys.executable if side == "ours" else args.upstream_python
                steps = args.synthetic_steps if case == "synthetic_100" else args.steps
                runs[case][side].append(run_child(python, side, case, steps))
    print(f"load average (1 min) before {load:.2f}, after {os.getloadavg()[0]:.2f}; {args.steps} timed steps "
          f"({args.synthetic_steps} on synthetic_100), median of {args.repeats} repeat(s)")
    print("| case | buildings x steps | ours steps/s (CPU) | upstream steps/s (CPU) | ratio wall (CPU) | "
          "ours / upstream build+reset s | ours / upstream peak RSS MB | ours whole episode s |")
    print("|---|---|---|---|---|---|---|---|")
    for case, sides in runs.items():
        def med(side: str, key: str, sides: dict = sides) -> float:
            return statistics.median(x[key] for x in sides[side])

        o, u = med("ours", "steps_per_s"), med("upstream", "steps_per_s")
        oc, uc = med("ours", "steps_per_cpu_s"), med("upstream", "steps_per_cpu_s")
        first = sides["ours"][0]
        print(f"| {case} | {first['buildings']} x {first['episode_steps'] + 1} | {o:,.0f} ({oc:,.0f}) | "
              f"{u:,.1f} ({uc:,.1f}) | {o / u:,.0f}x ({oc / uc:,.0f}x) | {med('ours', 'build_s'):.2f} / "
              f"{med('upstream', 'build_s'):.2f} | {med('ours', 'peak_rss_mb'):,.0f} / "
              f"{med('upstream', 'peak_rss_mb'):,.0f} | {med('ours', 'episode_s'):.2f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "--child":
        _child(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
    else:
        main()
