"""The project's parametric single-family house, written as an EnergyPlus epJSON document.

Geometry: a rectangular box, one conditioned thermal zone per story (``story_1`` ...), footprint =
floor area / stories with the front (long) facade ``aspect_ratio`` times the depth, flat insulated roof
over the top story (no attic), slab on grade, windows centred in every wall at the facade
window-to-wall ratio. The building is rotated so the front faces ``front_azimuth_deg``.

Two modes share everything but the HVAC: ``"ideal"`` adds a dual-set-point thermostat and a
``ZoneHVAC:IdealLoadsAirSystem`` (sensible only) per zone; ``"replay"`` has no HVAC and instead two
convective ``OtherEquipment`` objects per zone (``<zone> ILV cool`` with design level -1 W and
``<zone> ILV heat`` with +1 W) driven by ``Schedule:File`` columns in W (values >= 0, as EnergyPlus 25.2
requires).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from surrogates.energyplus.metadata import HouseParameters
from surrogates.energyplus.occupancy import daylight_days
from surrogates.energyplus.occupant_schedules import AWAKE_ACTIVITY_W
from surrogates.energyplus.schedule_file import (
    HOT_WATER_USE_C,
    SCHEDULE_COLUMNS,
    SCHEDULE_DIR,
    house_schedules,
    schedule_peaks,
    write_schedule_file,
)

#: the schedule names that read the ``Schedule:File`` columns :data:`SCHEDULE_COLUMNS`
SCHEDULE_NAMES = ("occupancy", "activity", "lighting", "equipment", "cooking", "dryer", "exterior", "hot_water")
#: vented appliances: (latent, radiant, lost) shares of their electricity; the rest is a convective zone gain.
#: Sensible + latent to the zone after the Building America House Simulation Protocols' appliance gains
#: (range 0.40 + 0.30, vented dryer 0.15 + 0.05); the lost share leaves through the hood or the dryer vent.
#: Outdoor equipment (pool, spa and well pumps) draws electricity with no zone gain: all lost.
VENTED_APPLIANCES = {"cooking": (0.30, 0.20, 0.30), "dryer": (0.05, 0.05, 0.80), "exterior": (0.0, 0.0, 1.0)}
#: Metabolic heat per person (W; the occupant-driven schedules use it for awake occupants), hot-water supply
#: temperature (C; the mixed use temperature is :data:`house_schedules.HOT_WATER_USE_C`), internal-mass area per
#: floor area (m2/m2). Daily water use (``dhw_*_litres``) is at the mixed use temperature.
ACTIVITY_W = AWAKE_ACTIVITY_W
HOT_WATER_SUPPLY_C = 49.0
INTERNAL_MASS_PER_FLOOR = 2.0
#: resistance of an uninsulated stud cavity [m2 K/W]: a closed vertical air space of ~90 mm (ASHRAE
#: Fundamentals' air-space table, ~0.17-0.18 for heat flow across a wall cavity with ordinary surfaces)
EMPTY_CAVITY_R_SI = 0.17

ZONE_OUTPUTS = ["Zone Mean Air Temperature", "Zone Air Relative Humidity", "Zone People Occupant Count",
                "Zone Lights Electricity Rate", "Zone Electric Equipment Electricity Rate"]
SITE_OUTPUTS = ["Site Outdoor Air Drybulb Temperature", "Site Direct Solar Radiation Rate per Area",
                "Site Diffuse Solar Radiation Rate per Area"]
IDEAL_OUTPUTS = ["Zone Ideal Loads Zone Sensible Cooling Rate", "Zone Ideal Loads Zone Sensible Heating Rate",
                 "Zone Thermostat Cooling Setpoint Temperature",
                 "Zone Thermostat Heating Setpoint Temperature"]
REPLAY_OUTPUTS = ["Other Equipment Convective Heating Rate"]
DHW_OUTPUTS = ["Water Use Equipment Heating Rate"]


def zone_names(house: HouseParameters) -> list[str]:
    """Thermal zone names, bottom story first."""
    return [f"story_{i + 1}" for i in range(house.stories)]


def footprint(house: HouseParameters) -> tuple[float, float]:
    """Front width and depth (m) of the rectangular footprint."""
    area = house.floor_area_m2 / house.stories
    width = math.sqrt(area * house.aspect_ratio)
    return width, area / width


def _vertices(points: Sequence[tuple[float, float, float]]) -> list[dict[str, float]]:
    return [{"vertex_x_coordinate": round(x, 4), "vertex_y_coordinate": round(y, 4),
             "vertex_z_coordinate": round(z, 4)} for x, y, z in points]


def _compact(hourly: tuple[list[float], list[float]], year: int, daylight: np.ndarray) -> list[dict[str, object]]:
    """``Schedule:Compact`` fields of hourly (weekday, weekend) values kept by the household's clock, in
    standard time: on the days of ``year`` where ``daylight`` (bool per day) is True each value comes an
    hour earlier."""
    earlier = tuple(values[1:] + values[:1] for values in hourly)
    ends = [day for day in range(len(daylight)) if day == len(daylight) - 1 or daylight[day + 1] != daylight[day]]
    data: list[dict[str, object]] = []
    for end in ends:
        through = dt.date(year, 1, 1) + dt.timedelta(days=end)
        data.append({"field": f"Through: {through.month:d}/{through.day:d}"})
        profile = earlier if daylight[end] else hourly
        for days, values in (("Weekdays SummerDesignDay WinterDesignDay", profile[0]),
                             ("Weekends Holidays CustomDay1 CustomDay2", profile[1])):
            data.append({"field": f"For: {days}"})
            for hour, value in enumerate(values):
                if hour == 23 or values[hour + 1] != value:
                    data += [{"field": f"Until: {hour + 1:02d}:00"}, {"field": float(value)}]
    return data


def house_materials(house: HouseParameters) -> dict[str, dict[str, dict[str, object]]]:
    """The epJSON ``Material``, ``Material:NoMass``, glazing and ``Construction`` objects of ``house`` (its
    insulation R values on fixed bare assemblies; :mod:`surrogates.energyplus.envelope` reads them too)."""

    def mat(thickness, k, rho, cp, absorptance=0.7):
        return {"roughness": "MediumRough", "thickness": thickness, "conductivity": k, "density": rho,
                "specific_heat": cp, "thermal_absorptance": 0.9, "solar_absorptance": absorptance,
                "visible_absorptance": absorptance}

    def nomass(r):
        return {"roughness": "MediumRough", "thermal_resistance": max(r, 0.01)}

    return {
        "Material": {
            "siding": mat(0.02, 0.7, 1800.0, 840.0, 0.6),
            "gypsum": mat(0.0127, 0.16, 800.0, 1090.0, 0.4),
            "roofing": mat(0.012, 0.16, 1120.0, 1460.0, 0.85),
            "plywood": mat(0.0159, 0.12, 540.0, 1210.0),
            "floor_deck": mat(0.025, 0.12, 540.0, 1210.0),
            "slab": mat(0.1, 1.4, 2300.0, 880.0),
            "furnishing": mat(0.025, 0.15, 600.0, 1300.0),
        },
        "Material:NoMass": {
            # cavity insulation (an empty stud cavity is an air space, not R-0) plus ~0.15 m2K/W of
            # sheathing and framing layers in the assembly
            "wall_insulation": nomass(max(house.wall_r_si, EMPTY_CAVITY_R_SI) + 0.15),
            "ceiling_insulation": nomass(house.ceiling_r_si + 0.1),
            # 0.5 m2K/W of soil between the slab and the ground-temperature boundary
            "slab_insulation": nomass(house.slab_r_si + 0.5),
        },
        "WindowMaterial:SimpleGlazingSystem": {
            "glazing": {"u_factor": house.window_u, "solar_heat_gain_coefficient": house.window_shgc,
                        "visible_transmittance": min(0.8, house.window_shgc + 0.1)},
        },
        "Construction": {
            "exterior_wall": {"outside_layer": "siding", "layer_2": "wall_insulation", "layer_3": "gypsum"},
            "roof": {"outside_layer": "roofing", "layer_2": "plywood", "layer_3": "ceiling_insulation",
                     "layer_4": "gypsum"},
            "slab_floor": {"outside_layer": "slab_insulation", "layer_2": "slab"},
            "interior_floor": {"outside_layer": "floor_deck"},
            "window": {"outside_layer": "glazing"},
            "internal_mass": {"outside_layer": "furnishing"},
        },
    }


def _window(name: str, wall: str, p: tuple[float, float], q: tuple[float, float], z0: float,
            height: float, wwr: float) -> dict[str, object] | None:
    length = math.dist(p, q)
    if wwr <= 0:
        return None
    win_h = min(1.2, height - 0.4)
    win_w = wwr * length * height / win_h
    if win_w > length - 0.2:
        win_w = length - 0.2
        win_h = min(height - 0.1, wwr * length * height / win_w)
    s0, s1 = (length - win_w) / 2 / length, (length + win_w) / 2 / length
    zb, zt = z0 + (height - win_h) / 2, z0 + (height + win_h) / 2
    a = (p[0] + s0 * (q[0] - p[0]), p[1] + s0 * (q[1] - p[1]))
    b = (p[0] + s1 * (q[0] - p[0]), p[1] + s1 * (q[1] - p[1]))
    fields: dict[str, object] = {"surface_type": "Window", "construction_name": "window",
                                 "building_surface_name": wall, "number_of_vertices": 4}
    for i, (x, y, z) in enumerate([(*a, zt), (*a, zb), (*b, zb), (*b, zt)], start=1):
        fields.update({f"vertex_{i}_x_coordinate": round(x, 4), f"vertex_{i}_y_coordinate": round(y, 4),
                       f"vertex_{i}_z_coordinate": round(z, 4)})
    return fields


def _geometry(house: HouseParameters) -> dict[str, dict[str, dict[str, object]]]:
    width, depth = footprint(house)
    h = house.story_height_m
    zones, surfaces, windows, masses = {}, {}, {}, {}
    corners = [(0.0, 0.0), (width, 0.0), (width, depth), (0.0, depth)]
    facades = ["front", "right", "back", "left"]
    names = zone_names(house)
    for i, zone in enumerate(names):
        z0, z1 = i * h, (i + 1) * h
        zones[zone] = {"x_origin": 0.0, "y_origin": 0.0, "z_origin": 0.0, "multiplier": 1,
                       "floor_area": round(width * depth, 4)}
        for j, facade in enumerate(facades):
            p, q = corners[j], corners[(j + 1) % 4]
            wall = f"{zone}_{facade}_wall"
            surfaces[wall] = {"surface_type": "Wall", "construction_name": "exterior_wall", "zone_name": zone,
                              "outside_boundary_condition": "Outdoors", "sun_exposure": "SunExposed",
                              "wind_exposure": "WindExposed",
                              "vertices": _vertices([(*p, z1), (*p, z0), (*q, z0), (*q, z1)])}
            if window := _window(f"{wall}_window", wall, p, q, z0, h, house.window_to_wall):
                windows[f"{wall}_window"] = window
        up = [(x, y, z1) for x, y in corners]
        down = [(x, y, z0) for x, y in reversed(corners)]
        if i == 0:
            surfaces[f"{zone}_floor"] = {"surface_type": "Floor", "construction_name": "slab_floor",
                                         "zone_name": zone, "outside_boundary_condition": "Ground",
                                         "sun_exposure": "NoSun", "wind_exposure": "NoWind",
                                         "vertices": _vertices(down)}
        else:
            below = names[i - 1]
            surfaces[f"{zone}_floor"] = {"surface_type": "Floor", "construction_name": "interior_floor",
                                         "zone_name": zone, "outside_boundary_condition": "Surface",
                                         "outside_boundary_condition_object": f"{below}_ceiling",
                                         "sun_exposure": "NoSun", "wind_exposure": "NoWind",
                                         "vertices": _vertices(down)}
        if i == len(names) - 1:
            surfaces[f"{zone}_roof"] = {"surface_type": "Roof", "construction_name": "roof",
                                        "zone_name": zone, "outside_boundary_condition": "Outdoors",
                                        "sun_exposure": "SunExposed",
                                        "wind_exposure": "WindExposed", "vertices": _vertices(up)}
        else:
            surfaces[f"{zone}_ceiling"] = {"surface_type": "Ceiling", "construction_name": "interior_floor",
                                           "zone_name": zone, "outside_boundary_condition": "Surface",
                                           "outside_boundary_condition_object": f"{names[i + 1]}_floor",
                                           "sun_exposure": "NoSun", "wind_exposure": "NoWind",
                                           "vertices": _vertices(up)}
        masses[f"{zone}_mass"] = {"construction_name": "internal_mass", "zone_or_zonelist_name": zone,
                                  "surface_area": round(INTERNAL_MASS_PER_FLOOR * width * depth, 3)}
    return {"Zone": zones, "BuildingSurface:Detailed": surfaces, "FenestrationSurface:Detailed": windows,
            "InternalMass": masses}


def _gains(house: HouseParameters, peaks: dict[str, float]) -> dict[str, dict[str, dict[str, object]]]:
    names = zone_names(house)
    people, lights, equipment, infiltration = {}, {}, {}, {}
    for zone in names:
        people[f"{zone}_people"] = {
            "zone_or_zonelist_or_space_or_spacelist_name": zone,
            "number_of_people_schedule_name": "occupancy",
            "number_of_people_calculation_method": "People",
            "number_of_people": round(peaks["people"] / len(names), 4),
            "fraction_radiant": 0.3, "activity_level_schedule_name": "activity"}
        lights[f"{zone}_lights"] = {
            "zone_or_zonelist_or_space_or_spacelist_name": zone, "schedule_name": "lighting",
            "design_level_calculation_method": "LightingLevel",
            "lighting_level": round(peaks["lighting_w"] / len(names), 3),
            "fraction_radiant": 0.6, "fraction_visible": 0.2, "return_air_fraction": 0.0}
        equipment[f"{zone}_equipment"] = {
            "zone_or_zonelist_or_space_or_spacelist_name": zone, "schedule_name": "equipment",
            "design_level_calculation_method": "EquipmentLevel",
            "design_level": round(peaks["plug_w"] / len(names), 3),
            "fraction_latent": 0.0, "fraction_radiant": 0.3, "fraction_lost": 0.0}
        for kind, (latent, radiant, lost) in VENTED_APPLIANCES.items():
            equipment[f"{zone}_{kind}"] = {
                "zone_or_zonelist_or_space_or_spacelist_name": zone, "schedule_name": kind,
                "design_level_calculation_method": "EquipmentLevel",
                "design_level": round(peaks[f"{kind}_w"] / len(names), 3),
                "fraction_latent": latent, "fraction_radiant": radiant, "fraction_lost": lost}
        infiltration[f"{zone}_infiltration"] = {
            "zone_or_zonelist_or_space_or_spacelist_name": zone, "schedule_name": "always_on",
            "design_flow_rate_calculation_method": "AirChanges/Hour",
            "air_changes_per_hour": round(house.ach_natural, 4), "constant_term_coefficient": 1.0,
            "temperature_term_coefficient": 0.0, "velocity_term_coefficient": 0.0,
            "velocity_squared_term_coefficient": 0.0}
    return {
        "People": people, "Lights": lights, "ElectricEquipment": equipment,
        "ZoneInfiltration:DesignFlowRate": infiltration,
        "WaterUse:Equipment": {"hot_water": {
            "end_use_subcategory": "DHW", "peak_flow_rate": peaks["dhw_m3_s"],
            "flow_rate_fraction_schedule_name": "hot_water",
            "target_temperature_schedule_name": "hot_water_target",
            "hot_water_supply_temperature_schedule_name": "hot_water_supply"}},
        "Site:WaterMainsTemperature": {"Site:WaterMainsTemperature 1": {
            "calculation_method": "CorrelationFromWeatherFile"}},
    }


def _schedules(house: HouseParameters, schedule_file: Path, timesteps_per_hour: int, hours: int, year: int,
               daylight: np.ndarray) -> dict[str, dict[str, dict[str, object]]]:
    def constant(value, limits="any_number"):
        return {"schedule_type_limits_name": limits, "hourly_value": value}

    def from_file(column: str, limits: str) -> dict[str, object]:
        return {"schedule_type_limits_name": limits, "file_name": str(schedule_file),
                "column_number": SCHEDULE_COLUMNS.index(column) + 1, "rows_to_skip_at_top": 1,
                "number_of_hours_of_data": hours, "column_separator": "Comma", "interpolate_to_timestep": "No",
                "minutes_per_item": 60 // timesteps_per_hour}

    cooling, heating, _ = house.setpoints()
    return {
        "ScheduleTypeLimits": {"fraction": {"lower_limit_value": 0.0, "upper_limit_value": 1.0,
                                            "numeric_type": "Continuous"},
                               "any_number": {"numeric_type": "Continuous"}},
        "Schedule:File": {name: from_file(column, "any_number" if name == "activity" else "fraction")
                          for name, column in zip(SCHEDULE_NAMES, SCHEDULE_COLUMNS, strict=True)},
        "Schedule:Constant": {
            "always_on": constant(1.0, "fraction"),
            "hot_water_supply": constant(HOT_WATER_SUPPLY_C), "hot_water_target": constant(HOT_WATER_USE_C),
            "dual_setpoint_control": constant(4.0)},
        "Schedule:Compact": {
            "cooling_setpoint": {"schedule_type_limits_name": "any_number", "data": _compact(cooling, year, daylight)},
            "heating_setpoint": {"schedule_type_limits_name": "any_number", "data": _compact(heating, year, daylight)}},
    }


def _ideal_loads(house: HouseParameters) -> dict[str, dict[str, dict[str, object]]]:
    out: dict[str, dict[str, dict[str, object]]] = {
        "ThermostatSetpoint:DualSetpoint": {"dual_setpoint": {
            "heating_setpoint_temperature_schedule_name": "heating_setpoint",
            "cooling_setpoint_temperature_schedule_name": "cooling_setpoint"}},
        "ZoneControl:Thermostat": {}, "ZoneHVAC:IdealLoadsAirSystem": {}, "ZoneHVAC:EquipmentList": {},
        "ZoneHVAC:EquipmentConnections": {}}
    for zone in zone_names(house):
        out["ZoneControl:Thermostat"][f"{zone}_thermostat"] = {
            "zone_or_zonelist_name": zone, "control_type_schedule_name": "dual_setpoint_control",
            "control_1_object_type": "ThermostatSetpoint:DualSetpoint", "control_1_name": "dual_setpoint"}
        out["ZoneHVAC:IdealLoadsAirSystem"][f"{zone} ideal loads air system"] = {
            "zone_supply_air_node_name": f"{zone}_supply_node", "heating_limit": "NoLimit",
            "cooling_limit": "NoLimit", "dehumidification_control_type": "ConstantSensibleHeatRatio",
            "cooling_sensible_heat_ratio": 1.0,
            "humidification_control_type": "None"}
        out["ZoneHVAC:EquipmentList"][f"{zone}_equipment_list"] = {"equipment": [{
            "zone_equipment_object_type": "ZoneHVAC:IdealLoadsAirSystem",
            "zone_equipment_name": f"{zone} ideal loads air system",
            "zone_equipment_cooling_sequence": 1, "zone_equipment_heating_or_no_load_sequence": 1}]}
        out["ZoneHVAC:EquipmentConnections"][f"{zone}_connections"] = {
            "zone_name": zone, "zone_conditioning_equipment_list_name": f"{zone}_equipment_list",
            "zone_air_inlet_node_or_nodelist_name": f"{zone}_supply_node",
            "zone_air_node_name": f"{zone}_air_node",
            "zone_return_air_node_or_nodelist_name": f"{zone}_return_node"}
    return out


def _replay_loads(house: HouseParameters, load_file: Path, timesteps_per_hour: int
                  ) -> dict[str, dict[str, dict[str, object]]]:
    schedules, equipment = {}, {}
    for k, zone in enumerate(zone_names(house)):
        for j, (kind, sign) in enumerate((("cool", -1.0), ("heat", 1.0))):
            name = f"{zone} ILV {kind}"
            schedules[f"{name} schedule"] = {
                "schedule_type_limits_name": "any_number", "file_name": str(load_file),
                "column_number": 2 * k + j + 1, "rows_to_skip_at_top": 1, "number_of_hours_of_data": 8760,
                "column_separator": "Comma", "interpolate_to_timestep": "No",
                "minutes_per_item": 60 // timesteps_per_hour}
            equipment[name] = {"fuel_type": "None", "zone_or_zonelist_or_space_or_spacelist_name": zone,
                               "schedule_name": f"{name} schedule", "design_level_calculation_method":
                               "EquipmentLevel", "design_level": sign, "fraction_latent": 0.0,
                               "fraction_radiant": 0.0, "fraction_lost": 0.0}
    return {"Schedule:File": schedules, "OtherEquipment": equipment}


def replay_column_names(house: HouseParameters) -> list[str]:
    """Column order of the replay ``Schedule:File`` CSV: per zone, cooling then heating (W, >= 0)."""
    return [f"{zone} ILV {kind}" for zone in zone_names(house) for kind in ("cool", "heat")]


def slab_boundary_c(ground_temperatures_c: Sequence[float]) -> list[float]:
    """The 12 monthly temperatures [C] of the boundary under the slab: the annual mean of the site's undisturbed
    (deep) ground temperatures in every month. The soil under a conditioned slab sits between the house, held
    near its set points all year, and the deep ground; the house damps the annual cycle that the undisturbed
    values carry (Austin's deep ground: 15.5 C in February, 24.2 C in August; the mean, 19.8 C, all year).
    With the undisturbed cycle a slab lost ~1 kW to 15.8 C soil all January and gained heat all summer
    (docs/energyplus.md, "Cooling realism")."""
    mean = sum(float(t) for t in ground_temperatures_c) / len(ground_temperatures_c)
    return [round(mean, 3)] * len(ground_temperatures_c)


def build_house_model(house: HouseParameters, *, mode: str, ground_temperatures_c: Sequence[float],
                      run_period: tuple[tuple[int, int], tuple[int, int]] = ((1, 1), (12, 31)),
                      year: int = 2018, timesteps_per_hour: int = 6, reporting_frequency: str = "Hourly",
                      load_file: Path | None = None, dhw: bool = True, schedule_seed: int = 0,
                      latitude_deg: float = 35.0, mains_mean_c: float = 20.0, schedule_dir: Path | None = None,
                      clock_zone: str | None = None) -> dict[str, object]:
    """The epJSON document (a dict) of ``house`` in ``mode`` ``"ideal"`` or ``"replay"``.

    ``ground_temperatures_c``: 12 monthly undisturbed ground temperatures (C; the slab's boundary is
    :func:`slab_boundary_c` of them); ``run_period``:
    ((begin month, day), (end month, day)) in calendar ``year`` (sets the weekdays); ``reporting_frequency``:
    ``"Hourly"`` or ``"Timestep"``; ``load_file``: the replay CSV (see :func:`replay_column_names`).
    People, lighting, plug loads and hot water follow the occupant-driven schedules of the whole ``year``
    (:func:`house_schedules` with ``schedule_seed``, ``latitude_deg`` and the annual mean mains temperature
    ``mains_mean_c`` [C]), written as a ``Schedule:File`` CSV
    into ``schedule_dir`` (default: the replay CSV's folder, else :data:`SCHEDULE_DIR`).
    The simulation keeps standard time all year; the schedules and the thermostat's set-point offsets follow
    the households' clock in IANA time zone ``clock_zone`` (None: standard time all year), so they come an
    hour earlier while its clocks show daylight time.
    """
    if mode not in ("ideal", "replay"):
        raise ValueError(f"mode must be 'ideal' or 'replay', got {mode!r}")
    if len(ground_temperatures_c) != 12:
        raise ValueError("need 12 monthly ground temperatures")
    (m0, d0), (m1, d1) = run_period
    months = ["january", "february", "march", "april", "may", "june", "july", "august", "september",
              "october", "november", "december"]
    model: dict[str, object] = {
        "Version": {"Version 1": {"version_identifier": "25.2"}},
        "Building": {"house": {"north_axis": (house.front_azimuth_deg - 180.0) % 360.0, "terrain": "Suburbs",
                               "solar_distribution": "FullExterior", "maximum_number_of_warmup_days": 25,
                               "minimum_number_of_warmup_days": 6}},
        "SimulationControl": {"SimulationControl 1": {
            "do_zone_sizing_calculation": "No", "do_system_sizing_calculation": "No",
            "do_plant_sizing_calculation": "No", "run_simulation_for_sizing_periods": "No",
            "run_simulation_for_weather_file_run_periods": "Yes"}},
        "Timestep": {"Timestep 1": {"number_of_timesteps_per_hour": timesteps_per_hour}},
        "RunPeriod": {"run": {"begin_month": m0, "begin_day_of_month": d0, "begin_year": year,
                              "end_month": m1, "end_day_of_month": d1, "end_year": year,
                              "use_weather_file_holidays_and_special_days": "No",
                              "use_weather_file_daylight_saving_period": "No"}},
        "GlobalGeometryRules": {"GlobalGeometryRules 1": {"starting_vertex_position": "UpperLeftCorner",
                                                          "vertex_entry_direction": "Counterclockwise",
                                                          "coordinate_system": "Relative"}},
        "Site:GroundTemperature:BuildingSurface": {"Site:GroundTemperature:BuildingSurface 1": {
            f"{month}_ground_temperature": float(t) for month, t in zip(months, slab_boundary_c(ground_temperatures_c),
                                                                        strict=True)}},
        "Output:SQLite": {"Output:SQLite 1": {"option_type": "Simple"}},
        "OutputControl:Files": {"OutputControl:Files 1": {
            "output_csv": "No", "output_mtr": "No", "output_eso": "No", "output_tabular": "No",
            "output_sqlite": "Yes", "output_json": "No"}},
    }
    schedules = house_schedules(house, year, timesteps_per_hour, schedule_seed, latitude_deg, mains_mean_c,
                                clock_zone)
    folder = schedule_dir or (Path(load_file).parent if load_file is not None else SCHEDULE_DIR)
    schedule_file = write_schedule_file(house, folder, year, timesteps_per_hour, schedule_seed, latitude_deg,
                                        mains_mean_c, clock_zone)
    daylight = daylight_days(year, clock_zone)
    hours = len(schedules.people) // timesteps_per_hour
    for part in (house_materials(house), _geometry(house), _gains(house, schedule_peaks(house, schedules)),
                 _schedules(house, schedule_file, timesteps_per_hour, hours, year, daylight)):
        model.update(part)
    if not dhw:
        model.pop("WaterUse:Equipment")
    outputs = ZONE_OUTPUTS + SITE_OUTPUTS + (DHW_OUTPUTS if dhw else [])
    if mode == "ideal":
        model.update(_ideal_loads(house))
        outputs = outputs + IDEAL_OUTPUTS
    else:
        if load_file is None:
            raise ValueError("replay mode needs load_file")
        replay = _replay_loads(house, load_file, timesteps_per_hour)
        model["Schedule:File"] = {**model["Schedule:File"], **replay["Schedule:File"]}
        model["OtherEquipment"] = replay["OtherEquipment"]
        outputs = outputs + REPLAY_OUTPUTS
    model["Output:Variable"] = {f"output_{i}": {"key_value": "*", "variable_name": name,
                                                "reporting_frequency": reporting_frequency}
                                for i, name in enumerate(outputs)}
    return model
