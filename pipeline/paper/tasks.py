"""The whole paper as independent tasks: one task per (benchmark, multiplier m, seed), run on a task runner,
each result written to ``<out>/tasks/<key>.json`` as soon as it finishes, so a rerun skips finished tasks.

A task file holds the run's options and the schema file's sha256; a file whose options or schema differ
from the current run is not reused. Learning rows run once per seed and are reported as mean and sample
standard deviation over the seeds; rule-based and no-control rows are deterministic and run once.

Tasks run on a :mod:`pipeline.runners` runner: in process (``workers=1``), a process pool (one process per
core) or Dask (a local cluster of worker processes, or an existing cluster's scheduler).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

from citylearn_env.errors import InputError
from citylearn_env.outputs import check_output_name, output_folder, write_output
from pipeline.paper.benchmarks import (
    BENCHMARKS,
    SWEEP_ID,
    RunOptions,
    Task,
    benchmark_notes,
    load_district,
    resolve_roles,
    run_benchmark,
)
from pipeline.paper.figures import FIGURES
from pipeline.paper.reference import CONTROLLERS, REFERENCES, configurations, run_reference
from pipeline.paper.results import provenance, write_results
from pipeline.runners import DaskRunner, InProcessRunner, ProcessRunner


def plan_tasks(only: Sequence[str] | None, sweep: Sequence[float], *, seed: int = 0, seeds: int = 1,
               multiplier: float = 3.0, controllers: Sequence[str] = CONTROLLERS) -> list[Task]:
    """The tasks of a run, longest first: SAC rows ``seeds`` times, the m-sweep's multipliers, MPC, the rest
    once.

    ``only``: benchmark ids (None = all 17, [] = none); ``sweep``: multipliers of rlc-b1-d_o-hp (SAC runs);
    ``controllers``: which of :data:`CONTROLLERS` run: "rbc" and "sac" keep the benchmarks of that control (the
    no-control rows always run), "oracle" and "mpc" add one task per storage configuration of the chosen
    benchmarks (:func:`pipeline.paper.reference.configurations`) at the first seed.
    """

    known = {b.id: b for b in BENCHMARKS}
    unknown = sorted(set(only or ()) - set(known))
    if unknown:
        raise InputError(f"unknown benchmark id(s) {unknown}; known: {', '.join(known)}", column="--only")
    strange = sorted(set(controllers) - set(CONTROLLERS))
    if strange:
        raise InputError(f"unknown controller(s) {strange}; known: {', '.join(CONTROLLERS)}", column="--controllers")
    if seeds < 1:
        raise InputError(f"--seeds must be >= 1, got {seeds}", column="--seeds")
    chosen = [b for b in BENCHMARKS if only is None or b.id in only]
    tasks: dict[str, Task] = {}
    for b in chosen:
        if b.control != "none" and b.control not in controllers:
            continue
        for s in range(seed, seed + (seeds if b.control == "sac" else 1)):
            task = Task(b.id, multiplier, s)
            tasks[task.key] = task
    for m in sweep if "sac" in controllers else ():
        for s in range(seed, seed + seeds):
            task = Task(SWEEP_ID, float(m), s)
            tasks[task.key] = task
    tasks |= {t.key: t for t in reference_tasks(chosen, controllers, seed=seed, multiplier=multiplier)}
    return sorted(tasks.values(), key=lambda t: task_order(known[t.id].control, t.controller))


def reference_tasks(chosen: Sequence[Any], controllers: Sequence[str], *, seed: int, multiplier: float
                    ) -> list[Task]:
    """One task per reference controller in ``controllers`` and storage configuration of the benchmarks
    ``chosen``, at ``seed``."""
    return [Task(b.id, multiplier, seed, c) for c in REFERENCES if c in controllers for b in configurations(chosen)]


def task_order(control: str, controller: str) -> int:
    """Sort rank of a task (long ones first): SAC 0, MPC 1, the rest 2."""
    return 0 if control == "sac" and not controller else 1 if controller == "mpc" else 2


def fingerprint(schema_path: str | Path, options: RunOptions) -> dict[str, Any]:
    """What a task result depends on besides the task: the schema file's sha256 and the run options."""
    digest = hashlib.sha256(Path(schema_path).read_bytes()).hexdigest()
    return {"schema_sha256": digest, **{k: list(v) if isinstance(v, tuple) else v
                                        for k, v in dataclasses.asdict(options).items() if k != "cores"}}


def read_finished(path: Path, expected: Mapping[str, Any]) -> dict[str, Any] | None:
    """The result in task file ``path`` when it exists, was made with ``expected`` and did not skip its
    configuration (a skipped reference is retried); else None."""
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if stored.get("fingerprint") != dict(expected) or "skipped" in stored["result"]:
        return None
    return stored["result"]


@lru_cache(maxsize=2)
def _district(schema_path: str, settings: str | None):

    return load_district(schema_path, settings)


def run_task(schema_path: str, task: Task, options: RunOptions, out_file: str,
             expected: Mapping[str, Any]) -> dict[str, Any]:
    """Run ``task`` and write its result file atomically (a worker's unit of work; top level, picklable)."""

    bench = next(b for b in BENCHMARKS if b.id == task.id)
    print(f"running {task.key} ...", flush=True)
    district = _district(schema_path, options.settings)
    if task.controller:
        result = run_reference(district, bench, task.controller, seed=task.seed, multiplier=task.multiplier,
                               options=options)
    else:
        result = run_benchmark(district, bench, seed=task.seed, multiplier=task.multiplier, options=options)
    result = {**result, **provenance()}
    target = Path(out_file)
    write_output(target.parent, target.name, json.dumps({"fingerprint": dict(expected), "result": result}),
                 column="--output")
    done = f"skipped ({result['skipped']})" if "skipped" in result else f"in {result['seconds']:.1f} s"
    print(f"finished {task.key} {done}", flush=True)
    return result


def run_paper(schema_path: str | Path, out_dir: str | Path, *, only: Sequence[str] | None = None,
              sweep: Sequence[float] = (1.0, 3.0, 6.0, 12.0), seed: int = 0, seeds: int = 1,
              multiplier: float = 3.0, options: RunOptions | None = None, workers: int = 1,
              runner: Any = None, log: Callable[[str], Any] = print,
              controllers: Sequence[str] = CONTROLLERS) -> dict[str, Any]:
    """Run (or resume) the paper on ``schema_path``: the benchmarks ``only`` (None = all 17), the m-sweep
    ``sweep`` and the reference ``controllers`` (:func:`plan_tasks`); write ``results.csv`` (mean over seeds,
    ``*_std``), ``runs.csv``, ``results.md``, ``regret.md`` / ``regret.csv``, ``multiplier_sweep.md`` and the
    figures into ``out_dir``. Returns :func:`pipeline.paper.results.write_results`' dict."""

    options = options or RunOptions()
    out = prepare_output(out_dir)
    schema_path = str(Path(schema_path).resolve())
    district = load_district(schema_path, options.settings)
    roles = resolve_roles(district, options.roles)
    options = dataclasses.replace(options, roles=roles)
    tasks = plan_tasks(only, sweep, seed=seed, seeds=seeds, multiplier=multiplier, controllers=controllers)
    for bench in (b for b in BENCHMARKS if b.id in {t.id for t in tasks if not t.controller}):
        for note in benchmark_notes(district, bench, roles):
            log(f"note: {bench.id}: {note}")
    tasks_folder = output_folder(out / "tasks", column="--output")
    for task in tasks:
        check_output_name(tasks_folder, f"{task.key}.json", column="--output")
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


def prepare_output(out_dir: str | Path) -> Path:
    """The run folder ``out_dir`` (:func:`citylearn_env.outputs.output_folder`: created if missing, never a link,
    never inside a built district) with no symbolic link at any name the run writes: refused in one line before
    anything runs."""
    out = output_folder(out_dir, column="--output")
    for name in OUTPUT_NAMES:
        check_output_name(out, name, column="--output")
    return out


#: the files a run writes into its folder (besides ``tasks/<key>.json``)
OUTPUT_NAMES = ("runs.csv", "results.csv", "results.md", "regret.csv", "regret.md", "multiplier_sweep.md",
                *FIGURES)


def cores_per_task(runner: Any, tasks: int) -> int:
    """CPU cores each of ``tasks`` tasks may use under ``runner``: all of this process's cores in process, the
    cores shared out over the tasks running at once on a local pool or local Dask cluster, 1 on a remote
    scheduler (its machines are not this one)."""

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    if isinstance(runner, InProcessRunner):
        return cpus
    if isinstance(runner, ProcessRunner) or (isinstance(runner, DaskRunner) and runner.address is None):
        return max(1, cpus // max(1, min(runner.workers, tasks)))
    return 1
