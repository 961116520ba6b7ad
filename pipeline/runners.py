"""Runners: how per-building (build) or per-task (paper) work runs. One protocol, :class:`Runner`, and its
four implementations:

* :class:`InProcessRunner` -- plain calls, one after the other, in this process (tests, quick runs);
* :class:`ProcessRunner` -- a pool of spawned worker processes on this machine;
* :class:`PrefectRunner` -- each call a Prefect task of the running flow, on the flow's task runner (threads,
  or Dask through prefect-dask: :mod:`pipeline.flows`);
* :class:`DaskRunner` -- a Dask cluster (an existing scheduler, or a local cluster per ``map``).

Every ``map`` returns ``{label: fn(*args)}`` in the order of ``calls``; the first failure ends it. With
``keep``, each result is handed to ``keep(label, result)`` in this process as soon as it arrives and only
what ``keep`` returns is held (a build writes a house's files and keeps a small record: the caller's memory
does not grow with the results' size).
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from concurrent.futures import ProcessPoolExecutor
from contextlib import ExitStack
from typing import Any, Protocol

from pipeline import progress

#: what a ``map`` keeps of each result: ``keep(label, result)`` (default: the result itself)
Keep = Callable[[str, Any], Any]


def keep_all(_label: str, result: Any) -> Any:
    return result


class Runner(Protocol):
    """Runs one step for several buildings or tasks, possibly in parallel; results come back by label, in order."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple],
            keep: Keep = keep_all) -> dict[str, Any]:
        """``{label: keep(label, fn(*args)) for label, args in calls.items()}``, ``keep`` called in this process
        as each result arrives (in the order they finish); ``step`` names the work (task names)."""
        ...


class InProcessRunner:
    """Plain calls, one after the other, in this process (tests, quick runs, no Prefect needed)."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple],
            keep: Keep = keep_all) -> dict[str, Any]:
        results = {}
        for label, args in calls.items():
            results[label] = keep(label, fn(*args))
            progress.advance(step, label)
        return results


def gather(submit: Callable[..., Any], fn: Callable[..., Any], calls: Mapping[str, tuple],
           keep: Keep = keep_all) -> dict[str, Any]:
    """Submit every call (``submit(label, fn, *args)`` returns a future), then take each result as it finishes
    (:func:`concurrent.futures.as_completed`): ``{label: keep(label, result)}`` in the order of ``calls``."""
    from concurrent.futures import as_completed

    futures = {label: submit(label, fn, *args) for label, args in calls.items()}
    labels = {id(future): label for label, future in futures.items()}
    results = {}
    for future in as_completed(futures.values()):
        results[labels[id(future)]] = keep(labels[id(future)], future.result())
    return {label: results[label] for label in futures}


class ProcessRunner:
    """A pool of ``workers`` processes (spawned: no state shared). A worker does not outlive this process: it
    leaves as soon as its parent is gone (SIGTERM or SIGKILL to the parent alone), instead of running its task
    to the end beside a rerun that does the same task (:func:`exit_with_parent`)."""

    def __init__(self, workers: int):
        self.workers = workers

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple],
            keep: Keep = keep_all) -> dict[str, Any]:
        with ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                 initializer=exit_with_parent, initargs=(os.getpid(),)) as pool:
            return gather(lambda _, f, *args: pool.submit(f, *args), fn, calls, keep)


#: seconds between a worker's looks at its parent
PARENT_POLL_S = 0.5


def exit_with_parent(parent: int) -> None:
    """Worker initializer: a daemon thread that ends this process (exit status 1) once ``parent`` is no longer
    its parent process (the parent died; the worker was re-parented)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="exit_with_parent", daemon=True).start()


class PrefectRunner:
    """Each call a Prefect task (named ``<step>-<label>``) of the running flow; waits for all, in order."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple],
            keep: Keep = keep_all) -> dict[str, Any]:
        # Prefect is the optional extra `pipeline`: imported only when a flow runs
        from prefect import task
        from prefect.cache_policies import (
            NO_CACHE,  # optional: Prefect (pipeline extra) loads only when a flow runs
        )
        from prefect.futures import as_completed  # (the same extra)

        work = task(fn, name=step, cache_policy=NO_CACHE, persist_result=False)
        futures = {label: work.with_options(task_run_name=f"{step}-{label}").submit(*args)
                   for label, args in calls.items()}
        labels = {id(future): label for label, future in futures.items()}
        results = {}
        for future in as_completed(list(futures.values())):
            # the first failure ends the build (its own error, one line in the CLI)
            results[labels[id(future)]] = keep(labels[id(future)], future.result())
            release_dask(future)
            progress.advance(step, labels[id(future)])
        return {label: results[label] for label in futures}


def release_dask(future: Any) -> None:
    """Let Dask forget the result of a Prefect future run on Dask (prefect-dask keeps the task's final state
    once read): a worker lost afterwards is then not asked to run that task again. Other futures: nothing."""
    wrapped = getattr(future, "wrapped_future", None)
    if callable(getattr(wrapped, "release", None)):
        wrapped.release()


class DaskRunner:
    """Dask: the scheduler at ``address`` (workers started apart, on this or other machines), else a local
    cluster of ``workers`` single-threaded worker processes (started and stopped by each ``map``).

    Each result is fetched into this process as soon as its task ends (:func:`gather_as_done`), so a worker
    lost later costs only the task it was running: the scheduler runs that again on another worker (up to
    distributed's ``allowed-failures``, 3 by default). Tasks are submitted impure and must be idempotent: the
    build's per-building work renames a cache entry into place whole and writes its building's files into
    the district's staging folder atomically or as the same bytes again; a paper task writes its result file
    atomically. A remote worker reads the inputs and the cache at the paths the configuration names, and
    writes under the output folder: shared storage (docs/build.md, the multi-node recipe)."""

    def __init__(self, address: str | None = None, workers: int = 2):
        self.address, self.workers = address, workers

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple],
            keep: Keep = keep_all) -> dict[str, Any]:
        # Dask is the optional extra `dask`
        from dask.distributed import Client, LocalCluster

        with ExitStack() as stack:
            target = self.address or stack.enter_context(LocalCluster(
                n_workers=self.workers, threads_per_worker=1, processes=True, dashboard_address=None))
            client = stack.enter_context(Client(target))
            run = uuid.uuid4().hex[:12]  # keys of its own: a shared scheduler may serve other builds' Building_1
            futures = {label: client.submit(fn, *args, key=f"{step}-{label}-{run}", pure=False)
                       for label, args in calls.items()}
            return gather_as_done(step, futures, keep)


def gather_as_done(step: str, futures: Mapping[str, Any], keep: Keep = keep_all) -> dict[str, Any]:
    """``{label: keep(label, result)}`` of Dask ``futures`` in the order given, each fetched as soon as it is
    done (the first failure ends it, its own error); reports each building to :mod:`pipeline.progress`."""
    from dask.distributed import as_completed  # optional extra: dask

    labels = {future.key: label for label, future in futures.items()}
    results = {}
    for future in as_completed(list(futures.values())):
        results[labels[future.key]] = keep(labels[future.key], future.result())
        future.release()  # the result lives here now, not in a worker's memory
        progress.advance(step, labels[future.key])
    return {label: results[label] for label in futures}
