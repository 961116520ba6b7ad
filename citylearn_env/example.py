"""A small synthetic district the project generates itself: for tests, demos and ``make run`` fallbacks.

Everything is drawn from simple documented profiles with a seeded generator (no external data):
outdoor temperature 27 +- 6 degC daily sine peaking at 15:00; clear-sky-like irradiance between 06:00 and
20:00; cooling load 0.45 kWh per K above 22 degC; DHW draws in the morning and evening; Austin-style TOU
prices (0.0587 $/kWh weekdays 15:00-18:00, else 0.0289-0.0291); carbon intensity 0.35-0.50 kg/kWh with an
evening peak. Hour h in the files is hour-ending (row 0 = hour 1 = 00:00-01:00).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from citylearn_env import layout

START = np.datetime64("2018-06-01T00")


def _calendar(hours: int) -> dict[str, np.ndarray]:
    stamps = START + np.arange(hours).astype("timedelta64[h]")
    days = stamps.astype("datetime64[D]")
    weekday = (days.astype(np.int64) - 4) % 7  # 1970-01-01 was a Thursday; 0 = Monday
    month = stamps.astype("datetime64[M]").astype(np.int64) % 12 + 1
    hour_of_day = (stamps - days).astype(np.int64)
    return {"month": month.astype(float), "hour": hour_of_day + 1.0, "day_type": weekday + 1.0,
            "daylight_savings_status": np.zeros(hours)}


def synthetic_series(hours: int, seed: int, n_buildings: int) -> tuple[dict, list[dict], dict, dict]:
    """Weather, per-building loads, pricing and carbon series (all length ``hours``)."""
    rng = np.random.default_rng(seed)
    cal = _calendar(hours)
    h = cal["hour"] - 0.5  # mid-interval clock hour
    t_out = 27.0 + 6.0 * np.sin(2 * np.pi * (h - 9.0) / 24.0) + rng.normal(0, 0.8, hours)
    sun = np.clip(np.sin(np.pi * (h - 6.0) / 14.0), 0.0, None)
    direct = 750.0 * sun * rng.uniform(0.6, 1.0, hours)
    diffuse = 180.0 * sun
    rh = np.clip(75.0 - 1.5 * (t_out - 27.0) + rng.normal(0, 3, hours), 5.0, 100.0)
    weather = {"outdoor_dry_bulb_temperature": t_out, "outdoor_relative_humidity": rh,
               "diffuse_solar_irradiance": diffuse, "direct_solar_irradiance": direct}
    for base in list(weather):
        for lag, suffix in ((6, "6h"), (12, "12h"), (24, "24h")):
            weather[f"{base}_predicted_{suffix}"] = np.roll(weather[base], -lag)
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


def _write_csv(path: Path, columns: dict[str, str], data: dict[str, np.ndarray], file_layout: str) -> None:
    names = [n for n in columns if n in data]
    head = layout.header({n: columns[n] for n in names}, file_layout)
    matrix = np.column_stack([data[n] for n in names])
    tmp = path.with_suffix(".tmp")
    np.savetxt(tmp, matrix, delimiter=",", header=",".join(head), comments="", fmt="%.10g")
    os.replace(tmp, path)


def write_example_district(out_dir: str | Path, *, n_buildings: int = 3, hours: int = 720, seed: int = 0,
                           file_layout: str = "v2.2") -> Path:
    """Write a synthetic district (schema.json + CSVs) into ``out_dir``; return the schema path.

    Each building: a heat pump for cooling, an electric DHW heater with a tank, a battery and PV; the
    actions are the DHW tank and the battery (storage scheduling, as in the SimBuild DHW/BESS benchmarks).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    weather, buildings, pricing, carbon = synthetic_series(hours, seed, n_buildings)
    _write_csv(out / "weather.csv", layout.WEATHER_COLUMNS, weather, file_layout)
    _write_csv(out / "pricing.csv", layout.PRICING_COLUMNS, pricing, file_layout)
    _write_csv(out / "carbon_intensity.csv", layout.CARBON_COLUMNS, carbon, file_layout)
    spec = {}
    for b, data in enumerate(buildings, start=1):
        name = f"Building_{b}"
        _write_csv(out / f"{name}.csv", layout.BUILDING_COLUMNS, data, file_layout)
        cop_peak = 0.25 * (8.0 + 273.15) / (float(weather["outdoor_dry_bulb_temperature"].max()) - 8.0)
        spec[name] = {
            "type": "citylearn.building.Building", "include": True,
            "energy_simulation": f"{name}.csv", "weather": "weather.csv", "pricing": "pricing.csv",
            "carbon_intensity": "carbon_intensity.csv",
            "cooling_device": {"type": "citylearn.energy_model.HeatPump", "attributes": {
                "nominal_power": round(float(data["cooling_demand"].max()) / cop_peak, 3), "efficiency": 0.25,
                "target_cooling_temperature": 8.0, "target_heating_temperature": 45.0}},
            "dhw_device": {"type": "citylearn.energy_model.ElectricHeater", "attributes": {
                "nominal_power": round(float(data["dhw_demand"].max()) / 0.9, 3), "efficiency": 0.9}},
            "dhw_storage": {"type": "citylearn.energy_model.StorageTank", "attributes": {
                "capacity": round(float(data["dhw_demand"].max()) / 2, 3), "loss_coefficient": 0.004}},
            "electrical_storage": {"type": "citylearn.energy_model.Battery", "attributes": {
                "capacity": 6.5, "nominal_power": 5.0, "efficiency": 0.95, "depth_of_discharge": 0.8,
                "capacity_loss_coefficient": 1e-5, "loss_coefficient": 1e-4}},
            "pv": {"type": "citylearn.energy_model.PV", "attributes": {"nominal_power": 2.0 + b}},
        }
    shared = {"month", "day_type", "hour", "outdoor_dry_bulb_temperature", "carbon_intensity",
              "electricity_pricing", "direct_solar_irradiance", "diffuse_solar_irradiance"}
    active = shared | {"non_shiftable_load", "solar_generation", "dhw_storage_soc", "electrical_storage_soc",
                       "net_electricity_consumption", "indoor_dry_bulb_temperature"}
    names = ["month", "day_type", "hour", "outdoor_dry_bulb_temperature", "diffuse_solar_irradiance",
             "direct_solar_irradiance", "carbon_intensity", "indoor_dry_bulb_temperature",
             "non_shiftable_load", "solar_generation", "dhw_storage_soc", "electrical_storage_soc",
             "net_electricity_consumption", "electricity_pricing", "cooling_demand", "dhw_demand",
             "occupant_count", "indoor_dry_bulb_temperature_set_point", "power_outage"]
    schema = {
        "root_directory": None, "central_agent": True,
        "simulation_start_time_step": 0, "simulation_end_time_step": hours - 1,
        "episode_time_steps": None, "rolling_episode_split": False, "random_episode_split": False,
        "seconds_per_time_step": 3600.0,
        "observations": {n: {"active": n in active, "shared_in_central_agent": n in shared} for n in names},
        "actions": {"cooling_storage": {"active": False}, "heating_storage": {"active": False},
                    "dhw_storage": {"active": True}, "electrical_storage": {"active": True},
                    "cooling_device": {"active": False}, "heating_device": {"active": False}},
        "reward_function": {"type": "citylearn.reward_function.RewardFunction", "attributes": {}},
        "buildings": spec,
    }
    path = out / "schema.json"
    path.write_text(json.dumps(schema, indent=2))
    return path
