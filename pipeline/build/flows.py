"""The Prefect flow ``build_district``: :func:`pipeline.build.run_build` with per-building work as tasks.

The flow body is the one build driver; :class:`PrefectRunner` submits each per-building call (ingest,
surrogate) as a task of the running flow, on the flow's task runner: a thread pool by default, prefect-dask's
DaskTaskRunner in :func:`build_district_on_dask` (a local Dask cluster, or the ``address`` of an existing
one). Runs locally with no server (Prefect's ephemeral mode).

No Prefect caching or result persistence: trained surrogates are cached by :mod:`pipeline.build.cache` (plain
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
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
from prefect import flow
from prefect.task_runners import ThreadPoolTaskRunner

from pipeline import progress
from pipeline.build.driver import run_build
from pipeline.config import BuildConfig, read_build_config
from pipeline.errors import InputError
from pipeline.progress import forward_dask_events
from pipeline.runners import PrefectRunner


@flow(name="build_district", task_runner=ThreadPoolTaskRunner(max_workers=2), log_prints=True)
def build_district(config: BuildConfig | str | Path, output_root: str = "artifacts") -> Path:
    """Build the district of ``config`` (a BuildConfig or a TOML path) into ``output_root/<name>``."""
    if not isinstance(config, BuildConfig):
        config = read_build_config(config)
    return run_build(config, output_root, PrefectRunner())


def build_district_on_dask(config: BuildConfig | str | Path, output_root: str = "artifacts", *,
                           address: str | None = None, workers: int | None = None) -> Path:
    """The build flow on Dask: an existing scheduler at ``address``, else a local cluster of ``workers``
    (default: the CPU count) single-threaded worker processes, started while Prefect's API starts.

    Every worker runs one task at a time with one torch thread (training sets it; Dask sets OMP/MKL threads
    to 1), so results do not depend on the worker count. Building reports (step, epochs) reach this process's
    progress display as Dask events (:func:`pipeline.progress.forward_dask_events`)."""

    from distributed import Client  # optional extra: dask
    from prefect_dask import DaskTaskRunner


    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="dask_cluster") as pool:
        cluster = None if address else pool.submit(local_cluster, workers or os.cpu_count() or 1)
        try:
            with prefect_api():
                if cluster is not None:
                    address = cluster.result().scheduler_address
                with Client(address) as client:
                    forward_dask_events(client)
                    runner = DaskTaskRunner(address=address)
                    return build_district.with_options(task_runner=runner)(config, output_root)
        finally:
            if cluster is not None:
                cluster.result().close()


def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` worker processes, one thread each, no dashboard, quiet logs."""
    import dask  # optional extra: dask
    from distributed import LocalCluster

    with dask.config.set({"logging.distributed": "error"}):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)


# ------------------------------------------------------------------------------- Prefect server lifetime
#: default wall-clock seconds the temporary API server may take to start (Prefect's default: 20 s of sleeps)
STARTUP_TIMEOUT_S = 600.0


class OrchestrationError(InputError):
    """Prefect or Dask could not run the build (not the inputs' fault); the CLI prints it as one line, exit 2."""


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
    from prefect.settings import (  # optional: Prefect (pipeline extra) loads only when a flow runs
        PREFECT_API_URL,
        temporary_settings,
    )

    configured = PREFECT_API_URL.value()
    if configured:
        yield configured
        return
    from prefect.server.api.server import (
        SubprocessASGIServer,  # optional: Prefect (pipeline extra) loads only when a flow runs
    )


    server = SubprocessASGIServer()
    previous = _exit_on_signals()
    watchdog = None
    try:
        from prefect.settings import (
            PREFECT_SERVER_DATABASE_CONNECTION_URL,  # optional: Prefect (pipeline extra) loads only when a flow runs
        )

        own_database = any(name in os.environ for name in (
            "PREFECT_SERVER_DATABASE_CONNECTION_URL", "PREFECT_API_DATABASE_CONNECTION_URL"))
        memory = {} if own_database else {PREFECT_SERVER_DATABASE_CONNECTION_URL: "sqlite+aiosqlite:///:memory:"}
        with temporary_settings(updates={**memory, **patient_settings()}):  # records in memory, patient
            progress.stage("prefect api")
            start_server(server, startup_timeout())
            progress.end("prefect api")
        watchdog = subprocess.Popen([sys.executable, "-c", _WATCHDOG, str(os.getpid()), str(server.server_process.pid)],
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with temporary_settings(updates={PREFECT_API_URL: server.api_url, **patient_settings()}):
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


def startup_timeout() -> float:
    """Wall-clock seconds the temporary server may take to answer: ``$DISTRICTGEN_PREFECT_STARTUP_TIMEOUT``
    (seconds), else :data:`STARTUP_TIMEOUT_S`."""
    text = os.environ.get("DISTRICTGEN_PREFECT_STARTUP_TIMEOUT")
    if not text:
        return STARTUP_TIMEOUT_S
    try:
        return float(text)
    except ValueError:
        raise InputError("not a number of seconds", file="environment",
                         column="DISTRICTGEN_PREFECT_STARTUP_TIMEOUT") from None


def patient_settings() -> dict:
    """Prefect settings for a busy machine, where not set by the user: API requests may take 5 minutes, the
    server's database statements and connections 1 minute (Prefect's defaults: 60, 10 and 5 s)."""
    from prefect.settings import (
        PREFECT_API_REQUEST_TIMEOUT,
        PREFECT_SERVER_DATABASE_CONNECTION_TIMEOUT,
        PREFECT_SERVER_DATABASE_TIMEOUT,
    )  # optional: Prefect (pipeline extra) loads only when a flow runs

    wanted = {PREFECT_API_REQUEST_TIMEOUT: 300.0, PREFECT_SERVER_DATABASE_TIMEOUT: 60.0,
              PREFECT_SERVER_DATABASE_CONNECTION_TIMEOUT: 60.0}
    return {setting: value for setting, value in wanted.items() if setting.name not in os.environ}


def start_server(server: Any, timeout_s: float) -> None:
    """Start Prefect's temporary server and wait until ``/health`` answers, by the wall clock, up to
    ``timeout_s``; raise :class:`OrchestrationError` (one line) if it does not.

    Prefect's own wait (``SubprocessASGIServer.start``) counts only its sleeps and gives up when a health
    request is slow to answer (a loaded machine); its server process is still starting then, so this keeps
    asking it (each request may take 30 s) until the deadline, and stops it only on giving up."""

    deadline = time.monotonic() + timeout_s
    try:
        server.start(timeout=max(1, int(timeout_s)))
        return
    except Exception:  # noqa: BLE001 - Prefect's wait gave up; the process may still come up
        pass
    with httpx.Client(timeout=30.0) as client:
        while time.monotonic() < deadline:
            process = server.server_process
            if process is None or process.poll() is not None:
                break
            try:
                if client.get(f"{server.api_url}/health").status_code == 200:
                    server.running = True
                    return
            except httpx.HTTPError:
                pass
            time.sleep(0.5)
    server.stop()
    raise OrchestrationError(f"Prefect's temporary API server did not answer within {timeout_s:.0f} s (a very "
                             "busy machine?): retry, raise DISTRICTGEN_PREFECT_STARTUP_TIMEOUT, run a Prefect "
                             "server and set PREFECT_API_URL, or build with --no-prefect")


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
