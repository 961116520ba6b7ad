"""Typed-core speed: citylearn_env vs upstream CityLearn 2.1.2 on citylearn_challenge_2023_phase_1, interleaved.

    .venv/bin/python benchmarks/typed_core_speed.py --upstream-python /tmp/cl212/bin/python [--repeats 5]
        [--episodes 2] [--seed 0] [--json OUT] [--ours-only] [--ours-root DIR] [--profile OUT]

The dataset is upstream's own 2023 phase-1 month (3 LSTM buildings with heat pumps, DHW and battery storage;
9 continuous actions, 720 hourly time steps = 719 ``step`` calls per episode), read unchanged from
../shared/data/citylearn/upstream/v2.1.2/. Each repeat is one fresh subprocess per side, and the sides alternate
(ours first on even repeats, upstream first on odd ones) so that a change in machine load hits both. Every
subprocess runs one thread (OMP/MKL/OPENBLAS/NUMBA threads = 1; ``torch.set_num_threads(1)`` upstream).

In a subprocess: import the env module (timed), construct the env (timed: ``build_s``), ``reset`` (timed),
then ``--episodes`` whole episodes, each ``reset`` followed by the step loop over an action table drawn up
front: ``numpy.random.default_rng(seed).uniform(low, high)`` of the env's ``action_space``, one row per
step. Both sides get the same table (its SHA-256 is reported). Only the step loop is timed. The first
episode carries lazy one-off costs (numba cache load, torch warm-up) and is reported on its own; "steady" is
the median of the later episodes. Across repeats the median is reported; ratio = ours / upstream.

Public API only: ``CityLearnEnv(schema, compat=True)``, ``reset(seed=)``, ``step(a)``, ``action_space``
(upstream: ``CityLearnEnv(schema, central_agent=True)``, ``reset()``, ``step([a])``, ``action_space[0]``).
``--profile OUT`` instead runs cProfile over one episode of ours (after one unprofiled warm-up episode)
and writes the top 15 functions by cumulative and by total time.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = (ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2"
          / "citylearn_challenge_2023_phase_1" / "schema.json")
THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS")


# --------------------------------------------------------------------------- child side (runs in each venv)
def _action_table(low, high, n_steps: int, seed: int):
    """``n_steps`` x n_actions float64 actions, uniform in [low, high] (the action space's bounds)."""
    import numpy as np

    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    return np.random.default_rng(seed).uniform(low, high, size=(n_steps, low.size))


def _episode_ours(env, table, seed: int) -> tuple[float, float]:
    """One episode of ours: reset, step through ``table``; returns (wall s, CPU s) of the step loop."""
    env.reset(seed=seed)
    rows = list(table)
    done = False
    t0, c0 = time.perf_counter(), time.process_time()
    for a in rows:
        _, _, terminated, truncated, _ = env.step(a)
        done = terminated or truncated
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if not done:
        raise RuntimeError(f"ours: episode not done after {len(rows)} steps")
    return wall, cpu


def _episode_upstream(env, table, seed: int) -> tuple[float, float]:
    """One episode of upstream 2.1.2 (``reset`` takes no seed); returns (wall s, CPU s) of the step loop."""
    env.reset()
    rows = [[row] for row in table.tolist()]
    done = False
    t0, c0 = time.perf_counter(), time.process_time()
    for a in rows:
        done = env.step(a)[2]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if not done:
        raise RuntimeError(f"upstream: episode not done after {len(rows)} steps")
    return wall, cpu


def _child(side: str, schema: str, n_steps: int, episodes: int, seed: int, out: str) -> None:
    """Run one side in this interpreter and write its timings (JSON) to ``out``."""
    import hashlib

    t0 = time.perf_counter()
    if side == "ours":
        from citylearn_env import CityLearnEnv

        import_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        env = CityLearnEnv(schema, compat=True)
        build_s = time.perf_counter() - t0
        space, episode, module = env.action_space, _episode_ours, sys.modules["citylearn_env"].__file__
        t0 = time.perf_counter()
        env.reset(seed=seed)
    else:
        import torch
        from citylearn.citylearn import CityLearnEnv

        torch.set_num_threads(1)
        import_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        env = CityLearnEnv(schema, central_agent=True)
        build_s = time.perf_counter() - t0
        space, episode, module = env.action_space[0], _episode_upstream, sys.modules["citylearn"].__file__
        t0 = time.perf_counter()
        env.reset()
    reset_s = time.perf_counter() - t0
    table = _action_table(space.low, space.high, n_steps, seed)
    runs = [episode(env, table, seed) for _ in range(episodes)]
    result = {
        "side": side, "module": module, "import_s": import_s, "build_s": build_s, "reset_s": reset_s,
        "steps": n_steps, "actions": int(table.shape[1]),
        "actions_sha256": hashlib.sha256(table.tobytes()).hexdigest()[:16],
        "steps_per_s": [n_steps / wall for wall, _ in runs],
        "steps_per_cpu_s": [n_steps / cpu for _, cpu in runs],
    }
    Path(out).write_text(json.dumps(result))


def _profile(schema: str, n_steps: int, seed: int, out: str) -> None:
    """cProfile one episode of ours (after one warm-up episode); top 15 by cumulative and by total time."""
    import cProfile
    import io
    import pstats

    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(schema, compat=True)
    table = _action_table(env.action_space.low, env.action_space.high, n_steps, seed)
    _episode_ours(env, table, seed)
    profiler = cProfile.Profile()
    profiler.enable()
    wall, _ = _episode_ours(env, table, seed)
    profiler.disable()
    text = io.StringIO()
    text.write(f"cProfile of one episode of citylearn_env ({sys.modules['citylearn_env'].__file__}), "
               f"{schema}, {n_steps} steps, seed {seed}, after one warm-up episode.\n"
               f"Step loop under the profiler: {wall:.3f} s = {1e6 * wall / n_steps:.0f} us/step "
               f"(profiler overhead included).\n\n")
    for key in ("cumulative", "tottime"):
        text.write(f"===== top 15 by {key} =====\n")
        pstats.Stats(profiler, stream=text).strip_dirs().sort_stats(key).print_stats(15)
    Path(out).write_text(text.getvalue())


# --------------------------------------------------------------------------- parent side
def episode_steps(schema_path: Path) -> int:
    """Number of ``step`` calls in one episode: (end - start) time steps of the schema (T steps, T - 1 calls)."""
    schema = json.loads(schema_path.read_text())
    if schema.get("episode_time_steps"):
        sys.exit(f"{schema_path}: episode_time_steps is set; this benchmark expects one whole-period episode")
    return int(schema["simulation_end_time_step"]) - int(schema["simulation_start_time_step"])


def run_side(side: str, python: str, ours_root: Path, schema: Path, n_steps: int, episodes: int,
             seed: int) -> dict:
    """One fresh subprocess of ``side``; its JSON result, or {"error": last stderr line}."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(dict.fromkeys(THREAD_VARS, "1"))
    if side in ("ours", "profile"):
        env["PYTHONPATH"] = str(ours_root)
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "result.json"
        cmd = [python, str(Path(__file__).resolve()), "--_child", side, "--schema", str(schema),
               "--_steps", str(n_steps), "--episodes", str(episodes), "--seed", str(seed), "--_out", str(out)]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=scratch)
        if proc.returncode or not out.exists():
            lines = proc.stderr.strip().splitlines()
            return {"side": side, "error": lines[-1] if lines else f"exit status {proc.returncode}"}
        return json.loads(out.read_text()) if side != "profile" else {}


def summarise(runs: list[dict]) -> dict:
    """Medians over repeats: first-episode and steady (later episodes) steps/s, build/import/reset seconds."""
    ok = [r for r in runs if "error" not in r]
    if not ok:
        return {"error": runs[0]["error"] if runs else "not run"}

    def med(values: list[float]) -> float:
        return statistics.median(values)

    steady = [med(r["steps_per_s"][1:] or r["steps_per_s"]) for r in ok]
    return {
        "repeats": len(ok), "steady_steps_per_s": med(steady), "steady_min": min(steady), "steady_max": max(steady),
        "first_episode_steps_per_s": med([r["steps_per_s"][0] for r in ok]),
        "steady_steps_per_cpu_s": med([med(r["steps_per_cpu_s"][1:] or r["steps_per_cpu_s"]) for r in ok]),
        "import_s": med([r["import_s"] for r in ok]), "build_s": med([r["build_s"] for r in ok]),
        "reset_s": med([r["reset_s"] for r in ok]), "actions_sha256": ok[0]["actions_sha256"],
        "module": ok[0]["module"],
    }


def git_label(ours_root: Path) -> str:
    """Short commit of ``ours_root`` (+"-dirty" if tracked files differ), or "unknown" outside a git tree."""
    env = dict(os.environ, GIT_OPTIONAL_LOCKS="0")
    head = subprocess.run(["git", "-C", str(ours_root), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True, env=env)
    if head.returncode:
        return "unknown"
    status = subprocess.run(["git", "-C", str(ours_root), "status", "--porcelain", "--untracked-files=no"],
                            capture_output=True, text=True, env=env)
    return head.stdout.strip() + ("-dirty" if status.stdout.strip() else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream-python", default="/tmp/cl212/bin/python",
                        help="interpreter with citylearn==2.1.2 (default /tmp/cl212/bin/python)")
    parser.add_argument("--ours-only", action="store_true", help="skip upstream")
    parser.add_argument("--ours-root", type=Path, default=ROOT,
                        help="directory to import citylearn_env from (default: this repo; e.g. a git-archive export)")
    parser.add_argument("--ours-label", help="label for ours (default: git commit of --ours-root)")
    parser.add_argument("--schema", type=Path, default=SCHEMA)
    parser.add_argument("--repeats", type=int, default=5, help="subprocesses per side (>= 3)")
    parser.add_argument("--episodes", type=int, default=2, help="episodes per subprocess (>= 2: first + steady)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="write all raw and summary numbers here")
    parser.add_argument("--profile", type=Path, help="only cProfile one episode of ours into this file")
    parser.add_argument("--_child", choices=("ours", "upstream", "profile"), help=argparse.SUPPRESS)
    parser.add_argument("--_steps", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--_out", help=argparse.SUPPRESS)
    args = parser.parse_args()

    if args._child == "profile":
        return _profile(str(args.schema), args._steps, args.seed, args._out)
    if args._child:
        return _child(args._child, str(args.schema), args._steps, args.episodes, args.seed, args._out)
    if not args.schema.exists():
        sys.exit(f"needs the upstream dataset at {args.schema}")
    if args.repeats < 3 or args.episodes < 2:
        sys.exit("--repeats must be >= 3 and --episodes >= 2")
    n_steps = episode_steps(args.schema)
    ours_root = args.ours_root.resolve()
    label = args.ours_label or git_label(ours_root)

    if args.profile:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        env.update(dict.fromkeys(THREAD_VARS, "1"), PYTHONPATH=str(ours_root))
        subprocess.run([sys.executable, str(Path(__file__).resolve()), "--_child", "profile", "--schema",
                        str(args.schema), "--_steps", str(n_steps), "--seed", str(args.seed), "--_out",
                        str(args.profile.resolve())], env=env, check=True, cwd=tempfile.gettempdir())
        print(f"wrote {args.profile}")
        return

    sides = ["ours"] if args.ours_only else ["ours", "upstream"]
    pythons = {"ours": sys.executable, "upstream": args.upstream_python}
    load_before = os.getloadavg()
    raw: dict[str, list[dict]] = {side: [] for side in sides}
    for r in range(args.repeats):
        for side in sides if r % 2 == 0 else sides[::-1]:
            result = run_side(side, pythons[side], ours_root, args.schema, n_steps, args.episodes, args.seed)
            result["load_1min_after"] = os.getloadavg()[0]
            raw[side].append(result)
            shown = (f"{statistics.median(result['steps_per_s'][1:]):,.0f} steps/s steady"
                     if "error" not in result else result["error"])
            print(f"repeat {r + 1}/{args.repeats} {side}: {shown}", file=sys.stderr, flush=True)
    load_after = os.getloadavg()

    summary = {side: summarise(raw[side]) for side in sides}
    ours, up = summary["ours"], summary.get("upstream", {})
    both = "error" not in ours and up and "error" not in up
    report = {
        "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"), "ours_label": label,
        "ours_root": str(ours_root), "schema": str(args.schema), "steps_per_episode": n_steps,
        "repeats": args.repeats, "episodes": args.episodes, "seed": args.seed,
        "loadavg_before": load_before, "loadavg_after": load_after, "summary": summary, "raw": raw,
        "ratio_steady": ours["steady_steps_per_s"] / up["steady_steps_per_s"] if both else None,
        "ratio_first_episode": (ours["first_episode_steps_per_s"] / up["first_episode_steps_per_s"]
                                if both else None),
        "ratio_steady_cpu": (ours["steady_steps_per_cpu_s"] / up["steady_steps_per_cpu_s"] if both else None),
        "same_actions": ours.get("actions_sha256") == up.get("actions_sha256") if both else None,
    }
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    print(format_table(report))


def format_table(report: dict) -> str:
    """A markdown table of the summary (steady = median of later episodes, first = first episode)."""

    def cell(side: dict, key: str, fmt: str) -> str:
        return format(side[key], fmt) if key in side else side.get("error", "-")

    lines = ["| side | steady steps/s (min-max) | first-episode steps/s | steps per CPU-s | import s | build s "
             "| reset s |", "|---|---|---|---|---|---|---|"]
    for name, side in report["summary"].items():
        spread = (f" ({side['steady_min']:,.0f}-{side['steady_max']:,.0f})" if "steady_min" in side else "")
        lines.append(f"| {name} | {cell(side, 'steady_steps_per_s', ',.0f')}{spread} "
                     f"| {cell(side, 'first_episode_steps_per_s', ',.0f')} "
                     f"| {cell(side, 'steady_steps_per_cpu_s', ',.0f')} | {cell(side, 'import_s', '.2f')} "
                     f"| {cell(side, 'build_s', '.3f')} | {cell(side, 'reset_s', '.3f')} |")
    before, after = report["loadavg_before"], report["loadavg_after"]
    lines.append("")
    lines.append(f"ours = {report['ours_label']} ({report['ours_root']}); {report['repeats']} repeats x "
                 f"{report['episodes']} episodes x {report['steps_per_episode']} steps; load average "
                 f"before {before[0]:.2f}/{before[1]:.2f}/{before[2]:.2f}, after "
                 f"{after[0]:.2f}/{after[1]:.2f}/{after[2]:.2f}; {report['date']}")
    if report["ratio_steady"] is not None:
        lines.append(f"ratio ours/upstream: steady {report['ratio_steady']:.1f}x, first episode "
                     f"{report['ratio_first_episode']:.1f}x, steady per CPU-s {report['ratio_steady_cpu']:.1f}x; "
                     f"same action table: {report['same_actions']}")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
