"""The whole paper as independent tasks: one task per (benchmark, multiplier m, seed), run on a task runner,
each result written to ``<out>/tasks/<key>.json`` as soon as it finishes, so a rerun skips finished tasks.

A task file holds the run's options and the schema file's sha256; a file whose options or schema differ
from the current run is not reused. Learning rows run once per seed and are reported as mean and sample
standard deviation over the seeds; rule-based and no-control rows are deterministic and run once.

Runners follow the build's ``Runner`` protocol (``map(step, fn, {label: args})``, pipeline/build.py):
:class:`pipeline.build.InProcessRunner` (``workers=1``), :class:`ProcessRunner` (one process per core) or
:class:`DaskRunner` (a local Dask cluster of worker processes, or an existing cluster's scheduler).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.paper import BENCHMARKS, RunOptions

SWEEP_ID = "rlc-b1-d_o-hp"
#: per-run numbers averaged over seeds (the rest of a run's fields are labels or the trace)
METRICS = ("cost", "emissions", "discomfort", "consumption", "average_daily_peak", "overcooling_mean",
           "overcooling_std", "undercooling_mean", "undercooling_std", "mean_abs_action", "train_seconds",
           "train_cpu_seconds", "seconds")


@dataclass(frozen=True)
class Task:
    """One run: benchmark ``id`` with over-cooling multiplier ``multiplier`` and seed ``seed``."""

    id: str
    multiplier: float
    seed: int

    @property
    def key(self) -> str:
        return f"{self.id}-m{self.multiplier:g}-s{self.seed}"


def plan_tasks(only: Sequence[str] | None, sweep: Sequence[float], *, seed: int = 0, seeds: int = 1,
               multiplier: float = 3.0) -> list[Task]:
    """The tasks of a run, longest first: SAC rows ``seeds`` times, the m-sweep's multipliers, the rest once.

    ``only``: benchmark ids (None = all 17, [] = none); ``sweep``: multipliers of rlc-b1-d_o-hp.
    """
    from citylearn_env.errors import InputError

    known = {b.id: b for b in BENCHMARKS}
    unknown = sorted(set(only or ()) - set(known))
    if unknown:
        raise InputError(f"unknown benchmark id(s) {unknown}; known: {', '.join(known)}", column="--only")
    if seeds < 1:
        raise InputError(f"--seeds must be >= 1, got {seeds}", column="--seeds")
    chosen = [b for b in BENCHMARKS if only is None or b.id in only]
    tasks: dict[str, Task] = {}
    for b in chosen:
        for s in range(seed, seed + (seeds if b.control == "sac" else 1)):
            task = Task(b.id, multiplier, s)
            tasks[task.key] = task
    for m in sweep:
        for s in range(seed, seed + seeds):
            task = Task(SWEEP_ID, float(m), s)
            tasks[task.key] = task
    return sorted(tasks.values(), key=lambda t: known[t.id].control != "sac")


def fingerprint(schema_path: str | Path, options: RunOptions) -> dict[str, Any]:
    """What a task result depends on besides the task: the schema file's sha256 and the run options."""
    digest = hashlib.sha256(Path(schema_path).read_bytes()).hexdigest()
    return {"schema_sha256": digest, **{k: list(v) if isinstance(v, tuple) else v
                                        for k, v in dataclasses.asdict(options).items() if k != "cores"}}


def read_finished(path: Path, expected: Mapping[str, Any]) -> dict[str, Any] | None:
    """The result in task file ``path`` when it exists and was made with ``expected``; else None."""
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return stored["result"] if stored.get("fingerprint") == dict(expected) else None


@lru_cache(maxsize=2)
def _district(schema_path: str, settings: str | None):
    from pipeline.paper import load_district

    return load_district(schema_path, settings)


def run_task(schema_path: str, task: Task, options: RunOptions, out_file: str,
             expected: Mapping[str, Any]) -> dict[str, Any]:
    """Run ``task`` and write its result file atomically (a worker's unit of work; top level, picklable)."""
    from pipeline.paper import run_benchmark

    bench = next(b for b in BENCHMARKS if b.id == task.id)
    print(f"running {task.key} ...", flush=True)
    result = run_benchmark(_district(schema_path, options.settings), bench, seed=task.seed,
                           multiplier=task.multiplier, options=options)
    target = Path(out_file)
    scratch = target.with_suffix(f".tmp{os.getpid()}")
    scratch.write_text(json.dumps({"fingerprint": dict(expected), "result": result}))
    scratch.replace(target)
    print(f"finished {task.key} in {result['seconds']:.1f} s", flush=True)
    return result


def gather(submit: Callable[..., Any], fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
    """Submit every call (``submit(label, fn, *args)`` returns a future), then wait for each: {label: result}."""
    futures = {label: submit(label, fn, *args) for label, args in calls.items()}
    return {label: future.result() for label, future in futures.items()}


class ProcessRunner:
    """The build's runner protocol on a pool of ``workers`` processes (spawned: no state shared)."""

    def __init__(self, workers: int):
        self.workers = workers

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        import multiprocessing

        with ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            return gather(lambda _, f, *args: pool.submit(f, *args), fn, calls)


class DaskRunner:
    """The build's runner protocol on Dask: the scheduler at ``address``, else a local cluster of ``workers``
    single-threaded worker processes (started and stopped by each ``map``). Task files are written by the
    workers, so a remote cluster needs the output folder on a shared file system."""

    def __init__(self, address: str | None = None, workers: int = 2):
        self.address, self.workers = address, workers

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        from contextlib import ExitStack

        from dask.distributed import Client, LocalCluster

        with ExitStack() as stack:
            target = self.address or stack.enter_context(LocalCluster(
                n_workers=self.workers, threads_per_worker=1, processes=True, dashboard_address=None))
            client = stack.enter_context(Client(target))
            return gather(lambda label, f, *args: client.submit(f, *args, key=f"{step}-{label}", pure=False),
                          fn, calls)


def run_paper(schema_path: str | Path, out_dir: str | Path, *, only: Sequence[str] | None = None,
              sweep: Sequence[float] = (1.0, 3.0, 6.0, 12.0), seed: int = 0, seeds: int = 1,
              multiplier: float = 3.0, options: RunOptions | None = None, workers: int = 1,
              runner: Any = None, log: Callable[[str], Any] = print) -> dict[str, Any]:
    """Run (or resume) the paper on ``schema_path``: the benchmarks ``only`` (None = all 17) and the m-sweep
    ``sweep``; write ``results.csv`` (mean over seeds, ``*_std``), ``runs.csv``, ``results.md``,
    ``multiplier_sweep.md`` and the figures into ``out_dir``. Returns {"results", "sweep", "runs"}."""
    from pipeline.build import InProcessRunner
    from pipeline.paper import load_district, resolve_roles

    options = options or RunOptions()
    schema_path = str(Path(schema_path).resolve())
    roles = resolve_roles(load_district(schema_path, options.settings), options.roles)
    options = dataclasses.replace(options, roles=roles)
    tasks = plan_tasks(only, sweep, seed=seed, seeds=seeds, multiplier=multiplier)
    out = Path(out_dir)
    (out / "tasks").mkdir(parents=True, exist_ok=True)
    expected = fingerprint(schema_path, options)
    done, todo = {}, {}
    for task in tasks:
        path = out / "tasks" / f"{task.key}.json"
        found = read_finished(path, expected)
        if found is None:
            todo[task.key] = (schema_path, task, options, str(path), expected)
        else:
            done[task.key] = found
    log(f"{len(tasks)} tasks: {len(done)} finished before, {len(todo)} to run on {max(workers, 1)} worker(s)")
    runner = runner or (ProcessRunner(workers) if workers > 1 and len(todo) > 1 else InProcessRunner())
    cores = cores_per_task(runner, len(todo))
    todo = {key: (path, task, dataclasses.replace(opts, cores=cores), *rest)
            for key, (path, task, opts, *rest) in todo.items()}
    done |= runner.map("paper", run_task, todo)
    runs = [done[t.key] for t in tasks]
    return write_results(out, runs, tasks, multiplier=multiplier, only=only, sweep=sweep, options=options,
                         seeds=seeds)


def cores_per_task(runner: Any, tasks: int) -> int:
    """CPU cores each of ``tasks`` tasks may use under ``runner``: all of this process's cores in process, the
    cores shared out over the tasks running at once on a local pool or local Dask cluster, 1 on a remote
    scheduler (its machines are not this one)."""
    from pipeline.build import InProcessRunner

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    if isinstance(runner, InProcessRunner):
        return cpus
    if isinstance(runner, ProcessRunner) or (isinstance(runner, DaskRunner) and runner.address is None):
        return max(1, cpus // max(1, min(runner.workers, tasks)))
    return 1


def summarise(runs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Mean of :data:`METRICS` over ``runs`` (the seeds of one row), their sample std as ``<name>_std``,
    the number of seeds, and the first run's labels and trace."""
    first = runs[0]
    row = {k: v for k, v in first.items() if k not in METRICS}
    row["seeds"] = len(runs)
    for name in METRICS:
        values = np.array([r[name] for r in runs], dtype=float)
        row[name] = float(values.mean())
        row[f"{name}_sd"] = float(values.std(ddof=1)) if len(values) > 1 else 0.0
    return row


def write_results(out: Path, runs: Sequence[Mapping[str, Any]], tasks: Sequence[Task], *, multiplier: float,
                  only: Sequence[str] | None, sweep: Sequence[float], options: RunOptions,
                  seeds: int) -> dict[str, Any]:
    """results.csv / runs.csv / results.md / multiplier_sweep.md and the figures from the finished runs."""
    import pandas as pd

    from pipeline.paper import sweep_table
    from pipeline.paper_figures import write_figures

    groups: dict[tuple[str, float], list] = {}
    for task, run in zip(tasks, runs, strict=True):
        groups.setdefault((task.id, task.multiplier), []).append(run)
    order = [b.id for b in BENCHMARKS if only is None or b.id in only]
    results = [summarise(groups[(i, multiplier)]) for i in order]
    swept = [summarise(groups[(SWEEP_ID, float(m))]) for m in sweep]
    plain = [{k: v for k, v in r.items() if k != "trace"} for r in runs]
    pd.DataFrame(plain).to_csv(out / "runs.csv", index=False)
    if results:
        pd.DataFrame([{k: v for k, v in r.items() if k != "trace"} for r in results]).to_csv(
            out / "results.csv", index=False)
        (out / "results.md").write_text(results_table(results, options, seeds))
    if swept:
        (out / "multiplier_sweep.md").write_text(sweep_table(swept))
    write_figures(out, results, swept)
    return {"results": results, "sweep": swept, "runs": list(runs)}


def _pm(row: Mapping[str, Any], name: str, digits: int) -> str:
    value = f"{row[name]:.{digits}f}"
    return value + (f" ± {row[name + '_sd']:.{digits}f}" if row["seeds"] > 1 else "")


def results_table(results: Sequence[Mapping[str, Any]], options: RunOptions, seeds: int) -> str:
    """results.md: the roles, the options, and one line per benchmark (mean ± std over seeds for SAC rows),
    with B1's cost and emissions as a change against both no-control baselines when they were run."""
    by_id = {r["id"]: r for r in results}
    roles = ", ".join(f"{role} = {name}" for role, name in zip(("B1", "B2"), options.roles or (), strict=False))
    ran = sorted({r.get("precision", "-") for r in results} - {"-"})
    threads = sorted({r.get("sac_threads", 0) for r in results} - {0})
    precision = (f" in {' and '.join(ran)} (--precision {options.precision}) on "
                 f"{' or '.join(map(str, threads))} thread(s)") if ran else ""
    lines = [f"Buildings: {roles}. Rules: {options.rules}. Environment: "
             f"{'CityLearn 2.1 preset' if options.compat else 'corrected'}. SAC: {options.sac}{precision}, "
             f"{options.sac_episodes} episodes, {seeds} seed(s) (SAC rows: mean ± std).", "",
             "| benchmark | buildings | cost $ | emissions kg | discomfort C h | consumption kWh | avg daily peak kW "
             "| cost vs x / x-pv | emissions vs x / x-pv |", "|---|---|---|---|---|---|---|---|---|"]
    base = [by_id.get("x-b1_b2-x-x"), by_id.get("x-b1_b2-x-pv")]
    for r in results:
        changes = [" / ".join(_percent(r[k], b[k]) if b else "-" for b in base) for k in ("cost", "emissions")]
        lines.append(f"| {r['id']} | {r['buildings']} | {_pm(r, 'cost', 3)} | {_pm(r, 'emissions', 2)} | "
                     f"{_pm(r, 'discomfort', 1)} | {_pm(r, 'consumption', 2)} | {_pm(r, 'average_daily_peak', 3)} | "
                     f"{changes[0]} | {changes[1]} |")
    return "\n".join(lines) + "\n"


def _percent(value: float, base: float) -> str:
    return f"{100.0 * (value - base) / base:+.1f} %" if base else "-"
