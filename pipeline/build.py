"""The district build: pure steps and ONE driver, :func:`run_build`.

Steps (inputs -> in-memory tables -> outputs)::

    resolve_selection [selection] -> the bldg_ids (pipeline.select: filters + one building per k-means cluster)
    site_signals      weather file, tariff, fuel mix -> weather / pricing / carbon tables + PV yield per kW
                      (the PV yield is computed once per site: every building shares the weather file)
    ingest_building   EULP building + the site's PV yield -> the building table (per building), or
    simulate_building a real stock row -> ONE full-year EnergyPlus pass on the district's weather: hourly
                      loads + the ILV table (per building, cached); house_table -> the building table
    size_buildings    building tables + outdoor temperature -> device attributes (cooling and heating)
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

import glob
import json
import os
import re
import shutil
import time
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from pipeline.config import BuildConfig
from pipeline.errors import InputError
from pipeline.manifest import (
    make_world_readable,
    package_version,
    split_surrogate_timings,
    verify_district,  # noqa: F401  (re-exported: build.verify_district)
    write_manifest,
    write_timings,
)
from pipeline.manifest import sha256_file as _sha256

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
#: largest mean |T_out difference| [degC] between a table's own outdoor temperature and the district's weather
#: over their common hours before the build refuses the table as simulated on other weather
WEATHER_TOLERANCE_C = 1.5
#: heating system of the stock -> heating device of the schema (``fuel`` and ``none``: simulation.fuel_heating)
HEATING_DEVICE_OF = {"heat_pump": "heat_pump", "electric_resistance": "electric_heater"}


# ---------------------------------------------------------------------------------------------- runners
class Runner(Protocol):
    """Runs one step for several buildings, possibly in parallel; results come back by label, in order."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        """``{label: fn(*args) for label, args in calls.items()}``; ``step`` names the work (task names)."""
        ...


class InProcessRunner:
    """Plain calls, one after the other, in this process (tests, quick runs, no Prefect needed)."""

    def map(self, step: str, fn: Callable[..., Any], calls: Mapping[str, tuple]) -> dict[str, Any]:
        from pipeline import progress

        results = {}
        for label, args in calls.items():
            results[label] = fn(*args)
            progress.advance(step, label)
        return results


def building_names(config: BuildConfig) -> list[str]:
    return [f"Building_{i}" for i in range(1, len(config.inputs.buildings) + 1)]


# ---------------------------------------------------------------------------------------------- selection
def resolve_selection(config: BuildConfig) -> tuple[BuildConfig, Any]:
    """The configuration with ``inputs.buildings`` set from ``[selection]`` (when given; the listed buildings
    otherwise) and the :class:`pipeline.select.Selection` (or None)."""
    if config.selection is None:
        return config, None
    from pipeline.select import select_from_file

    sel = config.selection
    selection = select_from_file(sel.metadata or config.inputs.characteristics, sel.filters, clusters=sel.clusters,
                                 seed=sel.seed, method=sel.method, max_clusters=sel.max_clusters)
    ids = [int(i) for i in selection.chosen["bldg_id"]]
    return config.model_copy(update={"inputs": config.inputs.model_copy(update={"buildings": ids})}), selection


def check_weather(own_outdoor_c: pd.Series, weather_outdoor_c: pd.Series, *, what: str, file: object) -> float:
    """Refuse (one line) a table whose own outdoor temperature [degC] differs from the district's weather by more
    than :data:`WEATHER_TOLERANCE_C` on average over their common hours; returns that mean difference.

    Both series are indexed by interval-beginning local standard time; no common hour is also a refusal.
    """
    common = own_outdoor_c.index.intersection(weather_outdoor_c.index)
    if len(common) == 0:
        raise InputError(f"{what} has no hour in common with the district's weather and period", file=file,
                         column="outdoor_dry_bulb_temperature")
    diff = float(np.mean(np.abs(own_outdoor_c.loc[common].to_numpy(dtype=float)
                                - weather_outdoor_c.loc[common].to_numpy(dtype=float))))
    if not diff <= WEATHER_TOLERANCE_C:
        raise InputError(f"{what} was simulated on other weather than the district's (mean |dT_out| = {diff:.2f} "
                         f"degC over {len(common)} h, limit {WEATHER_TOLERANCE_C}): re-simulate it with the "
                         "district's weather file", file=file, column="outdoor_dry_bulb_temperature")
    return diff


def read_characteristics_row(path: Path, bldg_id: int) -> dict[str, object]:
    """One stock row (either metadata layout) as plain JSON values in the published layout (``bldg_id``,
    ``in.*``); NaN -> None."""
    from pipeline.select import read_stock_table
    from surrogates.energyplus.metadata import normalise_characteristics

    path = Path(path)
    raw = read_stock_table(path)
    id_column = "bldg_id" if "bldg_id" in raw.columns else "building_id"
    if id_column not in raw.columns:
        raise InputError("no building id column (expected 'bldg_id' or 'building_id')", file=path, column="bldg_id")
    rows = raw[pd.to_numeric(raw[id_column], errors="coerce") == int(bldg_id)]
    if rows.empty:
        raise InputError(f"building {bldg_id} not in the characteristics", file=path, column=id_column)
    keep = {k: v for k, v in rows.iloc[0].to_dict().items()
            if str(k).startswith(("bldg_id", "building_id", "in.", "build_existing_model.", "upgrade_costs.floor"))}
    return {k: _plain(v) for k, v in normalise_characteristics(keep).items()}


def _plain(value: object) -> object:
    """A numpy scalar as a plain Python value; NaN -> None (JSON-safe cache-key parts)."""
    value = value.item() if isinstance(value, np.generic) else value
    return None if isinstance(value, float) and np.isnan(value) else value


@dataclass(frozen=True)
class HouseSimulation:
    """A simulated house: hourly loads (see :func:`surrogates.energyplus.ilv.hourly_loads`), its ILV table, the
    report summary (heating system, set-point repair), the cache key and whether the cache had it."""

    loads: pd.DataFrame
    ilv: pd.DataFrame
    summary: dict
    key: str
    hit: bool


def simulation_cache_parts(config: BuildConfig, row: Mapping[str, object]) -> dict:
    """What a house's simulation is a function of (the cache key parts): the stock row, the weather file's
    sha256, the calendar year of the period (the pass covers that whole year), the simulation settings (not
    ``fuel_heating``: it acts after the simulation) and the generator's sources. Not the period's days."""
    import surrogates
    from pipeline.cache import files_digest

    package = Path(surrogates.__file__).parent
    return {"row": dict(row), "epw_sha256": _sha256(Path(config.inputs.weather)), "year": config.period.start.year,
            "simulation": config.simulation.model_dump(exclude={"fuel_heating"}),
            "generator_sha256": files_digest([package / f for f in ENERGYPLUS_SOURCES], package)}


def simulate_building(config: BuildConfig, bldg_id: int) -> HouseSimulation:
    """The full-year EnergyPlus pass of one real stock row on the district's weather (loads + ILV), from the
    simulation cache (``<cache root>/simulations/<key>``; key: the row, the EPW's sha256, the simulation
    settings and the generator's sources) or simulated and stored."""
    import io

    from pipeline.cache import FileCache, cache_key, cache_root
    from surrogates.energyplus.ilv import ILVConfig
    from surrogates.sources.energyplus import simulate_house

    row = read_characteristics_row(config.inputs.characteristics, bldg_id)
    parts = simulation_cache_parts(config, row)
    sim, year = config.simulation, config.period.start.year
    key = cache_key(parts)
    cache = FileCache(cache_root(config.cache_dir) / "simulations")
    files = cache.get(key)
    if files is not None:
        return HouseSimulation(pd.read_parquet(io.BytesIO(files["loads.parquet"])),
                               pd.read_parquet(io.BytesIO(files["ilv.parquet"])),
                               json.loads(files["house.json"]), key, True)
    ilv_config = ILVConfig(partial_runs=sim.partial_runs, seed=sim.seed, timesteps_per_hour=sim.timesteps_per_hour,
                           year=year)
    loads, table, summary = simulate_house(row, Path(config.inputs.weather), config=ilv_config,
                                           source=config.inputs.characteristics)
    files = {"loads.parquet": loads.to_parquet(), "ilv.parquet": table.to_parquet(index=False),
             "house.json": json.dumps(summary).encode()}
    cache.put(key, files, inputs=parts)
    return HouseSimulation(loads, table, summary, key, False)


@dataclass(frozen=True)
class HouseWork:
    """One house's per-building work: its simulation and, for ``surrogate.source = "energyplus"``, its
    surrogate files (None otherwise: trained later, from tables that need the site's signals)."""

    simulation: HouseSimulation
    surrogate: SurrogateFiles | None


def house_work(config: BuildConfig, bldg_id: int, name: str) -> HouseWork:
    """Simulate a real stock row (:func:`simulate_building`) and train its surrogate on the simulated ILV table
    (:func:`surrogate_files`) in ONE task: no barrier between the two stages across houses, so a worker that
    finishes a simulation trains at once; each result is cached as soon as it exists (a rerun resumes)."""
    from pipeline.progress import report

    report(name, "simulate (EnergyPlus, full year)")
    simulation = simulate_building(config, bldg_id)
    surrogate = None
    if config.surrogate.source == "energyplus":
        surrogate = surrogate_files(config, bldg_id, name, simulation.ilv)
        simulation = replace(simulation, ilv=simulation.ilv.iloc[:0])  # used: not sent back to the build process
    return HouseWork(simulation, surrogate)


def house_table(config: BuildConfig, simulation: HouseSimulation, solar: pd.Series) -> pd.DataFrame:
    """The CityLearn building table of a simulated house over the period: calendar, the loads of the ideal
    pass (:func:`surrogates.energyplus.ilv.hourly_loads`), indoor humidity, hourly occupants and set points
    (``indoor_dry_bulb_temperature_set_point`` = the acting one; the cooling and heating set-point columns
    too where the file layout has them), ``hvac_mode`` 2 where heating exceeds cooling else 1, PV yield."""
    from citylearn_env.dataset import BUILDING_COLUMNS, calendar
    from pipeline.ingest.timeindex import period_index, select_period

    index = period_index(config.period.start, config.period.end)
    source = f"EnergyPlus house {simulation.summary['bldg_id']}"
    part = select_period(simulation.loads, index, file=source)
    out = pd.DataFrame(calendar(index[0].to_datetime64(), len(index),
                                [d.isoformat() for d in config.inputs.holidays]), index=index)
    out["indoor_dry_bulb_temperature"] = part["indoor_dry_bulb_temperature_c"].to_numpy()
    out["average_unmet_cooling_setpoint_difference"] = (part["indoor_dry_bulb_temperature_c"]
                                                        - part["set_point_c"]).to_numpy()
    out["indoor_relative_humidity"] = part["indoor_relative_humidity"].to_numpy()
    for name, column in (("non_shiftable_load", "non_shiftable_load_kwh"), ("dhw_demand", "dhw_demand_kwh"),
                         ("cooling_demand", "cooling_demand_kwh"), ("heating_demand", "heating_demand_kwh")):
        out[name] = part[column].to_numpy()
    out["solar_generation"] = select_period(solar.to_frame(), index, file=source).iloc[:, 0].to_numpy()
    out["occupant_count"] = part["occupant_count"].to_numpy()
    out["indoor_dry_bulb_temperature_set_point"] = part["set_point_c"].to_numpy()
    out["hvac_mode"] = np.where(part["heating_demand_kwh"] > part["cooling_demand_kwh"], 2, 1)
    out["power_outage"] = 0
    if config.layout == "v2.2":
        for name, column in (("indoor_dry_bulb_temperature_cooling_set_point", "cooling_set_point_c"),
                             ("indoor_dry_bulb_temperature_heating_set_point", "heating_set_point_c")):
            if name in BUILDING_COLUMNS:
                out[name] = part[column].to_numpy()
    return out


def heating_devices(config: BuildConfig, frames: Mapping[str, pd.DataFrame],
                    systems: Mapping[str, str]) -> dict[str, str | None]:
    """Heating device per building: None without heating demand in the period; else from the stock's heating
    system (heat pump -> the heat pump heats too; electric resistance -> an electric heater; a fuel or no
    system -> ``simulation.fuel_heating``)."""
    out: dict[str, str | None] = {}
    for name, frame in frames.items():
        if float(frame["heating_demand"].sum()) <= 0.0:
            out[name] = None
        else:
            out[name] = HEATING_DEVICE_OF.get(systems.get(name, "heat_pump"), config.simulation.fuel_heating)
    return out


# ---------------------------------------------------------------------------------------------- ingest
@dataclass(frozen=True)
class Signals:
    """The district's shared tables over the period (hourly, row 0 = period start 00:00 standard time).

    ``weather``: CityLearn weather columns; ``pricing``: $/kWh columns; ``carbon``: ``carbon_intensity``
    [kg CO2e/kWh]; ``solar``: PV AC yield [W per kW DC] of the site, indexed by local standard time over the
    weather file's whole range (buildings select their period); ``outdoor``: the weather file's outdoor
    dry-bulb temperature [degC] over its whole range (interval-beginning; for the weather-consistency check).
    """

    weather: pd.DataFrame
    pricing: pd.DataFrame
    carbon: pd.DataFrame
    solar: pd.Series
    outdoor: pd.Series | None = None


def site_signals(config: BuildConfig) -> Signals:
    """Read the weather file once: the weather table and the site's PV yield; then prices and carbon."""
    from pipeline.ingest.commands import carbon_table, read_weather_file
    from pipeline.ingest.tariff import citylearn_pricing, read_tariff
    from pipeline.ingest.timeindex import period_index
    from pipeline.ingest.weather import ForecastSpec, citylearn_weather
    from pipeline.pv import site_pv_yield

    p, i = config.period, config.inputs
    index = period_index(p.start, p.end)
    frame, meta = read_weather_file(i.weather, tmy_year=index[0].year)
    weather = citylearn_weather(frame, index, ForecastSpec(mode=config.forecast, seed=config.seed), file=i.weather)
    solar = site_pv_yield(frame, meta, tilt=config.pv.tilt, azimuth=config.pv.azimuth, file=i.weather)
    pricing = citylearn_pricing(read_tariff(i.tariff), index)
    carbon = carbon_table(i.fuel_mix, index, timezone=config.timezone)
    return Signals(weather, pricing, carbon, solar, frame["outdoor_dry_bulb_temperature_c"].astype(float))


def ingest_building(config: BuildConfig, bldg_id: int, solar: pd.Series,
                    weather: pd.Series | None = None) -> pd.DataFrame:
    """One building's CityLearn table from its EULP metadata and timeseries, with the site's PV yield; with
    ``weather`` (the district's outdoor temperature [degC]) the timeseries' own outdoor temperature, when it
    has one, must match it (:func:`check_weather`)."""
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
    own = "out.outdoor_air_dryblub_temp.c"
    if weather is not None and own in series.columns:
        check_weather(series[own].groupby(series.index.floor("h")).mean(), weather,
                      what=f"EULP timeseries of building {bldg_id}", file=series_path)
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
def size_buildings(config: BuildConfig, frames: Mapping[str, pd.DataFrame], weather: pd.DataFrame,
                   heating: Mapping[str, str | None] | None = None) -> dict[str, dict]:
    """Device attributes per building (the paper's rules, :func:`citylearn_env.sizing.size_devices`) from the
    in-memory tables; ``heating`` names each building's heating device (None: heating not served)."""
    from citylearn_env.sizing import size_devices

    rules = config.sizing.rules()
    outdoor = weather["outdoor_dry_bulb_temperature"].to_numpy(dtype=float)
    columns = ("cooling_demand", "heating_demand", "dhw_demand", "non_shiftable_load", "solar_generation")
    return {name: size_devices({c: frame[c].to_numpy(dtype=float) for c in columns}, outdoor, rules,
                               heating_device=(heating or {}).get(name))
            for name, frame in frames.items()}


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
                       seed=s.seed, max_seconds=s.max_seconds, precision=s.precision, progress=False, threads=1)


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
    return {"bldg_id": int(bldg_id), **{str(k): _plain(v) for k, v in row.items()}}


def surrogate_cache_parts(config: BuildConfig, bldg_id: int, name: str, table: pd.DataFrame | None = None,
                          weather: pd.Series | None = None) -> tuple[dict, pd.DataFrame | None]:
    """What a building's surrogate is a function of (the cache key parts), and its ILV table when at hand.

    Parts: the ILV table's content sha256 (a ``table`` given by the caller: a simulated house or an FMU run;
    else source ``csv``) or, for ``energyplus`` on EULP inputs, the EPW's sha256, the metadata row and the
    generator's sources; the full training configuration and the precision it resolves to on this CPU
    (:func:`surrogates.train.update_precision`); the trainer's sources (:data:`TRAINER_SOURCES`) and
    the torch version; the building's name and id (they are written into the files). Nothing else of the build
    configuration (battery, PV, period, ...) enters. With ``weather`` (the district's outdoor temperature
    [degC]) a csv table simulated on other weather is refused (:func:`check_weather`).
    """
    import surrogates
    from pipeline.cache import files_digest, table_digest

    package = Path(surrogates.__file__).parent
    from surrogates.train import update_precision

    train = train_config(config)
    settings = {k: v for k, v in asdict(train).items() if k != "progress"}
    parts: dict[str, object] = {
        "building": name, "bldg_id": int(bldg_id), "train": settings,
        "precision": update_precision(train).precision,  # what runs here: auto resolves per CPU
        "trainer_sha256": files_digest([package / f for f in TRAINER_SOURCES], package),
        "torch": package_version("torch"),
    }
    if table is not None:
        parts["ilv"] = {"source": config.surrogate.source, "table_sha256": table_digest(table)}
        return parts, table
    if config.surrogate.source == "energyplus":
        parts["ilv"] = {"source": "energyplus", "epw_sha256": _sha256(Path(config.inputs.weather)),
                        "metadata_row": eulp_metadata_row(config, bldg_id),
                        "generator_sha256": files_digest([package / f for f in ENERGYPLUS_SOURCES], package)}
        return parts, None
    from surrogates.ilv import read_ilv

    path = csv_ilv_path(config, bldg_id)
    table = read_ilv(path)
    if weather is not None:
        ideal = table[table["reference"] == table["reference"].min()]
        check_weather(pd.Series(ideal["outdoor_dry_bulb_temperature"].to_numpy(dtype=float),
                                index=pd.DatetimeIndex(ideal["timestamp"])), weather,
                      what=f"ILV table of building {bldg_id}", file=path)
    parts["ilv"] = {"source": "csv", "table_sha256": table_digest(table)}
    return parts, table


def fmu_ilv(config: BuildConfig, frame: pd.DataFrame, weather: pd.DataFrame) -> pd.DataFrame:
    """The ILV table of a building from the configured FMU, driven by the building's ideal loads and the
    district's weather over the period (:func:`surrogates.sources.fmu.simulate_ilv_fmu`)."""
    from surrogates.sources.fmu import simulate_ilv_fmu

    s = config.surrogate
    loads = pd.DataFrame({
        "direct_solar_irradiance": weather["direct_solar_irradiance"].to_numpy(dtype=float),
        "diffuse_solar_irradiance": weather["diffuse_solar_irradiance"].to_numpy(dtype=float),
        "outdoor_dry_bulb_temperature": weather["outdoor_dry_bulb_temperature"].to_numpy(dtype=float),
        "occupant_count": frame["occupant_count"].to_numpy(dtype=float),
        "cooling_demand": frame["cooling_demand"].to_numpy(dtype=float),
        "heating_demand": frame["heating_demand"].to_numpy(dtype=float),
        "indoor_dry_bulb_temperature_set_point": frame["indoor_dry_bulb_temperature_set_point"].to_numpy(float),
    }, index=frame.index)
    return simulate_ilv_fmu(s.fmu, loads, s.fmu_variables, start_values=s.fmu_start_values, seed=s.seed,
                            holidays={d for d in config.inputs.holidays} or None)


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

    from pipeline.progress import epochs
    from surrogates.export import train_and_export

    with tempfile.TemporaryDirectory(prefix="districtgen_surrogate_") as scratch:
        folder = Path(scratch) / "surrogates"
        train_and_export(table, folder, name, settings, source=f"ILV table of building {bldg_id}",
                         progress=epochs(name))
        files = {f"surrogates/{p.name}": p.read_bytes() for p in sorted(folder.glob(f"{name}.*"))}
    files[f"{name}.pth"] = files.pop(f"surrogates/{name}.pth")
    return files


def surrogate_files(config: BuildConfig, bldg_id: int, name: str, table: pd.DataFrame | None = None,
                    weather: pd.Series | None = None) -> SurrogateFiles:
    """A building's surrogate files: from the cache (:mod:`pipeline.cache`) when an intact entry of the same
    key exists, else trained (and stored). The cache folder: ``config.cache_dir``, else
    ``$DISTRICTGEN_CACHE_DIR``, else ``~/.cache/districtgen``; entries under ``surrogates/<key>/``.
    ``table``: the ILV table when the caller has it (a simulated house, an FMU run)."""
    from pipeline.cache import FileCache, cache_key, cache_root
    from pipeline.progress import report

    parts, table = surrogate_cache_parts(config, bldg_id, name, table, weather)
    key = cache_key(parts)
    cache = FileCache(cache_root(config.cache_dir) / "surrogates")
    files = cache.get(key)
    if files is not None:
        report(name, "surrogate from the cache")
        return SurrogateFiles(files, key, True)
    if table is None:
        report(name, "simulate ILV runs (EnergyPlus)")
        table = energyplus_ilv(config, bldg_id)
    report(name, "train", 0, config.surrogate.epochs)
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
    the one schema writer :func:`citylearn_env.emit.schema_document`.

    A building's ``heating_device`` (when sized) is the heat pump itself or an ``ElectricHeater``; with
    surrogates the ``heating_device`` action is active, and inactive in the buildings without one."""
    from citylearn_env.dataset import DynamicsBlock
    from citylearn_env.emit import BuildingEntry, schema_document

    slots = ("cooling_device", "heating_device", "dhw_device", "dhw_storage", "electrical_storage", "pv")
    heated = {n for n in names if "heating_device" in sizes[n]}
    entries = [BuildingEntry(
        name, {slot: sizes[name][slot] for slot in slots if slot in sizes[name]},
        dynamics=DynamicsBlock.from_schema(dynamics[name]) if dynamics else None,
        device_types={"heating_device": "citylearn.energy_model.ElectricHeater"} if _resistance(sizes[name]) else {},
        inactive_actions=("heating_device",) if dynamics and heated and name not in heated else ())
        for name in names]
    actions = {"dhw_storage", "electrical_storage"}
    if dynamics:
        actions |= {"cooling_device"} | ({"heating_device"} if heated else set())
    return schema_document(
        entries, hours=_hours(config), observations=(*OBSERVATIONS_SHARED, *OBSERVATIONS_BUILDING),
        shared_observations=OBSERVATIONS_SHARED, layout=config.layout, random_seed=config.seed,
        active_actions=actions)


def _resistance(size: Mapping[str, Mapping]) -> bool:
    """A sized heating device without a heating target temperature is an electric (resistance) heater."""
    return "heating_device" in size and "target_heating_temperature" not in size["heating_device"]


# ---------------------------------------------------------------------------------------------- validate
def validate_district(schema_path: Path, report_dir: Path, name: str | None = None,
                      schema: Mapping[str, Any] | None = None) -> dict:
    """Load the schema once, run no control and the cost RBC on it; write KPI tables and the report.

    ``schema``: the schema as a dict when the caller has it (else ``schema_path`` is read for the report).
    """
    from citylearn_env import load_schema
    from pipeline.controllers import run_policy
    from pipeline.report import report_series, write_report

    report_dir.mkdir(parents=True, exist_ok=True)
    district = load_schema(schema_path)
    results = {}
    for policy in ("no_control", "cost_rbc"):
        env = run_policy(district, policy)
        kpis = env.evaluate()
        kpis.to_csv(report_dir / f"kpis_{policy}.csv", index=False)
        objectives = env.objectives()
        results[policy] = {"objectives": {k: v for k, v in objectives.items() if np.isscalar(v)},
                           "per_building": objectives["per_building"], "kpis": kpis, "series": report_series(env)}
    schema = dict(schema) if schema is not None else json.loads(Path(schema_path).read_text())
    write_report(report_dir, name or schema_path.parent.name, schema, results, schema_path.parent / "surrogates")
    return results


# ---------------------------------------------------------------------------------------------- driver
def run_build(config: BuildConfig, output_root: str | Path = "artifacts", runner: Runner | None = None) -> Path:
    """THE build: every step in order, per-building work through ``runner`` (default: in-process).

    Writes into a hidden sibling folder of ``output_root/<name>`` and renames it into place only when the
    schema validated; returns ``output_root/<name>``. Hashes, versions and the surrogate cache keys go into
    ``manifest.json`` (reproducible); timings [s], training seconds and cache hits into ``timings.json``
    (:mod:`pipeline.manifest`); every file 0644, every folder 0755; the selection, each house's heating
    system and device and its set-point repair go into ``selection.csv`` / ``buildings.json`` and the report.
    """
    from pipeline import progress

    runner = runner or InProcessRunner()
    timings: dict[str, float] = {}
    started = time.perf_counter()
    config, selection = resolve_selection(config)
    timings["selection"] = time.perf_counter() - started
    names = building_names(config)
    ids = dict(zip(names, config.inputs.buildings, strict=True))
    with staging(config, output_root) as out:
        started = time.perf_counter()
        signals, houses, early = signals_and_houses(config, ids, runner, timings)
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
            todo = {n: (config, i, n, tables[n], outdoor) for n, i in ids.items() if n not in early}
            if todo:
                progress.stage("surrogate", len(todo))
            trained = early | runner.map("surrogate", surrogate_files, todo)
            trained = {n: trained[n] for n in names}
            if todo:
                progress.end("surrogate")
            split = {n: split_surrogate_timings(trained[n].files) for n in names}  # seconds -> timings.json
            dynamics = {n: write_surrogate_files(out, split[n][0]) for n in names}
            cache_use = {n: {"hit": trained[n].hit, **split[n][1]} for n in names}
        timings["surrogates"] = time.perf_counter() - started
        schema = schema_dict(config, names, sizes, dynamics)
        schema_path = out / "schema.json"
        schema_path.write_text(json.dumps(schema, indent=2))
        buildings = building_notes(ids, systems, heating, {n: h.summary for n, h in houses.items()}, frames,
                                   sizes)
        (out / "buildings.json").write_text(json.dumps(buildings, indent=2))
        if selection is not None:
            selection.chosen.assign(building=names).to_csv(out / "selection.csv", index=False)
        started = time.perf_counter()
        progress.stage("validate")
        validate_district(schema_path, out / "report", config.name, schema)
        progress.end("validate")
        append_building_report(out / "report" / "summary.md", buildings, selection)
        timings["validate"] = time.perf_counter() - started
        write_manifest(out, config, {n: trained[n].key for n in cache_use})
        write_timings(out, config, timings, cache_use)
        make_world_readable(out)
    return Path(output_root) / config.name


def signals_and_houses(config: BuildConfig, ids: Mapping[str, int], runner: Runner, timings: dict[str, float],
                       ) -> tuple[Signals, dict[str, HouseSimulation], dict[str, SurrogateFiles]]:
    """The site's signals (read in a thread) while the runner does the per-house work (:func:`house_work`:
    simulation and, for ``energyplus`` surrogates, training) of buildings from real characteristics.

    Returns the signals, the simulations and the surrogates already trained, by building name; records the
    wall seconds of both in ``timings`` (``site_signals``, ``houses``)."""
    from pipeline import progress

    started = time.perf_counter()
    houses: dict[str, HouseSimulation] = {}
    early: dict[str, SurrogateFiles] = {}

    def done(_) -> None:
        timings["site_signals"] = time.perf_counter() - started
        progress.end("site signals")

    progress.stage("site signals")
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="site_signals") as pool:
        pending = pool.submit(site_signals, config)  # read while the houses simulate: serial time hidden
        pending.add_done_callback(done)
        if config.inputs.characteristics is not None:
            progress.stage("house", len(ids))
            work = runner.map("house", house_work, {n: (config, i, n) for n, i in ids.items()})
            houses = {n: work[n].simulation for n in ids}
            early = {n: work[n].surrogate for n in ids if work[n].surrogate is not None}
            timings["houses"] = time.perf_counter() - started
            progress.end("house")
        return pending.result(), houses, early


def eulp_heating_system(config: BuildConfig, bldg_id: int) -> str:
    """The heating system (:func:`surrogates.energyplus.metadata.parse_heating_system`) of an EULP building
    from its metadata (``in.heating_fuel``, ``in.hvac_heating_type_and_fuel``); a heat pump when absent."""
    from surrogates.energyplus.metadata import parse_heating_system

    row = eulp_metadata_row(config, bldg_id)
    if row.get("in.heating_fuel") is None:
        return "heat_pump"
    return parse_heating_system(row["in.heating_fuel"], row.get("in.hvac_heating_type_and_fuel")
                                or row.get("in.hvac_heating_efficiency") or "")


def building_notes(ids: Mapping[str, int], systems: Mapping[str, str], heating: Mapping[str, str | None],
                   summaries: Mapping[str, dict], frames: Mapping[str, pd.DataFrame],
                   sizes: Mapping[str, dict] | None = None) -> dict[str, dict]:
    """Per building: bldg_id, the stock's heating system, the schema's heating device (and why) and its nominal
    electric power [kW], the period's heating and cooling demand [kWh] and, for simulated houses, the house
    summary (set points, repairs)."""
    why = {"heat_pump": "heats with a heat pump", "electric_resistance": "heats with electric resistance",
           "fuel": "heats with a fuel: electrified", "none": "has no heating system: electrified"}
    notes = {}
    for name, bldg_id in ids.items():
        frame = frames[name]
        device = heating[name]
        note = "no heating demand in the period" if device is None else why.get(systems[name], "")
        power = ((sizes or {}).get(name, {}).get("heating_device") or {}).get("nominal_power")
        notes[name] = {"bldg_id": int(bldg_id), "heating_system": systems[name], "heating_device": device,
                       "heating_note": note, "heating_power_kw": power, "heating_demand_kwh": round(float(frame["heating_demand"].sum()), 3),
                       "cooling_demand_kwh": round(float(frame["cooling_demand"].sum()), 3),
                       **{k: v for k, v in summaries.get(name, {}).items() if k != "bldg_id"}}
    return notes


def append_building_report(summary: Path, buildings: Mapping[str, dict], selection: Any) -> None:
    """Append the buildings' heating devices, set-point repairs and the selection to ``report/summary.md``."""
    lines = ["", "## Buildings", "",
             "| building | bldg_id | stock heating | heating device | kW | heating / cooling demand kWh | "
             "set points degC (heat / cool) | set-point hours repaired |", "|---|---|---|---|---|---|---|---|"]
    for name, b in buildings.items():
        fuel = b.get("heating_fuel", "")
        stock = f"{b['heating_system']}{f' ({fuel})' if fuel else ''}"
        device = {"heat_pump": "heat pump", "electric_heater": "electric heater", None: "none"}[b["heating_device"]]
        heat, cool = b.get("heating_set_point_c"), b.get("cooling_set_point_c")
        points = f"{heat[0]:.1f}-{heat[1]:.1f} / {cool[0]:.1f}-{cool[1]:.1f}" if heat and cool else "-"
        power = f"{b['heating_power_kw']:.2f}" if b.get("heating_power_kw") is not None else "-"
        lines.append(f"| {name} | {b['bldg_id']} | {stock} | {device}: {b['heating_note']} | {power} | "
                     f"{b['heating_demand_kwh']:.0f} / {b['cooling_demand_kwh']:.0f} | {points} | "
                     f"{b.get('set_point_hours_repaired', '-')} |")
    if any(b.get("set_point_hours_repaired") for b in buildings.values()):
        lines += ["", "Repaired set points: where the stock's heating set point is at or above its cooling set "
                      "point (EnergyPlus refuses it), both move to their mean -/+ 0.5 K."]
    if selection is not None:
        from pipeline.select import format_validity

        k = int(selection.chosen["k"].iloc[0])
        lines += ["", f"## Selection (k = {k}, one building per k-means cluster)", "", "```",
                  format_validity(selection.validity, k), "```"]
    with open(summary, "a") as handle:
        handle.write("\n".join(lines) + "\n")


def build_district_local(config: BuildConfig, output_root: str | Path = "artifacts") -> Path:
    """:func:`run_build` with plain in-process calls (no Prefect)."""
    return run_build(config, output_root, InProcessRunner())


class staging:
    """Context manager: a hidden sibling folder ``.<name>.building-<pid>`` that replaces ``root/<name>`` only
    on success. It only ever creates, renames or deletes what a build created:

    * ``root`` must be a folder (created if missing); ``root/<name>`` may be replaced only when it is a
      districtgen build of the same name (a folder with a ``manifest.json`` naming it), never a symlink;
    * each staging folder has an ownership mark beside it (``.<name>.building-<pid>.districtgen``, JSON with the
      pid); a staging folder whose mark names a process that is gone (a killed build) is deleted on the next
      build of that name, as is a ``.<name>.old-<pid>`` that holds a districtgen build of that name.

    Problems are one :class:`~pipeline.errors.InputError` naming the folder and key ``name``/``output_root``.
    """

    def __init__(self, config: BuildConfig, root: str | Path):
        from pipeline.config import NAME_PATTERN

        if not isinstance(config.name, str) or not re.fullmatch(NAME_PATTERN, config.name):  # model_copy skips it
            raise InputError("not a safe district name (a slug of letters, digits, '_', '-', '.')",
                             file=config.source, column="name")
        self.root, self.name = Path(root), config.name
        self.final = self.root / config.name
        self.tmp = self.root / f".{config.name}.building-{os.getpid()}"
        self.mark = self.tmp.with_name(self.tmp.name + ".districtgen")

    def __enter__(self) -> Path:
        self.check()
        self._clean_stale()
        try:
            self.mark.write_text(json.dumps({"pid": os.getpid(), "district": self.name}))
            self.tmp.mkdir()
        except OSError as error:
            self.mark.unlink(missing_ok=True)
            raise InputError(f"cannot write into the output folder: {error.strerror or error}", file=self.root,
                             column="output_root") from None
        return self.tmp

    def check(self) -> None:
        """Create the output root if missing; refuse a root that is a file and a final folder that is not ours."""
        if self.root.exists() and not self.root.is_dir():
            raise InputError("the output folder is a file", file=self.root, column="output_root")
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError(f"cannot create the output folder: {error.strerror or error}", file=self.root,
                             column="output_root") from None
        if (self.final.exists() or self.final.is_symlink()) and not _is_build(self.final, self.name):
            raise InputError("exists and is not a districtgen build of this name: not replaced (move it away or "
                             "choose another name)", file=self.final, column="name")

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is not None:
                shutil.rmtree(self.tmp, ignore_errors=True)
                return
            old = self.final.with_name(f".{self.final.name}.old-{os.getpid()}")
            if self.final.exists():
                self.final.rename(old)
            self.tmp.rename(self.final)
            shutil.rmtree(old, ignore_errors=True)
        finally:
            self.mark.unlink(missing_ok=True)

    def _clean_stale(self) -> None:
        """Delete what killed builds of this name left: marked staging folders of dead processes, old builds."""
        for mark in self.root.glob(f".{glob.escape(self.name)}.building-*.districtgen"):
            folder = mark.with_name(mark.name[: -len(".districtgen")])
            try:
                pid = int(json.loads(mark.read_text())["pid"])
            except (OSError, ValueError, KeyError, TypeError):
                continue
            if folder.name != f".{self.name}.building-{pid}" or (pid != os.getpid() and _alive(pid)):
                continue
            if folder.is_dir() and not folder.is_symlink():
                shutil.rmtree(folder, ignore_errors=True)
            mark.unlink(missing_ok=True)
        for old in self.root.glob(f".{glob.escape(self.name)}.old-*"):
            if _is_build(old, self.name):
                shutil.rmtree(old, ignore_errors=True)


def _is_build(folder: Path, name: str) -> bool:
    """Whether ``folder`` is a real folder (no symlink) holding a districtgen build of district ``name``."""
    try:
        return (not folder.is_symlink() and folder.is_dir()
                and json.loads((folder / "manifest.json").read_text()).get("district") == name)
    except (OSError, ValueError, AttributeError):
        return False


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _hours(config: BuildConfig) -> int:
    return ((config.period.end - config.period.start).days + 1) * 24


