"""The district build: pure steps and ONE driver, :func:`run_build`.

Steps (inputs -> in-memory tables -> outputs)::

    resolve_selection [selection] -> the bldg_ids (pipeline.select: filters + one building per k-means cluster)
    site_signals      weather file, tariff, fuel mix -> weather / pricing / carbon tables + PV yield per kW
                      (the PV yield is computed once per site: every building shares the weather file)
    ingest_building   EULP building + the site's PV yield -> the building table (per building), or
    simulate_building a real stock row -> ONE EnergyPlus pass on the district's weather over the months it
                      needs: hourly loads + the ILV table (per building, cached); house_table -> the building
                      table
    size_buildings    building tables + outdoor temperature -> device attributes (cooling and heating)
    surrogate_files   ILV table (or EnergyPlus inputs) -> trained LSTM files and the training table, through the
                      surrogate cache; a house's judge through the judgement cache (per building; see
                      pipeline.builder.cache)
    schema_dict       -> schema.json;  validate_district -> write_report -> report/;  write_manifest -> manifest.json

Tables are ``pandas.DataFrame`` of internal (v2.2) column names, one row per hour from ``period.start``
00:00 (local standard time; row 0 is CityLearn hour 1); they are written with
:func:`citylearn_env.dataset.write_table` and never read back. :func:`run_build` sequences the steps and
submits the per-building work through a :class:`pipeline.runners.Runner`: :class:`~pipeline.runners.InProcessRunner` (plain calls),
or :class:`~pipeline.runners.PrefectRunner` (:mod:`pipeline.flows`) (tasks on a thread pool, or on Dask). A build is written into
a temporary sibling folder and renamed into place only when complete and validated.
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from pipeline import progress
from pipeline.builder.houses import (
    HouseSimulation,
    building_notes,
    check_repeats,
    eulp_heating_system,
    heating_devices,
    house_config,
    house_table,
    house_work,
    schedule_repeats,
)
from pipeline.builder.manifest import (
    make_world_readable,
    split_surrogate_timings,
    write_manifest,
    write_timings,
)
from pipeline.builder.report import SelectionSummary, district_report, write_report
from pipeline.builder.staging import staging
from pipeline.builder.steps import (
    Signals,
    building_names,
    ingest_building,
    resolve_selection,
    schema_dict,
    site_signals,
    size_buildings,
    write_tables,
)
from pipeline.builder.surrogates import (
    SurrogateFiles,
    annotate_schema,
    cache_hits,
    check_cache_root,
    check_surrogate_errors,
    fmu_ilv,
    resolve_precision,
    surrogate_errors,
    surrogate_files,
    write_surrogate_files,
)
from pipeline.builder.validate import validate_district
from pipeline.config import BuildConfig
from pipeline.runners import InProcessRunner, Runner


def run_build(config: BuildConfig, output_root: str | Path = "artifacts", runner: Runner | None = None) -> Path:
    """THE build: every step in order, per-building work through ``runner`` (default: in-process).

    Writes into a hidden sibling folder of ``output_root/<name>`` and renames it into place only when the
    schema validated; returns ``output_root/<name>``. Hashes, versions and the surrogate (and judgement) cache
    keys go into ``manifest.json`` (reproducible); timings [s], training seconds and cache hits into
    ``timings.json`` (:mod:`pipeline.builder.manifest`); every file 0644, every folder 0755; the selection, each
    house's heating system and device and its set-point repair go into ``selection.csv`` / ``buildings.json``
    and the report.
    """

    runner = runner or InProcessRunner()
    check_cache_root(config)  # an unusable cache: one line now, not after the houses' simulation
    timings: dict[str, float] = {}
    started = time.perf_counter()
    config, selection = resolve_selection(config)
    check_repeats(config)
    timings["selection"] = time.perf_counter() - started
    config, precision = resolve_precision(config)  # once, here: every worker trains in the same mode
    names = building_names(config)
    ids = dict(zip(names, config.inputs.buildings, strict=True))
    # a repeated stock row: its own occupant-schedule seed (simulation, training data and judge)
    repeats = schedule_repeats(config.inputs.buildings)
    configs = {n: house_config(config, r) for n, r in zip(names, repeats, strict=True)}
    with staging(config, output_root) as out:
        started = time.perf_counter()
        signals, houses, early = signals_and_houses(configs, ids, runner, timings)
        outdoor = signals.outdoor
        if config.inputs.characteristics is not None:
            frames = {n: house_table(config, houses[n], signals.solar) for n in names}
            systems = {n: houses[n].summary["heating_system"] for n in names}
        else:
            progress.stage("ingest", len(names))
            frames = runner.map("ingest", ingest_building,
                                {n: (config, i, signals.solar, outdoor) for n, i in ids.items()})
            systems = {n: eulp_heating_system(config, i) for n, i in ids.items()}
            progress.end("ingest")
        write_tables(out, config.layout, {
            "weather.csv": ("weather", signals.weather), "pricing.csv": ("pricing", signals.pricing),
            "carbon_intensity.csv": ("carbon", signals.carbon),
            **{f"{n}.csv": ("building", frames[n]) for n in names}})
        timings["ingest"] = time.perf_counter() - started
        heating = heating_devices(config, frames, systems)
        sizes = size_buildings(config, frames, signals.weather, heating)
        started = time.perf_counter()
        dynamics, cache_use, trained = None, {}, {}
        if config.surrogate.source != "none":
            tables = {n: None for n in names}
            if config.surrogate.source == "energyplus" and houses:
                tables = {n: houses[n].ilv for n in names}
            elif config.surrogate.source == "fmu":
                tables = {n: fmu_ilv(config, frames[n], signals.weather) for n in names}
            todo = {n: (configs[n], i, n, tables[n], outdoor) for n, i in ids.items() if n not in early}
            if todo:
                progress.stage("surrogate", len(todo))
            trained = early | runner.map("surrogate", surrogate_files, todo)
            trained = {n: trained[n] for n in names}
            if todo:
                progress.end("surrogate")
            split = {n: split_surrogate_timings(trained[n].files) for n in names}  # seconds -> timings.json
            dynamics = {n: write_surrogate_files(out, split[n][0]) for n in names}
            cache_use = {n: {**cache_hits(trained[n]), **split[n][1]} for n in names}
        timings["surrogates"] = time.perf_counter() - started
        judged = surrogate_errors({n: trained[n].files for n in trained})  # the judge's record per house
        check_surrogate_errors(judged, config.surrogate.strict)  # a warning per house, or refused (--strict)
        schema = annotate_schema(schema_dict(config, names, sizes, dynamics), judged)
        schema_path = out / "schema.json"
        schema_path.write_text(json.dumps(schema, indent=2))
        buildings = building_notes(ids, systems, heating, {n: h.summary for n, h in houses.items()}, frames,
                                   sizes)
        (out / "buildings.json").write_text(json.dumps(buildings, indent=2))
        if selection is not None:
            chosen = selection.chosen.assign(building=names)
            if "repeat" in chosen.columns and not (chosen["repeat"] > 0).any():  # no repeats: the former table
                chosen = chosen.drop(columns="repeat")
            chosen.to_csv(out / "selection.csv", index=False)
        started = time.perf_counter()
        progress.stage("validate")
        validation = validate_district(schema_path)
        progress.end("validate")
        chosen = SelectionSummary.of(selection) if selection is not None else None
        write_report(out / "report", district_report(out, config.name, schema, validation, chosen))
        timings["validate"] = time.perf_counter() - started
        write_manifest(out, config, {n: trained[n].key for n in cache_use},
                       {n: trained[n].judge_key for n in cache_use if trained[n].judge_key is not None},
                       selection=chosen.to_json() if chosen is not None else None)
        write_timings(out, config, timings, cache_use, precision)
        make_world_readable(out)
    return Path(output_root) / config.name


def signals_and_houses(configs: Mapping[str, BuildConfig], ids: Mapping[str, int], runner: Runner,
                       timings: dict[str, float],
                       ) -> tuple[Signals, dict[str, HouseSimulation], dict[str, SurrogateFiles]]:
    """The site's signals (read in a thread) while the runner does the per-house work (:func:`house_work`:
    simulation and, for ``energyplus`` surrogates, training) of buildings from real characteristics;
    ``configs``: each building's configuration (:func:`pipeline.builder.houses.house_config`).

    Returns the signals, the simulations and the surrogates already trained, by building name; records the
    wall seconds of both in ``timings`` (``site_signals``, ``houses``)."""

    started = time.perf_counter()
    houses: dict[str, HouseSimulation] = {}
    early: dict[str, SurrogateFiles] = {}

    def done(_) -> None:
        timings["site_signals"] = time.perf_counter() - started
        progress.end("site signals")

    progress.stage("site signals")
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="site_signals") as pool:
        config = next(iter(configs.values()))  # the first copy of a row: the district's own configuration
        pending = pool.submit(site_signals, config)  # read while the houses simulate: serial time hidden
        pending.add_done_callback(done)
        if config.inputs.characteristics is not None:
            progress.stage("house", len(ids))
            work = runner.map("house", house_work, {n: (configs[n], i, n) for n, i in ids.items()})
            houses = {n: work[n].simulation for n in ids}
            early = {n: work[n].surrogate for n in ids if work[n].surrogate is not None}
            timings["houses"] = time.perf_counter() - started
            progress.end("house")
        return pending.result(), houses, early


def build_district_local(config: BuildConfig, output_root: str | Path = "artifacts") -> Path:
    """:func:`run_build` with plain in-process calls (no Prefect)."""
    return run_build(config, output_root, InProcessRunner())
