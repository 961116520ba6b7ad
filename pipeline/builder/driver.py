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
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from pipeline import progress
from pipeline.builder.houses import (
    HouseWork,
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
    site_signals_once,
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
        signals, records = buildings_written(out, config, configs, ids, runner, timings)
        write_tables(out, config.layout, {
            "weather.csv": ("weather", signals.weather), "pricing.csv": ("pricing", signals.pricing),
            "carbon_intensity.csv": ("carbon", signals.carbon)})
        timings["ingest"] = time.perf_counter() - started
        started = time.perf_counter()
        if config.surrogate.source != "none":
            todo = {n: (configs[n], i, n, records[n].ilv_input(config, signals), signals.outdoor)
                    for n, i in ids.items() if records[n].surrogate is None}
            if todo:
                progress.stage("surrogate", len(todo))
            runner.map("surrogate", surrogate_files, todo,
                       keep=lambda n, files: records[n].keep_surrogate(out, n, files))
            if todo:
                progress.end("surrogate")
        timings["surrogates"] = time.perf_counter() - started
        trained = {n: r.surrogate for n, r in records.items() if r.surrogate is not None}
        judged = {n: t.judged for n, t in trained.items() if t.judged is not None}  # the judge's record per house
        check_surrogate_errors(judged, config.surrogate.strict)  # a warning per house, or refused (--strict)
        sizes = {n: records[n].size for n in names}
        dynamics = {n: trained[n].dynamics for n in names} if trained else None
        schema = annotate_schema(schema_dict(config, names, sizes, dynamics), judged)
        schema_path = out / "schema.json"
        schema_path.write_text(json.dumps(schema, indent=2))
        (out / "buildings.json").write_text(json.dumps({n: records[n].note for n in names}, indent=2))
        if selection is not None:
            chosen = selection.chosen.assign(building=names)
            if "repeat" in chosen.columns and not (chosen["repeat"] > 0).any():  # no repeats: the former table
                chosen = chosen.drop(columns="repeat")
            chosen.to_csv(out / "selection.csv", index=False)
        started = time.perf_counter()
        progress.stage("validate")
        validation = validate_district(schema_path, runner)
        progress.end("validate")
        chosen = SelectionSummary.of(selection) if selection is not None else None
        write_report(out / "report", district_report(out, config.name, schema, validation, chosen))
        timings["validate"] = time.perf_counter() - started
        write_manifest(out, config, {n: t.key for n, t in trained.items()},
                       {n: t.judge_key for n, t in trained.items() if t.judge_key is not None},
                       selection=chosen.to_json() if chosen is not None else None)
        write_timings(out, config, timings, {n: t.cache_use for n, t in trained.items()}, precision)
        make_world_readable(out)
    return Path(output_root) / config.name


@dataclass(frozen=True)
class TrainedRecord:
    """What the build keeps of a building's surrogate once its files are in the district: the schema's
    ``dynamics`` block, the judge's record (None: not judged), the cache keys and what ``timings.json``
    records (cache hits, training seconds)."""

    dynamics: dict
    judged: dict | None
    key: str
    judge_key: str | None
    cache_use: dict


@dataclass
class BuildingRecord:
    """What the build keeps of a building once its table is written: the stock's heating system, the
    schema's heating device and sizes, the note of ``buildings.json``, its surrogate record (once trained)
    and, for an FMU surrogate only (which trains on it), its table. A few kB: a district's build holds one
    per building, never all buildings' tables."""

    size: dict
    note: dict
    surrogate: TrainedRecord | None = None
    frame: pd.DataFrame | None = None

    def ilv_input(self, config: BuildConfig, signals: Signals) -> pd.DataFrame | None:
        """The ILV table a later surrogate trains on: the FMU's runs over this building's table, else None
        (a precomputed table or an EnergyPlus pass, found by the trainer)."""
        return fmu_ilv(config, self.frame, signals.weather) if config.surrogate.source == "fmu" else None

    def keep_surrogate(self, out: Path, name: str, trained: SurrogateFiles) -> None:
        """Write the building's surrogate files into ``out`` and keep their record (not their bytes)."""
        files, seconds = split_surrogate_timings(trained.files)  # seconds -> timings.json
        judged = surrogate_errors({name: trained.files}).get(name)
        self.surrogate = TrainedRecord(write_surrogate_files(out, files), judged, trained.key, trained.judge_key,
                                       {**cache_hits(trained), **seconds})


def building_record(out: Path, config: BuildConfig, name: str, bldg_id: int, frame: pd.DataFrame, system: str,
                    summary: Mapping, outdoor: pd.DataFrame) -> BuildingRecord:
    """Write a building's table into ``out`` and return its record: heating device (from the stock's
    ``system``), sizes (on the district's ``outdoor`` weather table) and note."""
    write_tables(out, config.layout, {f"{name}.csv": ("building", frame)})
    heating = heating_devices(config, {name: frame}, {name: system})
    size = size_buildings(config, {name: frame}, outdoor, heating)[name]
    note = building_notes({name: bldg_id}, {name: system}, heating, {name: dict(summary)}, {name: frame},
                          {name: size})[name]
    return BuildingRecord(size, note, frame=frame if config.surrogate.source == "fmu" else None)


def house_task(config: BuildConfig, bldg_id: int, name: str, out: Path,
               work: Callable[[BuildConfig, int, str], HouseWork] = house_work) -> BuildingRecord:
    """A house's whole per-building work where it runs (a worker): :func:`house_work` (simulation and, for
    ``energyplus`` surrogates, training), then its table and surrogate files written into the district's
    staging folder ``out`` (shared storage on a cluster; a rerun writes the same bytes); returns its
    :class:`BuildingRecord`. ``work``: the house work (a benchmark's stand-in)."""
    done = work(config, bldg_id, name)
    signals = site_signals_once(config)
    summary = done.simulation.summary
    record = building_record(out, config, name, bldg_id, house_table(config, done.simulation, signals.solar),
                             summary["heating_system"], summary, signals.weather)
    if done.surrogate is not None:
        record.keep_surrogate(out, name, done.surrogate)
    return record


def ingest_task(config: BuildConfig, bldg_id: int, name: str, out: Path) -> BuildingRecord:
    """An EULP building's per-building work where it runs: its table (:func:`ingest_building`) written into
    ``out``; returns its :class:`BuildingRecord`."""
    signals = site_signals_once(config)
    frame = ingest_building(config, bldg_id, signals.solar, signals.outdoor)
    return building_record(out, config, name, bldg_id, frame, eulp_heating_system(config, bldg_id), {},
                           signals.weather)


def buildings_written(out: Path, config: BuildConfig, configs: Mapping[str, BuildConfig],
                      ids: Mapping[str, int], runner: Runner, timings: dict[str, float],
                      ) -> tuple[Signals, dict[str, BuildingRecord]]:
    """Every building's per-building work on ``runner`` (:func:`house_task` for houses from real
    characteristics, :func:`ingest_task` for EULP buildings), each writing its files into ``out`` and
    returning only its :class:`BuildingRecord`, while the site's signals are read here in a thread.
    ``configs``: each building's configuration (:func:`pipeline.builder.houses.house_config`).

    Returns the signals and the records by building name; records the wall seconds of the signals and of
    the houses in ``timings`` (``site_signals``, ``houses``)."""

    started = time.perf_counter()

    def done(_) -> None:
        timings["site_signals"] = time.perf_counter() - started
        progress.end("site signals")

    progress.stage("site signals")
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="site_signals") as pool:
        pending = pool.submit(site_signals_once, config)  # read while the houses simulate: serial time hidden
        pending.add_done_callback(done)
        houses = config.inputs.characteristics is not None
        step = "house" if houses else "ingest"
        progress.stage(step, len(ids))
        records = runner.map(step, house_task if houses else ingest_task,
                             {n: (configs[n], i, n, out) for n, i in ids.items()})
        if houses:
            timings["houses"] = time.perf_counter() - started
        progress.end(step)
        return pending.result(), records


def build_district_local(config: BuildConfig, output_root: str | Path = "artifacts") -> Path:
    """:func:`run_build` with plain in-process calls (no Prefect)."""
    return run_build(config, output_root, InProcessRunner())
