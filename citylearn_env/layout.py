"""The two CityLearn v2 dataset layouts, as column tables.

* ``"v2.1"``: columns are read **by position**; header text is informative only (CityLearn 2.1.x, the version
  behind the SimBuild 2024 results). The carbon file has one column named ``kg_CO2/kWh``.
* ``"v2.2"``: columns are read **by snake_case header name** (CityLearn 2.2 and later). On reading, the
  later aliases ``*_predicted_1/2/3`` (for 6/12/24 h) and ``indoor_dry_bulb_temperature_cooling_set_point``
  are accepted too.

Each table maps our internal name (the v2.2 header) to the v2.1 header text, in file order. Units: energies
in kWh per time step, temperatures in degC, irradiance in W/m2, ``solar_generation`` in W of AC output per kW
of installed PV, prices in $/kWh, carbon intensity in kg CO2e/kWh. ``hour`` is 1..24, hour-ending (row 0 is
hour 1, the hour that ends at 01:00); ``day_type`` is 1 = Monday ... 7 = Sunday, 8 = holiday.
"""

from __future__ import annotations

LAYOUTS = ("v2.1", "v2.2")

#: building ``energy_simulation`` file: internal name -> v2.1 header; True = optional
BUILDING_COLUMNS: dict[str, str] = {
    "month": "Month",
    "hour": "Hour",
    "day_type": "Day Type",
    "daylight_savings_status": "Daylight Savings Status",
    "indoor_dry_bulb_temperature": "Indoor Temperature (C)",
    "average_unmet_cooling_setpoint_difference": "Average Unmet Cooling Setpoint Difference (C)",
    "indoor_relative_humidity": "Indoor Relative Humidity (%)",
    "non_shiftable_load": "Equipment Electric Power (kWh)",
    "dhw_demand": "DHW Heating (kWh)",
    "cooling_demand": "Cooling Load (kWh)",
    "heating_demand": "Heating Load (kWh)",
    "solar_generation": "Solar Generation (W/kW)",
    "occupant_count": "Occupant Count (people)",
    "indoor_dry_bulb_temperature_set_point": "Temperature Set Point (C)",
    "hvac_mode": "HVAC Mode (Off/Cooling/Heating)",
    "power_outage": "Power Outage",
}
#: the first 12 building columns are required; the rest default (occupants 0, set point 0, hvac_mode see schema)
BUILDING_REQUIRED = 12

WEATHER_COLUMNS: dict[str, str] = {
    "outdoor_dry_bulb_temperature": "Outdoor Drybulb Temperature (C)",
    "outdoor_relative_humidity": "Outdoor Relative Humidity (%)",
    "diffuse_solar_irradiance": "Diffuse Solar Radiation (W/m2)",
    "direct_solar_irradiance": "Direct Solar Radiation (W/m2)",
    "outdoor_dry_bulb_temperature_predicted_6h": "6h Outdoor Drybulb Temperature (C)",
    "outdoor_dry_bulb_temperature_predicted_12h": "12h Outdoor Drybulb Temperature (C)",
    "outdoor_dry_bulb_temperature_predicted_24h": "24h Outdoor Drybulb Temperature (C)",
    "outdoor_relative_humidity_predicted_6h": "6h Outdoor Relative Humidity (%)",
    "outdoor_relative_humidity_predicted_12h": "12h Outdoor Relative Humidity (%)",
    "outdoor_relative_humidity_predicted_24h": "24h Outdoor Relative Humidity (%)",
    "diffuse_solar_irradiance_predicted_6h": "6h Diffuse Solar Radiation (W/m2)",
    "diffuse_solar_irradiance_predicted_12h": "12h Diffuse Solar Radiation (W/m2)",
    "diffuse_solar_irradiance_predicted_24h": "24h Diffuse Solar Radiation (W/m2)",
    "direct_solar_irradiance_predicted_6h": "6h Direct Solar Radiation (W/m2)",
    "direct_solar_irradiance_predicted_12h": "12h Direct Solar Radiation (W/m2)",
    "direct_solar_irradiance_predicted_24h": "24h Direct Solar Radiation (W/m2)",
}

PRICING_COLUMNS: dict[str, str] = {
    "electricity_pricing": "Electricity Pricing [$/kWh]",
    "electricity_pricing_predicted_6h": "6h Prediction Electricity Pricing [$/kWh]",
    "electricity_pricing_predicted_12h": "12h Prediction Electricity Pricing [$/kWh]",
    "electricity_pricing_predicted_24h": "24h Prediction Electricity Pricing [$/kWh]",
}

CARBON_COLUMNS: dict[str, str] = {"carbon_intensity": "kg_CO2/kWh"}

#: later-version header aliases accepted when reading the named layout
ALIASES: dict[str, str] = {
    **{
        f"{base}_predicted_{i}": f"{base}_predicted_{h}"
        for base in (
            "outdoor_dry_bulb_temperature",
            "outdoor_relative_humidity",
            "diffuse_solar_irradiance",
            "direct_solar_irradiance",
            "electricity_pricing",
        )
        for i, h in ((1, "6h"), (2, "12h"), (3, "24h"))
    },
    "indoor_dry_bulb_temperature_cooling_set_point": "indoor_dry_bulb_temperature_set_point",
}


def header(columns: dict[str, str], layout: str) -> list[str]:
    """The header row to write for ``columns`` in ``layout`` ("v2.1" or "v2.2")."""
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; known: {', '.join(LAYOUTS)}")
    return list(columns.values()) if layout == "v2.1" else list(columns)
