"""The build's site and table steps: selection, the site's signals (weather, PV yield, prices, carbon), EULP
building tables, sizing and the schema. Pure functions of the typed configuration returning frames/dicts; they
compose the readers of :mod:`pipeline.ingest` (files are read there, not here).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from citylearn_env.dataset import DynamicsBlock, write_table
from citylearn_env.emit import BuildingEntry, schema_document
from citylearn_env.sizing import size_devices
from pipeline.config import BuildConfig
from pipeline.ingest.carbon import read_carbon_intensity
from pipeline.ingest.eulp import citylearn_building, read_eulp_building
from pipeline.ingest.stock import read_eulp_metadata_row
from pipeline.ingest.tariff import citylearn_pricing, read_tariff
from pipeline.ingest.timeindex import period_index
from pipeline.ingest.weather import ForecastSpec, check_weather, citylearn_weather, read_weather_file
from pipeline.pv import site_pv_yield
from pipeline.select import select_from_file

OBSERVATIONS_SHARED = ("month", "day_type", "hour", "outdoor_dry_bulb_temperature",
                       "outdoor_dry_bulb_temperature_predicted_6h", "diffuse_solar_irradiance",
                       "direct_solar_irradiance", "carbon_intensity", "electricity_pricing",
                       "electricity_pricing_predicted_6h")


OBSERVATIONS_BUILDING = ("indoor_dry_bulb_temperature", "non_shiftable_load", "solar_generation",
                         "dhw_storage_soc", "electrical_storage_soc", "net_electricity_consumption",
                         "cooling_demand", "dhw_demand", "occupant_count", "indoor_dry_bulb_temperature_set_point",
                         "indoor_dry_bulb_temperature_delta", "power_outage")


def building_names(config: BuildConfig) -> list[str]:
    return [f"Building_{i}" for i in range(1, len(config.inputs.buildings) + 1)]


def resolve_selection(config: BuildConfig) -> tuple[BuildConfig, Any]:
    """The configuration with ``inputs.buildings`` set from ``[selection]`` (when given; the listed buildings
    otherwise) and the :class:`pipeline.select.Selection` (or None)."""
    if config.selection is None:
        return config, None

    sel = config.selection
    selection = select_from_file(sel.metadata or config.inputs.characteristics, sel.filters, houses=sel.houses,
                                 seed=sel.seed, method=sel.method, max_clusters=sel.max_clusters)
    ids = [int(i) for i in selection.chosen["bldg_id"]]
    return config.model_copy(update={"inputs": config.inputs.model_copy(update={"buildings": ids})}), selection


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

    p, i = config.period, config.inputs
    index = period_index(p.start, p.end)
    frame, meta = read_weather_file(i.weather, tmy_year=index[0].year)
    weather = citylearn_weather(frame, index, ForecastSpec(mode=config.forecast, seed=config.seed), file=i.weather)
    solar = site_pv_yield(frame, meta, tilt=config.pv.tilt, azimuth=config.pv.azimuth, file=i.weather)
    pricing = citylearn_pricing(read_tariff(i.tariff), index)
    carbon = read_carbon_intensity(i.fuel_mix, index, timezone=config.timezone)
    return Signals(weather, pricing, carbon, solar, frame["outdoor_dry_bulb_temperature_c"].astype(float))


_SIGNALS: dict[str, Signals] = {}
_SIGNALS_LOCK = threading.Lock()


def site_signals_once(config: BuildConfig) -> Signals:
    """:func:`site_signals`, computed once per process for a site (weather, period, tariff, fuel mix, PV,
    forecasts): every house task of a worker, and the build process itself, share one copy; concurrent
    callers wait for the first one's."""
    key = config.model_dump_json(include={"inputs", "period", "pv", "forecast", "seed", "timezone"})
    with _SIGNALS_LOCK:
        if key not in _SIGNALS:
            _SIGNALS.clear()  # one site at a time: a process serves one build
            _SIGNALS[key] = site_signals(config)
        return _SIGNALS[key]


def ingest_building(config: BuildConfig, bldg_id: int, solar: pd.Series,
                    weather: pd.Series | None = None) -> pd.DataFrame:
    """One building's CityLearn table from its EULP metadata and timeseries, with the site's PV yield; with
    ``weather`` (the district's outdoor temperature [degC]) the timeseries' own outdoor temperature, when it
    has one, must match it (:func:`pipeline.ingest.weather.check_weather`)."""
    i = config.inputs
    eulp = read_eulp_building(i.eulp, int(bldg_id), upgrade=i.upgrade, state=i.state)
    own = "out.outdoor_air_dryblub_temp.c"
    if weather is not None and own in eulp.series.columns:
        check_weather(eulp.series[own].groupby(eulp.series.index.floor("h")).mean(), weather,
                      what=f"EULP timeseries of building {bldg_id}", file=eulp.series_path)
    return citylearn_building(eulp.loads, period_index(config.period.start, config.period.end),
                              holidays=[d.isoformat() for d in i.holidays], solar_generation=solar,
                              file=eulp.series_path)


def write_tables(out: Path, layout: str, tables: Mapping[str, tuple[str, pd.DataFrame]]) -> None:
    """Write ``{file name: (kind, table)}`` into ``out`` with :func:`citylearn_env.dataset.write_table`."""

    for filename, (kind, table) in tables.items():
        write_table(out / filename, kind, {c: table[c].to_numpy(dtype=float) for c in table.columns}, layout)


def size_buildings(config: BuildConfig, frames: Mapping[str, pd.DataFrame], weather: pd.DataFrame,
                   heating: Mapping[str, str | None] | None = None) -> dict[str, dict]:
    """Device attributes per building (the paper's rules, :func:`citylearn_env.sizing.size_devices`) from the
    in-memory tables; ``heating`` names each building's heating device (None: heating not served)."""

    rules = config.sizing.rules()
    outdoor = weather["outdoor_dry_bulb_temperature"].to_numpy(dtype=float)
    columns = ("cooling_demand", "heating_demand", "dhw_demand", "non_shiftable_load", "solar_generation")
    return {name: size_devices({c: frame[c].to_numpy(dtype=float) for c in columns}, outdoor, rules,
                               heating_device=(heating or {}).get(name))
            for name, frame in frames.items()}


def eulp_metadata_row(config: BuildConfig, bldg_id: int) -> dict[str, object]:
    """The building's EULP metadata row of the district's release (:func:`pipeline.ingest.stock.read_eulp_metadata_row`)."""

    i = config.inputs
    return read_eulp_metadata_row(i.eulp, bldg_id, upgrade=i.upgrade, state=i.state)


def schema_dict(config: BuildConfig, names: list[str], sizes: dict[str, dict],
                dynamics: dict[str, dict] | None) -> dict:
    """The CityLearn schema of the district (file names relative to the schema's folder), written through
    the one schema writer :func:`citylearn_env.emit.schema_document`.

    A building's ``heating_device`` (when sized) is the heat pump itself or an ``ElectricHeater``; with
    surrogates the ``heating_device`` action is active, and inactive in the buildings without one."""

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
        entries, hours=period_hours(config), observations=(*OBSERVATIONS_SHARED, *OBSERVATIONS_BUILDING),
        shared_observations=OBSERVATIONS_SHARED, layout=config.layout, random_seed=config.seed,
        active_actions=actions)


def _resistance(size: Mapping[str, Mapping]) -> bool:
    """A sized heating device without a heating target temperature is an electric (resistance) heater."""
    return "heating_device" in size and "target_heating_temperature" not in size["heating_device"]


def period_hours(config: BuildConfig) -> int:
    return ((config.period.end - config.period.start).days + 1) * 24
