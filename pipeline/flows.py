"""The Prefect flow ``build_district``: :func:`pipeline.builder.run_build` with per-building work as tasks.

The flow body is the one build driver; :class:`PrefectRunner` submits each per-building call (ingest,
surrogate) as a task of the running flow, on the flow's task runner: a thread pool by default, prefect-dask's
DaskTaskRunner in :func:`build_district_on_dask` (a local Dask cluster, or the ``address`` of an existing
one). Runs locally with no server (Prefect's ephemeral mode).

No Prefect caching or result persistence: trained surrogates are cached by :mod:`pipeline.builder.cache` (plain
files checked by sha256, keyed on what training uses), never pickled.

Prefect's API: :func:`prefect_api` uses a configured server (``PREFECT_API_URL``), else starts Prefect's
API server itself on a free local port (:mod:`pipeline.prefect_server`) and stops it when the build ends, fails,
is interrupted (Ctrl-C, SIGTERM, SIGHUP) or is killed outright, even while the server is still starting (the
server watches this process from its first line, and a small watchdog process stops it from outside), so no
server process outlives a build. A server that cannot start (no free port, its port taken, it exits) and an
API lost mid-build are each one line (:class:`OrchestrationError`). ``districtgen build`` and
:func:`build_district_on_dask` run inside it.
"""

from __future__ import annotations

import importlib
import os
import threading
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

from prefect import flow
from prefect.task_runners import ThreadPoolTaskRunner

from pipeline import progress
from pipeline.builder.staging import exit_on_signals
from pipeline.config import BuildConfig, read_build_config
from pipeline.errors import InputError
from pipeline.prefect_server import PORTS, OrchestrationError, api_loss_in_one_line, start_server
from pipeline.progress import forward_dask_events
from pipeline.runners import PrefectRunner


@flow(name="build_district", task_runner=ThreadPoolTaskRunner(max_workers=2), log_prints=True)
def build_district(config: BuildConfig | str | Path, output_root: str = "artifacts") -> Path:
    """Build the district of ``config`` (a BuildConfig or a TOML path) into ``output_root/<name>``."""
    from pipeline.builder.driver import run_build  # torch, pvlib, ...: loaded while the API server starts

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
                    wait_for_a_worker(client, address)
                    forward_dask_events(client)
                    runner = DaskTaskRunner(address=address)
                    return build_district.with_options(task_runner=runner)(config, output_root)
        finally:
            if cluster is not None:
                cluster.result().close()


#: seconds a build waits for the first worker of a scheduler given by address
WORKER_WAIT_S = 600.0


def wait_for_a_worker(client, address: str, seconds: float = WORKER_WAIT_S) -> None:
    """Wait until the scheduler at ``address`` has a worker; none within ``seconds``: one
    :class:`OrchestrationError` line (a build would otherwise wait for ever)."""
    from distributed import TimeoutError as DaskTimeout  # optional extra: dask

    try:
        client.wait_for_workers(1, timeout=seconds)
    except (DaskTimeout, TimeoutError):
        raise OrchestrationError(f"no Dask worker joined the scheduler at {address} within {seconds:.0f} s: start "
                                 "`dask worker ADDRESS` processes (docs/build.md, multi-node builds)") from None


def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` worker processes, one thread each, no dashboard, quiet logs."""
    import dask  # optional extra: dask
    from distributed import LocalCluster

    with dask.config.set({"logging.distributed": "error"}):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)


# ------------------------------------------------------------------------------- Prefect server lifetime
#: default wall-clock seconds the temporary API server may take to start (Prefect's default: 20 s of sleeps)
STARTUP_TIMEOUT_S = 600.0


#: Prefect client retries of a failed API request (back-off 2, 4, ..., 64 s: about 2 minutes; Prefect: 5)
CLIENT_RETRIES = 6


@contextmanager
def prefect_api(ports: Sequence[int] = PORTS) -> Iterator[str]:
    """Yield the Prefect API URL a build uses: ``PREFECT_API_URL`` if set, else a temporary local server on a
    free port of ``ports`` owned by this call (stopped on exit, on an error, on SIGINT/SIGTERM/SIGHUP; if this
    process is killed with SIGKILL, even while the server starts, the server stops itself and a watchdog
    process makes sure). The temporary server keeps its run records in memory unless a database is configured
    (``PREFECT_SERVER_DATABASE_CONNECTION_URL``). A connection to the API lost mid-build (after Prefect's
    retries) ends in one :class:`OrchestrationError` line saying that a rerun resumes from the cache."""
    from prefect.settings import (  # optional: Prefect (pipeline extra) loads only when a flow runs
        PREFECT_API_URL,
        temporary_settings,
    )

    configured = PREFECT_API_URL.value()
    if configured:
        with temporary_settings(updates=patient_client()), api_loss_in_one_line(configured):
            yield configured
        return
    signals = exit_on_signals()  # SIGTERM / SIGHUP: the finally below stops the server
    signals.__enter__()
    server = None
    settings = {**server_database(), **patient_settings()}
    try:
        with temporary_settings(updates=settings):  # the server inherits them
            progress.stage("prefect api")
            preload(BUILD_MODULES)  # the build's imports on the other core while the server starts
            server = start_server(startup_timeout(), ports)
            progress.end("prefect api")
        with (temporary_settings(updates={**settings, PREFECT_API_URL: server.api_url}),
              api_loss_in_one_line(server.api_url, server)):
            yield server.api_url
    finally:
        if server is not None:
            if server.process.poll() is None:  # send the runs' queued logs while the server is still there
                from prefect.logging.handlers import APILogWorker

                APILogWorker.drain_all(timeout=5)
            server.stop()
        signals.__exit__(None, None, None)


#: what a build imports after the API is up (torch, pandas, pvlib, scikit-learn, EnergyPlus glue: 5-8 s)
BUILD_MODULES = ("pipeline.builder.driver",)


def preload(modules: Sequence[str]) -> threading.Thread:
    """Import ``modules`` in a daemon thread (the server's startup is a separate process, so its 20 s and
    these imports overlap). A failed import is left for the caller's own import to raise where it can say
    so in one line (Python drops a module whose import failed)."""

    def load() -> None:
        for name in modules:
            try:
                importlib.import_module(name)
            except BaseException:  # noqa: BLE001 -- re-raised by the build's own import
                return

    thread = threading.Thread(target=load, name="preload", daemon=True)
    thread.start()
    return thread


def server_database() -> dict:
    """The temporary server's database: in memory, unless the user configured one. Run logs are then not sent
    to the API (where nothing could read them: the server has no UI and forgets them when the build ends),
    which spares a busy machine the traffic and the terminal Prefect's "Error logging to API" lines if the
    API is lost; unless the user set ``PREFECT_LOGGING_TO_API_ENABLED``."""
    from prefect.settings import (  # optional: Prefect (pipeline extra) loads only when a flow runs
        PREFECT_LOGGING_TO_API_ENABLED,
        PREFECT_SERVER_DATABASE_CONNECTION_URL,
    )

    own = any(name in os.environ for name in (
        "PREFECT_SERVER_DATABASE_CONNECTION_URL", "PREFECT_API_DATABASE_CONNECTION_URL"))
    if own:
        return {}
    quiet = {} if PREFECT_LOGGING_TO_API_ENABLED.name in os.environ else {PREFECT_LOGGING_TO_API_ENABLED: False}
    return {PREFECT_SERVER_DATABASE_CONNECTION_URL: "sqlite+aiosqlite:///:memory:", **quiet}




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


def patient_client() -> dict:
    """Prefect client settings for a busy machine, where not set by the user: API requests may take 5 minutes
    (Prefect: 60 s) and a failed one is retried :data:`CLIENT_RETRIES` times, the waits doubling from 2 s."""
    from prefect.settings import (  # optional: Prefect (pipeline extra) loads only when a flow runs
        PREFECT_API_REQUEST_TIMEOUT,
        PREFECT_CLIENT_MAX_RETRIES,
    )

    wanted = {PREFECT_API_REQUEST_TIMEOUT: 300.0, PREFECT_CLIENT_MAX_RETRIES: CLIENT_RETRIES}
    return {setting: value for setting, value in wanted.items() if setting.name not in os.environ}


def patient_settings() -> dict:
    """:func:`patient_client`, and the temporary server's database statements and connections may take
    1 minute (Prefect's defaults: 10 and 5 s), where not set by the user."""
    from prefect.settings import (
        PREFECT_SERVER_DATABASE_CONNECTION_TIMEOUT,
        PREFECT_SERVER_DATABASE_TIMEOUT,
    )  # optional: Prefect (pipeline extra) loads only when a flow runs

    wanted = {PREFECT_SERVER_DATABASE_TIMEOUT: 60.0, PREFECT_SERVER_DATABASE_CONNECTION_TIMEOUT: 60.0}
    return {**patient_client(),
            **{setting: value for setting, value in wanted.items() if setting.name not in os.environ}}


