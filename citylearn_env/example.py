"""A small synthetic district the project generates itself: for tests, demos and ``make run`` fallbacks.

Everything is drawn from simple documented profiles with a seeded generator (no external data):
outdoor temperature 27 +- 6 degC daily sine peaking at 15:00; clear-sky-like irradiance between 06:00 and
20:00; cooling load 0.45 kWh per K above 22 degC; DHW draws in the morning and evening; Austin-style TOU
prices (0.0587 $/kWh weekdays 15:00-18:00, else 0.0289-0.0291); carbon intensity 0.35-0.50 kg/kWh with an
evening peak. Hour h in the files is hour-ending (row 0 = hour 1 = 00:00-01:00).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from citylearn_env.dataset import calendar, write_table
from citylearn_env.emit import BuildingEntry, schema_document, write_schema
from citylearn_env.sizing import SizingRules, size_devices

START = np.datetime64("2018-06-01T00")
#: the example's storage and PV (documented demo values; heat pump, DHW heater and tank follow the sizing rules)
EXAMPLE_BATTERY = {"capacity": 6.5, "nominal_power": 5.0, "efficiency": 0.95, "depth_of_discharge": 0.8,
                   "capacity_loss_coefficient": 1e-5, "loss_coefficient": 1e-4}
SHARED_OBSERVATIONS = ("month", "day_type", "hour", "outdoor_dry_bulb_temperature", "carbon_intensity",
                       "electricity_pricing", "direct_solar_irradiance", "diffuse_solar_irradiance")
OBSERVATIONS = ("month", "day_type", "hour", "outdoor_dry_bulb_temperature", "diffuse_solar_irradiance",
                "direct_solar_irradiance", "carbon_intensity", "indoor_dry_bulb_temperature",
                "non_shiftable_load", "solar_generation", "dhw_storage_soc", "electrical_storage_soc",
                "net_electricity_consumption", "electricity_pricing", "cooling_demand", "dhw_demand",
                "occupant_count", "indoor_dry_bulb_temperature_set_point", "power_outage")
ACTIVE_OBSERVATIONS = (*SHARED_OBSERVATIONS, "non_shiftable_load", "solar_generation", "dhw_storage_soc",
                       "electrical_storage_soc", "net_electricity_consumption", "indoor_dry_bulb_temperature")


def synthetic_series(hours: int, seed: int, n_buildings: int) -> tuple[dict, list[dict], dict, dict]:
    """Weather, per-building loads, pricing and carbon series (all length ``hours``)."""
    rng = np.random.default_rng(seed)
    cal = calendar(START, hours)
    h = cal["hour"] - 0.5  # mid-interval clock hour
    t_out = 27.0 + 6.0 * np.sin(2 * np.pi * (h - 9.0) / 24.0) + rng.normal(0, 0.8, hours)
    sun = np.clip(np.sin(np.pi * (h - 6.0) / 14.0), 0.0, None)
    direct = 750.0 * sun * rng.uniform(0.6, 1.0, hours)
    diffuse = 180.0 * sun
    rh = np.clip(75.0 - 1.5 * (t_out - 27.0) + rng.normal(0, 3, hours), 5.0, 100.0)
    weather = {"outdoor_dry_bulb_temperature": t_out, "outdoor_relative_humidity": rh,
               "diffuse_solar_irradiance": diffuse, "direct_solar_irradiance": direct}
    weather |= {base + "_predicted_" + suffix: np.roll(values, -lag) for base, values in list(weather.items())
                for lag, suffix in ((6, "6h"), (12, "12h"), (24, "24h"))}
    weekday = cal["day_type"] <= 5
    on_peak = weekday & (cal["hour"] >= 16) & (cal["hour"] <= 18)
    mid = weekday & (cal["hour"] >= 8) & ~on_peak & (cal["hour"] <= 22)
    price = np.where(on_peak, 0.0587, np.where(mid, 0.0291, 0.0289))
    pricing = {"electricity_pricing": price, **{f"electricity_pricing_predicted_{s}": np.roll(price, -lag)
                                                for lag, s in ((6, "6h"), (12, "12h"), (24, "24h"))}}
    carbon = {"carbon_intensity": 0.42 + 0.07 * np.sin(2 * np.pi * (h - 14.0) / 24.0)}
    buildings = []
    for b in range(n_buildings):
        scale = 0.8 + 0.2 * b
        cooling = np.clip(0.45 * scale * (t_out - 22.0) + 0.002 * direct + rng.normal(0, 0.1, hours), 0, None)
        draws = np.exp(-0.5 * ((h - 7.5) / 1.0) ** 2) + 0.8 * np.exp(-0.5 * ((h - 19.5) / 1.5) ** 2)
        dhw = np.clip(0.9 * scale * draws + rng.normal(0, 0.03, hours), 0, None)
        nsl = 0.35 * scale + 0.4 * np.exp(-0.5 * ((h - 20.0) / 2.5) ** 2) + rng.uniform(0, 0.1, hours)
        setpoint = np.full(hours, 23.3 + 0.5 * b)
        buildings.append({
            **cal,
            "indoor_dry_bulb_temperature": setpoint + rng.normal(0, 0.05, hours),
            "average_unmet_cooling_setpoint_difference": np.zeros(hours),
            "indoor_relative_humidity": np.full(hours, 50.0),
            "non_shiftable_load": nsl, "dhw_demand": dhw, "cooling_demand": cooling,
            "heating_demand": np.zeros(hours),
            "solar_generation": 800.0 * sun * rng.uniform(0.7, 1.0, hours),
            "occupant_count": np.where((cal["hour"] > 8) & (cal["hour"] < 18) & weekday, 1.0, 3.0),
            "indoor_dry_bulb_temperature_set_point": setpoint,
            "hvac_mode": np.ones(hours),
        })
    return weather, buildings, pricing, carbon


def write_example_district(out_dir: str | Path, *, n_buildings: int = 3, hours: int = 720, seed: int = 0,
                           file_layout: str = "v2.2") -> Path:
    """Write a synthetic district (schema.json + CSVs) into ``out_dir``; return the schema path.

    Each building: a heat pump for cooling, an electric DHW heater with a tank (sized by
    :func:`citylearn_env.sizing.size_devices` with the paper's rules), a 6.5 kWh / 5 kW battery and
    (2 + b) kW of PV for building b = 1, 2, ...; the actions are the DHW tank and the battery (storage
    scheduling, as in the SimBuild DHW/BESS benchmarks). Files are written with
    :func:`citylearn_env.dataset.write_table` and the schema with :mod:`citylearn_env.emit`, as a pipeline
    build writes them.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    weather, buildings, pricing, carbon = synthetic_series(hours, seed, n_buildings)
    write_table(out / "weather.csv", "weather", weather, file_layout)
    write_table(out / "pricing.csv", "pricing", pricing, file_layout)
    write_table(out / "carbon_intensity.csv", "carbon", carbon, file_layout)
    rules = SizingRules()
    entries = []
    for b, data in enumerate(buildings, start=1):
        name = f"Building_{b}"
        write_table(out / f"{name}.csv", "building", data, file_layout)
        devices = size_devices(data, weather["outdoor_dry_bulb_temperature"], rules)
        devices["electrical_storage"] = dict(EXAMPLE_BATTERY)
        devices["pv"] = {"nominal_power": 2.0 + b}
        entries.append(BuildingEntry(name, devices))
    schema = schema_document(entries, hours=hours, observations=OBSERVATIONS,
                             shared_observations=SHARED_OBSERVATIONS, active_observations=ACTIVE_OBSERVATIONS,
                             active_actions=("dhw_storage", "electrical_storage"), layout=file_layout)
    return write_schema(out / "schema.json", schema)
