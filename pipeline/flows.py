"""The Prefect flow ``build_district``: :func:`pipeline.build.run_build` with per-building work as tasks.

The flow body is the one build driver; :class:`PrefectRunner` submits each per-building call (ingest,
surrogate) as a task of the running flow, on the flow's task runner: a thread pool by default, prefect-dask's
DaskTaskRunner in :func:`build_district_on_dask` (a local Dask cluster, or the ``address`` of an existing
one). Runs locally with no server (Prefect's ephemeral mode).

No Prefect caching or result persistence: trained surrogates are cached by :mod:`pipeline.cache` (plain
files checked by sha256, keyed on what training uses), never pickled.

Prefect's API: :func:`prefect_api` uses a configured server (``PREFECT_API_URL``), else starts Prefect's
temporary local server itself and stops it when the build ends, fails, is interrupted (Ctrl-C, SIGTERM,
SIGHUP) or is killed outright (a small watchdog process stops the server when this process is gone), so no
server process outlives a build. ``districtgen build`` and :func:`build_district_on_dask` run inside it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from prefect import flow, task
from prefect.cache_policies import NO_CACHE
from prefect.task_runners import ThreadPoolTaskRunner

from pipeline import build
from pipeline.config import BuildConfig, read_build_config


class PrefectRunner:
    """Each call a Prefect task (named ``<step>-<label>``) of the running flow; waits for all, in order."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        work = task(fn, name=step, cache_policy=NO_CACHE, persist_result=False)
        futures = {label: work.with_options(task_run_name=f"{step}-{label}").submit(*args)
                   for label, args in calls.items()}
        return {label: future.result() for label, future in futures.items()}


@flow(name="build_district", task_runner=ThreadPoolTaskRunner(max_workers=2), log_prints=True)
def build_district(config: BuildConfig | str | Path, output_root: str = "artifacts") -> Path:
    """Build the district of ``config`` (a BuildConfig or a TOML path) into ``output_root/<name>``."""
    if not isinstance(config, BuildConfig):
        config = read_build_config(config)
    return build.run_build(config, output_root, PrefectRunner())


def build_district_on_dask(config: BuildConfig | str | Path, output_root: str = "artifacts", *,
                           address: str | None = None, workers: int = 2) -> Path:
    """The build flow on Dask: an existing scheduler at ``address``, else a local cluster of ``workers``
    single-threaded processes (worth it for few, long per-building tasks such as EnergyPlus or training)."""
    from prefect_dask import DaskTaskRunner

    if address:
        runner = DaskTaskRunner(address=address)
    else:
        runner = DaskTaskRunner(cluster_kwargs={"n_workers": workers, "threads_per_worker": 1, "processes": True,
                                                "dashboard_address": None})
    with prefect_api():
        return build_district.with_options(task_runner=runner)(config, output_root)


# ------------------------------------------------------------------------------- Prefect server lifetime
#: run by the watchdog: poll the parent (argv[1]) every 0.5 s; when it is gone, stop the server (argv[2])
_WATCHDOG = """
import os, signal, sys, time
parent, server = int(sys.argv[1]), int(sys.argv[2])
while os.getppid() == parent:
    time.sleep(0.5)
try:
    os.kill(server, signal.SIGTERM)
except ProcessLookupError:
    pass
"""


@contextmanager
def prefect_api() -> Iterator[str]:
    """Yield the Prefect API URL a build uses: ``PREFECT_API_URL`` if set, else a temporary local server owned
    by this call (stopped on exit, on an error, on SIGINT/SIGTERM/SIGHUP, and by a watchdog process if this
    process is killed with SIGKILL). The temporary server keeps its run records in memory unless a database
    is configured (``PREFECT_SERVER_DATABASE_CONNECTION_URL``)."""
    from prefect.settings import PREFECT_API_URL, temporary_settings

    configured = PREFECT_API_URL.value()
    if configured:
        yield configured
        return
    from prefect.server.api.server import SubprocessASGIServer

    server = SubprocessASGIServer()
    previous = _exit_on_signals()
    watchdog = None
    try:
        from prefect.settings import PREFECT_SERVER_DATABASE_CONNECTION_URL

        own_database = any(name in os.environ for name in (
            "PREFECT_SERVER_DATABASE_CONNECTION_URL", "PREFECT_API_DATABASE_CONNECTION_URL"))
        memory = {} if own_database else {PREFECT_SERVER_DATABASE_CONNECTION_URL: "sqlite+aiosqlite:///:memory:"}
        with temporary_settings(updates=memory):  # run records in memory: nothing written to ~/.prefect
            server.start()
        watchdog = subprocess.Popen([sys.executable, "-c", _WATCHDOG, str(os.getpid()), str(server.server_process.pid)],
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with temporary_settings(updates={PREFECT_API_URL: server.api_url}):
            yield server.api_url
    finally:
        if server.running:  # send the runs' queued logs while the server is still there
            from prefect.logging.handlers import APILogWorker

            APILogWorker.drain_all(timeout=5)
        server.stop()
        if watchdog is not None:
            watchdog.terminate()
            watchdog.wait()
        _restore_signals(previous)


def _exit_on_signals() -> dict:
    """Turn SIGTERM and SIGHUP into SystemExit (so ``finally`` blocks stop the server); main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return {}

    def leave(signum, frame):
        raise SystemExit(128 + signum)

    return {sig: signal.signal(sig, leave) for sig in (signal.SIGTERM, signal.SIGHUP)}


def _restore_signals(previous: dict) -> None:
    for sig, handler in previous.items():
        signal.signal(sig, handler)
