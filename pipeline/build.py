"""The district build: pure steps and ONE driver, :func:`run_build`.

Steps (inputs -> in-memory tables -> outputs)::

    site_signals      weather file, tariff, fuel mix -> weather / pricing / carbon tables + PV yield per kW
                      (the PV yield is computed once per site: every building shares the weather file)
    ingest_building   EULP building + the site's PV yield -> the building table (per building)
    size_buildings    building tables + outdoor temperature -> device attributes (pipeline.sizing)
    surrogate_files   ILV table (or EnergyPlus inputs) -> trained LSTM files, through the surrogate cache
                      (per building; see pipeline.cache)
    schema_dict       -> schema.json;  validate_district -> report/;  write_manifest -> manifest.json

Tables are ``pandas.DataFrame`` of internal (v2.2) column names, one row per hour from ``period.start``
00:00 (local standard time; row 0 is CityLearn hour 1); they are written with
:func:`citylearn_env.dataset.write_table` and never read back. :func:`run_build` sequences the steps and
submits the per-building work through a :class:`Runner`: :class:`InProcessRunner` (plain calls, here),
or the Prefect runner of :mod:`pipeline.flows` (tasks on a thread pool, or on Dask). A build is written into
a temporary sibling folder and renamed into place only when complete and validated.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shutil
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from importlib import metadata as importlib_metadata
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from pipeline.config import BuildConfig
from pipeline.errors import InputError

OBSERVATIONS_SHARED = ("month", "day_type", "hour", "outdoor_dry_bulb_temperature",
                       "outdoor_dry_bulb_temperature_predicted_6h", "diffuse_solar_irradiance",
                       "direct_solar_irradiance", "carbon_intensity", "electricity_pricing",
                       "electricity_pricing_predicted_6h")
OBSERVATIONS_BUILDING = ("indoor_dry_bulb_temperature", "non_shiftable_load", "solar_generation",
                         "dhw_storage_soc", "electrical_storage_soc", "net_electricity_consumption",
                         "cooling_demand", "dhw_demand", "occupant_count", "indoor_dry_bulb_temperature_set_point",
                         "indoor_dry_bulb_temperature_delta", "power_outage")
#: the trainer's source files (relative to the ``surrogates`` package): part of every surrogate cache key
TRAINER_SOURCES = ("train.py", "model.py", "export.py", "evaluate.py", "ilv.py")
#: what turns EULP metadata + EPW into an ILV table: part of the key for ``surrogate.source = "energyplus"``
ENERGYPLUS_SOURCES = ("sources/energyplus.py", "energyplus/ilv.py", "energyplus/house.py",
                      "energyplus/metadata.py", "energyplus/runner.py", "energyplus/sqlite.py", "energyplus/epw.py")


# ---------------------------------------------------------------------------------------------- runners
class Runner(Protocol):
    """Runs one step for several buildings, possibly in parallel; results come back by label, in order."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        """``{label: fn(*args) for label, args in calls.items()}``; ``step`` names the work (task names)."""
        ...


class InProcessRunner:
    """Plain calls, one after the other, in this process (tests, quick runs, no Prefect needed)."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        return {label: fn(*args) for label, args in calls.items()}


def building_names(config: BuildConfig) -> list[str]:
    return [f"Building_{i}" for i in range(1, len(config.inputs.buildings) + 1)]


# ---------------------------------------------------------------------------------------------- ingest
@dataclass(frozen=True)
class Signals:
    """The district's shared tables over the period (hourly, row 0 = period start 00:00 standard time).

    ``weather``: CityLearn weather columns; ``pricing``: $/kWh columns; ``carbon``: ``carbon_intensity``
    [kg CO2e/kWh]; ``solar``: PV AC yield [W per kW DC] of the site, indexed by local standard time over the
    weather file's whole range (buildings select their period).
    """

    weather: pd.DataFrame
    pricing: pd.DataFrame
    carbon: pd.DataFrame
    solar: pd.Series


def site_signals(config: BuildConfig) -> Signals:
    """Read the weather file once: the weather table and the site's PV yield; then prices and carbon."""
    from pipeline.carbon import carbon_intensity, read_emission_factors
    from pipeline.ingest.commands import read_weather_file
    from pipeline.ingest.fuel_mix import read_fuel_mix_csv, read_fuel_mix_workbook
    from pipeline.ingest.tariff import citylearn_pricing, read_tariff
    from pipeline.ingest.timeindex import period_index, select_period
    from pipeline.ingest.weather import ForecastSpec, citylearn_weather
    from pipeline.pv import site_pv_yield

    p, i = config.period, config.inputs
    index = period_index(p.start, p.end)
    frame, meta = read_weather_file(i.weather, tmy_year=index[0].year)
    weather = citylearn_weather(frame, index, ForecastSpec(mode=config.forecast, seed=config.seed), file=i.weather)
    solar = site_pv_yield(frame, meta, tilt=config.pv.tilt, azimuth=config.pv.azimuth, file=i.weather)
    pricing = citylearn_pricing(read_tariff(i.tariff), index)
    fuel_mix = Path(i.fuel_mix)
    if fuel_mix.suffix.lower() in (".xlsx", ".xlsm"):
        generation, _ = read_fuel_mix_workbook(fuel_mix, timezone=config.timezone)
    else:
        generation, _ = read_fuel_mix_csv(fuel_mix, timezone=config.timezone)
    generation = select_period(generation, index, file=fuel_mix)
    carbon = carbon_intensity(generation, read_emission_factors(None)).to_frame("carbon_intensity")
    return Signals(weather, pricing, carbon, solar)


def ingest_building(config: BuildConfig, bldg_id: int, solar: pd.Series) -> pd.DataFrame:
    """One building's CityLearn table from its EULP metadata and timeseries, with the site's PV yield."""
    from pipeline.ingest.eulp import (
        building_loads,
        citylearn_building,
        locate_building,
        read_eulp_metadata,
        read_eulp_timeseries,
    )
    from pipeline.ingest.timeindex import period_index

    i = config.inputs
    metadata_path, series_path = locate_building(i.eulp, int(bldg_id), upgrade=i.upgrade, state=i.state)
    metadata = read_eulp_metadata(metadata_path)
    if int(bldg_id) not in metadata.index:
        raise InputError(f"building {bldg_id} not in the metadata", file=metadata_path, column="bldg_id")
    series, _ = read_eulp_timeseries(series_path)
    loads = building_loads(series, metadata.loc[int(bldg_id)], file=series_path)
    return citylearn_building(loads, period_index(config.period.start, config.period.end),
                              holidays=[d.isoformat() for d in i.holidays], solar_generation=solar,
                              file=series_path)


def write_tables(out: Path, layout: str, tables: Mapping[str, tuple[str, pd.DataFrame]]) -> None:
    """Write ``{file name: (kind, table)}`` into ``out`` with :func:`citylearn_env.dataset.write_table`."""
    from citylearn_env.dataset import write_table

    for filename, (kind, table) in tables.items():
        write_table(out / filename, kind, {c: table[c].to_numpy(dtype=float) for c in table.columns}, layout)


# ---------------------------------------------------------------------------------------------- sizing
def size_buildings(config: BuildConfig, frames: Mapping[str, pd.DataFrame],
                   weather: pd.DataFrame) -> dict[str, dict]:
    """Device attributes per building (the paper's rules, :mod:`pipeline.sizing`) from the in-memory tables."""
    from pipeline.sizing import size_building

    rules = config.sizing.rules()
    outdoor = weather["outdoor_dry_bulb_temperature"].to_numpy(dtype=float)
    return {name: size_building(frame, outdoor, rules) for name, frame in frames.items()}


# ---------------------------------------------------------------------------------------------- surrogates
@dataclass(frozen=True)
class SurrogateFiles:
    """A building's surrogate files (relative path -> bytes), the cache key, and whether the cache had them."""

    files: dict[str, bytes]
    key: str
    hit: bool


def train_config(config: BuildConfig):
    """The :class:`surrogates.train.TrainConfig` of the build (single-threaded, no progress bar)."""
    from surrogates.train import TrainConfig

    s = config.surrogate
    return TrainConfig(hidden_size=s.hidden_size, num_layers=s.num_layers, lookback=s.lookback, epochs=s.epochs,
                       seed=s.seed, max_seconds=s.max_seconds, progress=False, threads=1)


def csv_ilv_path(config: BuildConfig, bldg_id: int) -> Path:
    """``inputs.ilv/<bldg_id>.parquet`` (or ``.csv``) of a building (surrogate source ``csv``)."""
    if config.inputs.ilv is None:
        raise InputError("surrogate.source = 'csv' needs inputs.ilv (a folder of <bldg_id>.parquet/.csv)",
                         file=config.source, column="inputs.ilv")
    for suffix in (".parquet", ".csv"):
        path = config.inputs.ilv / f"{bldg_id}{suffix}"
        if path.exists():
            return path
    raise InputError(f"no ILV table for building {bldg_id}", file=config.inputs.ilv, column="inputs.ilv")


def eulp_metadata_row(config: BuildConfig, bldg_id: int) -> dict[str, object]:
    """The building's EULP metadata row as plain JSON values (``bldg_id`` included; NaN -> None)."""
    from pipeline.ingest.eulp import locate_building, read_eulp_metadata

    i = config.inputs
    metadata_path, _ = locate_building(i.eulp, int(bldg_id), upgrade=i.upgrade, state=i.state)
    row = read_eulp_metadata(metadata_path).loc[int(bldg_id)].to_dict()
    plain = {"bldg_id": int(bldg_id)}
    for key, value in row.items():
        value = value.item() if isinstance(value, np.generic) else value
        plain[str(key)] = None if isinstance(value, float) and np.isnan(value) else value
    return plain


def surrogate_cache_parts(config: BuildConfig, bldg_id: int, name: str) -> tuple[dict, pd.DataFrame | None]:
    """What a building's surrogate is a function of (the cache key parts), and its ILV table when at hand.

    Parts: the ILV table's content sha256 (source ``csv``) or, for ``energyplus``, the EPW's sha256, the
    metadata row and the generator's sources; the full training configuration; the trainer's sources
    (:data:`TRAINER_SOURCES`) and the torch version; the building's name and id (they are written into the
    files). Nothing else of the build configuration (battery, PV, period, ...) enters.
    """
    import surrogates
    from pipeline.cache import files_digest, table_digest

    package = Path(surrogates.__file__).parent
    settings = {k: v for k, v in asdict(train_config(config)).items() if k != "progress"}
    parts: dict[str, object] = {
        "building": name, "bldg_id": int(bldg_id), "train": settings,
        "trainer_sha256": files_digest([package / f for f in TRAINER_SOURCES], package),
        "torch": _version("torch"),
    }
    if config.surrogate.source == "energyplus":
        parts["ilv"] = {"source": "energyplus", "epw_sha256": _sha256(Path(config.inputs.weather)),
                        "metadata_row": eulp_metadata_row(config, bldg_id),
                        "generator_sha256": files_digest([package / f for f in ENERGYPLUS_SOURCES], package)}
        return parts, None
    from surrogates.ilv import read_ilv

    table = read_ilv(csv_ilv_path(config, bldg_id))
    parts["ilv"] = {"source": "csv", "table_sha256": table_digest(table)}
    return parts, table


def energyplus_ilv(config: BuildConfig, bldg_id: int) -> pd.DataFrame:
    """The building's ILV table simulated with the project's EnergyPlus house model (validated)."""
    from surrogates.ilv import validate_ilv
    from surrogates.sources.energyplus import energyplus_ilv_table

    result = energyplus_ilv_table(eulp_metadata_row(config, bldg_id), Path(config.inputs.weather))
    return validate_ilv(result.table, source=f"EnergyPlus ILV of building {bldg_id}")


def train_files(table: pd.DataFrame, bldg_id: int, name: str, settings) -> dict[str, bytes]:
    """Train, evaluate and export in a scratch folder; return the files (relative path -> bytes).

    ``<name>.pth`` goes next to the schema, ``surrogates/<name>.{dynamics,metrics}.json`` and ``.png`` into
    ``surrogates/``.
    """
    import tempfile

    from surrogates.export import train_and_export

    with tempfile.TemporaryDirectory(prefix="districtgen_surrogate_") as scratch:
        folder = Path(scratch) / "surrogates"
        train_and_export(table, folder, name, settings, source=f"ILV table of building {bldg_id}")
        files = {f"surrogates/{p.name}": p.read_bytes() for p in sorted(folder.glob(f"{name}.*"))}
    files[f"{name}.pth"] = files.pop(f"surrogates/{name}.pth")
    return files


def surrogate_files(config: BuildConfig, bldg_id: int, name: str) -> SurrogateFiles:
    """A building's surrogate files: from the cache (:mod:`pipeline.cache`) when an intact entry of the same
    key exists, else trained (and stored). The cache folder: ``config.cache_dir``, else
    ``$DISTRICTGEN_CACHE_DIR``, else ``~/.cache/districtgen``; entries under ``surrogates/<key>/``."""
    from pipeline.cache import FileCache, cache_key, cache_root

    parts, table = surrogate_cache_parts(config, bldg_id, name)
    key = cache_key(parts)
    cache = FileCache(cache_root(config.cache_dir) / "surrogates")
    files = cache.get(key)
    if files is not None:
        return SurrogateFiles(files, key, True)
    if table is None:
        table = energyplus_ilv(config, bldg_id)
    files = train_files(table, bldg_id, name, train_config(config))
    cache.put(key, files, inputs=parts)
    return SurrogateFiles(files, key, False)


def write_surrogate_files(out: Path, files: Mapping[str, bytes]) -> dict:
    """Write a building's surrogate files into the district folder; return its ``dynamics`` block."""
    dynamics_name = next(r for r in files if r.endswith(".dynamics.json"))
    pth = next(r for r in files if r.endswith(".pth"))
    block = json.loads(files[dynamics_name])
    block["attributes"]["filename"] = pth
    for relative, data in files.items():
        path = out / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        if relative == dynamics_name:
            path.write_text(json.dumps(block, indent=2))
        else:
            path.write_bytes(data)
    return block


# ---------------------------------------------------------------------------------------------- emit
def schema_dict(config: BuildConfig, names: list[str], sizes: dict[str, dict],
                dynamics: dict[str, dict] | None) -> dict:
    """The CityLearn schema of the district (file names relative to the schema's folder), written through
    the one schema writer :func:`citylearn_env.emit.schema_document`."""
    from citylearn_env.dataset import DynamicsBlock
    from citylearn_env.emit import BuildingEntry, schema_document

    slots = ("cooling_device", "dhw_device", "dhw_storage", "electrical_storage", "pv")
    entries = [BuildingEntry(name, {slot: sizes[name][slot] for slot in slots},
                             dynamics=DynamicsBlock.from_schema(dynamics[name]) if dynamics else None)
               for name in names]
    return schema_document(
        entries, hours=_hours(config), observations=(*OBSERVATIONS_SHARED, *OBSERVATIONS_BUILDING),
        shared_observations=OBSERVATIONS_SHARED, layout=config.layout, random_seed=config.seed,
        active_actions={"dhw_storage", "electrical_storage"} | ({"cooling_device"} if dynamics else set()))


def write_manifest(out: Path, config: BuildConfig, timings: dict[str, float],
                   surrogate_cache: Mapping[str, Mapping[str, object]] | None = None) -> Path:
    """``manifest.json``: sha256 of every output and input, versions, seeds, timings, surrogate cache use."""
    files = {}
    for path in sorted(p for p in out.rglob("*") if p.is_file() and p.name != "manifest.json"):
        files[str(path.relative_to(out))] = {"sha256": _sha256(path), "bytes": path.stat().st_size}
    inputs = {}
    for key in ("weather", "tariff", "fuel_mix"):
        path = Path(getattr(config.inputs, key))
        inputs[key] = {"path": str(path), "sha256": _sha256(path)}
    versions = {dist: _version(dist) for dist in
                ("districtgen", "numpy", "pandas", "torch", "gymnasium", "prefect", "pvlib")}
    manifest = {"district": config.name, "config": json.loads(config.model_dump_json()), "inputs": inputs,
                "outputs": files, "versions": versions, "python": platform.python_version(),
                "seeds": {"build": config.seed, "surrogate": config.surrogate.seed}, "timings_s": timings,
                "surrogate_cache": dict(surrogate_cache or {})}
    path = out / "manifest.json"
    path.write_text(json.dumps(manifest, indent=2, default=str))
    return path


def verify_district(folder: str | Path) -> list[str]:
    """Re-check every output hash of ``manifest.json``; return the problems (empty = intact)."""
    folder = Path(folder)
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except FileNotFoundError:
        raise InputError("no manifest.json: not a districtgen build", file=folder) from None
    problems = []
    for name, entry in manifest["outputs"].items():
        path = folder / name
        if not path.exists():
            problems.append(f"{name}: missing")
        elif _sha256(path) != entry["sha256"]:
            problems.append(f"{name}: sha256 differs from the manifest")
    return problems


# ---------------------------------------------------------------------------------------------- validate
def validate_district(schema_path: Path, report_dir: Path, name: str | None = None,
                      schema: Mapping[str, Any] | None = None) -> dict:
    """Load the schema once, run no control and the cost RBC on it; write KPI tables and the report.

    ``schema``: the schema as a dict when the caller has it (else ``schema_path`` is read for the report).
    """
    from citylearn_env import load_schema
    from pipeline.controllers import run_policy
    from pipeline.report import write_report

    report_dir.mkdir(parents=True, exist_ok=True)
    district = load_schema(schema_path)
    results = {}
    for policy in ("no_control", "cost_rbc"):
        env = run_policy(district, policy)
        kpis = env.evaluate()
        kpis.to_csv(report_dir / f"kpis_{policy}.csv", index=False)
        results[policy] = {"objectives": {k: v for k, v in env.objectives().items() if np.isscalar(v)},
                           "kpis": kpis, "net": env.series()["net_electricity_consumption"].sum(axis=0)}
    schema = dict(schema) if schema is not None else json.loads(Path(schema_path).read_text())
    write_report(report_dir, name or schema_path.parent.name, schema, results, schema_path.parent / "surrogates")
    return results


# ---------------------------------------------------------------------------------------------- driver
def run_build(config: BuildConfig, output_root: str | Path = "artifacts", runner: Runner | None = None) -> Path:
    """THE build: every step in order, per-building work through ``runner`` (default: in-process).

    Writes into a hidden sibling folder of ``output_root/<name>`` and renames it into place only when the
    schema validated; returns ``output_root/<name>``. Timings [s] and the surrogate cache use (key, hit) per
    building go into ``manifest.json``.
    """
    runner = runner or InProcessRunner()
    names = building_names(config)
    ids = dict(zip(names, config.inputs.buildings, strict=True))
    with staging(config, output_root) as out:
        timings: dict[str, float] = {}
        started = time.perf_counter()
        signals = site_signals(config)
        frames = runner.map("ingest", ingest_building, {n: (config, i, signals.solar) for n, i in ids.items()})
        write_tables(out, config.layout, {
            "weather.csv": ("weather", signals.weather), "pricing.csv": ("pricing", signals.pricing),
            "carbon_intensity.csv": ("carbon", signals.carbon),
            **{f"{n}.csv": ("building", frames[n]) for n in names}})
        timings["ingest"] = time.perf_counter() - started
        sizes = size_buildings(config, frames, signals.weather)
        started = time.perf_counter()
        dynamics, cache_use = None, {}
        if config.surrogate.source != "none":
            trained = runner.map("surrogate", surrogate_files, {n: (config, i, n) for n, i in ids.items()})
            dynamics = {n: write_surrogate_files(out, trained[n].files) for n in names}
            cache_use = {n: {"key": trained[n].key, "hit": trained[n].hit} for n in names}
        timings["surrogates"] = time.perf_counter() - started
        schema = schema_dict(config, names, sizes, dynamics)
        schema_path = out / "schema.json"
        schema_path.write_text(json.dumps(schema, indent=2))
        started = time.perf_counter()
        validate_district(schema_path, out / "report", config.name, schema)
        timings["validate"] = time.perf_counter() - started
        write_manifest(out, config, timings, cache_use)
    return Path(output_root) / config.name


def build_district_local(config: BuildConfig, output_root: str | Path = "artifacts") -> Path:
    """:func:`run_build` with plain in-process calls (no Prefect)."""
    return run_build(config, output_root, InProcessRunner())


class staging:
    """Context manager: a temporary sibling folder that replaces ``root/name`` only on success."""

    def __init__(self, config: BuildConfig, root: str | Path):
        self.final = Path(root) / config.name
        self.tmp = Path(root) / f".{config.name}.building-{os.getpid()}"

    def __enter__(self) -> Path:
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.tmp.mkdir(parents=True)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return
        old = self.final.with_name(f".{self.final.name}.old-{os.getpid()}")
        if self.final.exists():
            self.final.rename(old)
        self.tmp.rename(self.final)
        shutil.rmtree(old, ignore_errors=True)


def _hours(config: BuildConfig) -> int:
    return ((config.period.end - config.period.start).days + 1) * 24


def _version(dist: str) -> str | None:
    try:
        return importlib_metadata.version(dist)
    except importlib_metadata.PackageNotFoundError:
        return None


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()
