"""A house-year of the parametric house written in the EULP (ResStock) 15-minute timeseries layout.

The ideal-loads run (4 timesteps per hour) gives delivered loads and zone temperatures; electricity is
derived with fixed efficiencies (engineering assumptions, documented in raw/README.md): central heat pump
cooling COP :data:`COOLING_COP`, heating COP :data:`HEATING_COP`, electric storage water heater efficiency
:data:`WATER_HEATER_EFFICIENCY`. Fans, pumps and latent (dehumidification) loads are not modelled.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from surrogates.energyplus.engine import run_energyplus
from surrogates.energyplus.epw import read_epw_ground_temperatures
from surrogates.energyplus.house import build_house_model, zone_names
from surrogates.energyplus.metadata import HouseParameters
from surrogates.energyplus.sqlite import area_weighted, read_report_variables, read_zone_floor_areas

KWH_PER_KBTU = 0.29307107017222
COOLING_COP = 3.5
HEATING_COP = 2.8
WATER_HEATER_EFFICIENCY = 0.92
TIMESTEPS_PER_HOUR = 4


def simulate_eulp_timeseries(house: HouseParameters, epw: Path, *, year: int = 2018,
                             workdir: Path | None = None) -> pd.DataFrame:
    """15-minute EULP-layout timeseries of ``house`` for calendar ``year`` on weather ``epw``.

    Columns: ``timestamp`` (END of each 15-min interval, local standard time), ``bldg_id``,
    ``out.electricity.<end use>.energy_consumption`` [kWh per interval] for cooling, heating, hot_water,
    lighting_interior, plug_loads and total, ``out.site_energy.total.energy_consumption`` [kWh],
    ``out.load.{cooling,heating,hot_water}.energy_delivered.kbtu`` [kBtu per interval],
    ``out.zone_mean_air_temp.conditioned_space.c`` and ``out.outdoor_air_dryblub_temp.c`` (NREL's
    spelling) [C].
    """
    model = build_house_model(house, mode="ideal", ground_temperatures_c=read_epw_ground_temperatures(epw),
                              year=year, timesteps_per_hour=TIMESTEPS_PER_HOUR,
                              reporting_frequency="Timestep")
    with tempfile.TemporaryDirectory(prefix="eulp_", dir=workdir) as tmp:
        sql = run_energyplus(model, Path(epw), Path(tmp), "baseline")
        frame = read_report_variables(sql, year=year, frequency="Zone Timestep")
        areas = read_zone_floor_areas(sql)
    kwh = 1.0 / TIMESTEPS_PER_HOUR / 1000.0  # W averaged over one timestep -> kWh
    keys = [f"{zone} IDEAL LOADS AIR SYSTEM".upper() for zone in zone_names(house)]
    cooling = frame["Zone Ideal Loads Zone Sensible Cooling Rate"][keys].sum(axis=1).to_numpy() * kwh
    heating = frame["Zone Ideal Loads Zone Sensible Heating Rate"][keys].sum(axis=1).to_numpy() * kwh
    hot_water = frame["Water Use Equipment Heating Rate"].sum(axis=1).to_numpy() * kwh
    lighting = frame["Zone Lights Electricity Rate"].sum(axis=1).to_numpy() * kwh
    plug = frame["Zone Electric Equipment Electricity Rate"].sum(axis=1).to_numpy() * kwh
    electricity = {
        "cooling": cooling / COOLING_COP,
        "heating": heating / HEATING_COP,
        "hot_water": hot_water / WATER_HEATER_EFFICIENCY,
        "lighting_interior": lighting,
        "plug_loads": plug,
    }
    electricity["total"] = np.sum(list(electricity.values()), axis=0)
    out = {"timestamp": frame.index.to_numpy(), "bldg_id": np.full(len(frame), house.bldg_id, dtype=np.int64)}
    for end_use, values in electricity.items():
        out[f"out.electricity.{end_use}.energy_consumption"] = values
    out["out.site_energy.total.energy_consumption"] = electricity["total"]
    out["out.load.cooling.energy_delivered.kbtu"] = cooling / KWH_PER_KBTU
    out["out.load.heating.energy_delivered.kbtu"] = heating / KWH_PER_KBTU
    out["out.load.hot_water.energy_delivered.kbtu"] = hot_water / KWH_PER_KBTU
    out["out.zone_mean_air_temp.conditioned_space.c"] = area_weighted(
        frame, "Zone Mean Air Temperature", areas).to_numpy()
    outdoor = frame[("Site Outdoor Air Drybulb Temperature", "ENVIRONMENT")]
    out["out.outdoor_air_dryblub_temp.c"] = outdoor.to_numpy()
    table = pd.DataFrame(out)
    floats = [c for c in table.columns if c.startswith("out.")]
    table[floats] = table[floats].astype(np.float32)
    return table
