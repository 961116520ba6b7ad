"""Houses from real stock rows: the EnergyPlus pass over the months the district needs (cached), the building
table, the heating device and the per-house notes of the report.
"""

from __future__ import annotations

import calendar
import io
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import pandas as pd

import surrogates
from pipeline.builder.cache import FileCache, cache_key, cache_root, files_digest
from pipeline.builder.manifest import (
    sha256_file,
)
from pipeline.builder.steps import eulp_metadata_row
from pipeline.builder.surrogates import (
    ENERGYPLUS_SOURCES,
    SurrogateFiles,
    ilv_config,
    simulated_months,
    surrogate_files,
)
from pipeline.config import SEED_LIMIT, BuildConfig
from pipeline.errors import InputError
from pipeline.ingest.eulp import citylearn_building
from pipeline.ingest.stock import read_characteristics_row
from pipeline.ingest.timeindex import period_index
from pipeline.progress import report
from surrogates.energyplus.metadata import parse_heating_system
from surrogates.energyplus.occupant_schedules import SCHEDULE_VERSION
from surrogates.sources.energyplus import simulate_house

#: heating system of the stock -> heating device of the schema (``fuel`` and ``none``: simulation.fuel_heating)
HEATING_DEVICE_OF = {"heat_pump": "heat_pump", "electric_resistance": "electric_heater"}


def schedule_repeats(buildings: Sequence[int]) -> list[int]:
    """Per position of the district's ``buildings`` (bldg_ids): how many times that bldg_id came before it
    (0: the row itself, r: its r-th repeat). A repeat draws its occupant schedules with ``[simulation]
    schedule_seed + r`` (:func:`house_config`)."""
    seen: dict[int, int] = {}
    out = []
    for bldg_id in buildings:
        out.append(seen.get(int(bldg_id), 0))
        seen[int(bldg_id)] = out[-1] + 1
    return out


def house_config(config: BuildConfig, repeat: int) -> BuildConfig:
    """The configuration one house is simulated, trained and judged with: ``config`` itself for a row's first
    copy, else its occupant-schedule seed moved on by ``repeat`` (mod 2**32)."""
    if repeat == 0:
        return config
    seed = (config.simulation.schedule_seed + repeat) % SEED_LIMIT
    return config.model_copy(update={"simulation": config.simulation.model_copy(update={"schedule_seed": seed})})


def check_repeats(config: BuildConfig) -> None:
    """Refuse a district that lists a bldg_id twice when its loads come from EULP timeseries (the copies would
    be the same building); simulated houses (``inputs.characteristics``) repeat with their own schedules."""
    repeats = schedule_repeats(config.inputs.buildings or [])
    if config.inputs.eulp is not None and any(repeats):
        position = next(i for i, r in enumerate(repeats) if r)
        raise InputError(f"bldg_id {config.inputs.buildings[position]} repeats (position {position + 1}), but EULP "
                         "buildings have fixed loads: a house repeats only when simulated (inputs.characteristics, "
                         "each copy with its own occupant schedules); ask for at most as many houses as rows",
                         file=config.source, column="selection.houses" if config.selection else "inputs.buildings")


@dataclass(frozen=True)
class HouseSimulation:
    """A simulated house: hourly loads (see :func:`surrogates.energyplus.ilv_runs.hourly_loads`), its ILV table, the
    report summary (heating system, set-point repair), the cache key and whether the cache had it."""

    loads: pd.DataFrame
    ilv: pd.DataFrame
    summary: dict
    key: str
    hit: bool


def simulation_cache_parts(config: BuildConfig, row: Mapping[str, object]) -> dict:
    """What a house's simulation is a function of (the cache key parts): the stock row, the weather file's
    sha256, the calendar year of the period and the months simulated in it (:func:`simulated_months`), the
    simulation settings (with the occupant-schedule seed; not ``fuel_heating``: it acts after the simulation), the time zone (the households'
    clock) and the generator's sources. Not the period's days."""

    package = Path(surrogates.__file__).parent
    return {"row": dict(row), "epw_sha256": sha256_file(Path(config.inputs.weather)), "year": config.period.start.year,
            "run_period": [list(p) for p in simulated_months(config)],
            "simulation": config.simulation.model_dump(exclude={"fuel_heating"}),
            "generator_sha256": files_digest([package / f for f in ENERGYPLUS_SOURCES], package),
            "schedule_version": SCHEDULE_VERSION, "timezone": config.timezone}


def simulate_building(config: BuildConfig, bldg_id: int) -> HouseSimulation:
    """The EnergyPlus pass of one real stock row on the district's weather over :func:`simulated_months`
    (loads + ILV), from the simulation cache (``<cache root>/simulations/<key>``; key: the row, the EPW's
    sha256, the months, the simulation settings and the generator's sources) or simulated and stored."""

    row = read_characteristics_row(config.inputs.characteristics, bldg_id)
    parts = simulation_cache_parts(config, row)
    key = cache_key(parts)
    cache = FileCache(cache_root(config.cache_dir) / "simulations")
    files = cache.get(key)
    if files is not None:
        return HouseSimulation(pd.read_parquet(io.BytesIO(files["loads.parquet"])),
                               pd.read_parquet(io.BytesIO(files["ilv.parquet"])),
                               json.loads(files["house.json"]), key, True)
    loads, table, summary = simulate_house(row, Path(config.inputs.weather), config=ilv_config(config),
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

    (m0, _), (m1, _) = simulated_months(config)
    span = "full year" if (m0, m1) == (1, 12) else "-".join(dict.fromkeys(calendar.month_abbr[m] for m in (m0, m1)))
    report(name, f"simulate (EnergyPlus, {span})")
    simulation = simulate_building(config, bldg_id)
    surrogate = None
    if config.surrogate.source == "energyplus":
        surrogate = surrogate_files(config, bldg_id, name, simulation.ilv)
        simulation = replace(simulation, ilv=simulation.ilv.iloc[:0])  # used: not sent back to the build process
    return HouseWork(simulation, surrogate)


def house_table(config: BuildConfig, simulation: HouseSimulation, solar: pd.Series) -> pd.DataFrame:
    """The CityLearn building table of a simulated house over the period: its ideal-pass loads
    (:func:`surrogates.energyplus.ilv_runs.hourly_loads`, with indoor humidity and both set points) through the one
    table maker of every building, :func:`pipeline.ingest.eulp.citylearn_building`, with the site's PV yield."""
    index = period_index(config.period.start, config.period.end)
    return citylearn_building(simulation.loads, index, holidays=[d.isoformat() for d in config.inputs.holidays],
                              solar_generation=solar, file=f"EnergyPlus house {simulation.summary['bldg_id']}")


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


def eulp_heating_system(config: BuildConfig, bldg_id: int) -> str:
    """The heating system (:func:`surrogates.energyplus.metadata.parse_heating_system`) of an EULP building
    from its metadata (``in.heating_fuel``, ``in.hvac_heating_type_and_fuel``); a heat pump when absent."""

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
