"""The Prefect flow ``build_district``: the steps of :mod:`pipeline.build`, per-building work as mapped tasks.

Surrogate training results are cached (Prefect result persistence, ``PREFECT_RESULTS_LOCAL_STORAGE_PATH``):
rebuilding with unchanged inputs reuses the trained models.

Runs locally with no server (Prefect's ephemeral mode) on a thread pool; :func:`build_district_on_dask` runs
the same flow with prefect-dask's DaskTaskRunner (a local Dask cluster, or the ``address`` of an existing one).
"""

from __future__ import annotations

import time
from pathlib import Path

from prefect import flow, task
from prefect.cache_policies import INPUTS, NO_CACHE, TASK_SOURCE
from prefect.task_runners import ThreadPoolTaskRunner

from pipeline import build
from pipeline.config import BuildConfig, read_build_config

ingest_signals = task(build.ingest_signals, name="ingest-signals", cache_policy=NO_CACHE)
ingest_building = task(build.ingest_building, name="ingest-building", cache_policy=NO_CACHE,
                       task_run_name="ingest-{name}")
size_buildings = task(build.size_buildings, name="sizing", cache_policy=NO_CACHE)
# training is the expensive step: cached on its inputs (config, building, sha256 of the training data) and
# on the code, with persisted results, so a rerun after a crash or with unchanged inputs does not retrain
train_files = task(build.train_building_files, name="train-surrogate", cache_policy=INPUTS + TASK_SOURCE,
                   persist_result=True, task_run_name="surrogate-{name}")
finish = task(build.finish, name="emit-and-validate", cache_policy=NO_CACHE)


@flow(name="build_district", task_runner=ThreadPoolTaskRunner(max_workers=2), log_prints=True)
def build_district(config: BuildConfig | str | Path, output_root: str = "artifacts") -> Path:
    """Build the district of ``config`` (a BuildConfig or a TOML path) into ``output_root/<name>``."""
    if not isinstance(config, BuildConfig):
        config = read_build_config(config)
    names = build.building_names(config)
    ids = config.inputs.buildings
    with build.staging(config, output_root) as out:
        timings = {}
        started = time.perf_counter()
        signals = ingest_signals.submit(config, out)
        files = [ingest_building.submit(config, i, n, out) for i, n in zip(ids, names, strict=True)]
        signals.result()
        for f in files:
            f.result()
        timings["ingest"] = time.perf_counter() - started
        sizes = size_buildings.submit(config, out, names)
        started = time.perf_counter()
        dynamics = None
        if config.surrogate.source != "none":
            trained = [train_files.submit(config, i, n, build.surrogate_input_digest(config, i))
                       for i, n in zip(ids, names, strict=True)]
            dynamics = {n: build.write_surrogate_files(out, t.result()) for n, t in zip(names, trained, strict=True)}
        timings["surrogates"] = time.perf_counter() - started
        finish.submit(config, out, names, sizes.result(), dynamics, timings).result()
    return Path(output_root) / config.name


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
