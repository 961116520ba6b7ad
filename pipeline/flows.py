"""The Prefect flow ``build_district``: :func:`pipeline.build.run_build` with per-building work as tasks.

The flow body is the one build driver; :class:`PrefectRunner` submits each per-building call (ingest,
surrogate) as a task of the running flow, on the flow's task runner: a thread pool by default, prefect-dask's
DaskTaskRunner in :func:`build_district_on_dask` (a local Dask cluster, or the ``address`` of an existing
one). Runs locally with no server (Prefect's ephemeral mode).

No Prefect caching or result persistence: trained surrogates are cached by :mod:`pipeline.cache` (plain
files checked by sha256, keyed on what training uses), never pickled.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
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
    return build_district.with_options(task_runner=runner)(config, output_root)
