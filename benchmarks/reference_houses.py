"""Independent validation houses of the surrogate validation suite (:mod:`surrogate_suite`): EnergyPlus
reference models shipped with ``pyenergyplus-lbnl``, turned into ideal-load-variation (ILV) tables the same
way upstream CityLearn does, but without our parametric house generator (:mod:`surrogates.energyplus.house`
is not used here).

Per model (an IDF of ``pyenergyplus/data/model``, converted to epJSON by the engine's ``--convert-only``):

1. **HVAC-free base** (:func:`hvac_free_model`): only geometry, constructions, materials, schedules,
   internal gains, infiltration, inter-zone mixing, site and algorithm objects are kept (a whitelist of
   object types); air loops, plant loops, zone equipment, thermostats, EMS, refrigeration, sizing,
   natural ventilation (``ZoneVentilation:*``), exhaust fans and every output object are dropped. The
   conditioned zones are the ones the original model served with zone equipment. Ground temperatures
   come from the EPW header (the models' own are for their original city).
2. **Variation** (:func:`apply_variation`): infiltration, window U-factor and internal gains (people,
   lights, electric/gas/other equipment) scaled by the factors of a :class:`ReferenceHouse`.
3. **Ideal pass**: a dual-set-point thermostat (20 / 24 degC) and a sensible-only
   ``ZoneHVAC:IdealLoadsAirSystem`` on every conditioned zone.
4. **Replays** without HVAC: per conditioned zone two convective ``OtherEquipment`` objects (cooling
   design level -1 W, heating +1 W) driven by ``Schedule:File`` columns of ``m(t) x`` the zone's ideal
   load (W >= 0, as EnergyPlus 25.2 requires); ``m`` from
   :func:`surrogates.sources.fmu.load_multipliers`, shared by all zones of the building:

   ======== ============================================================================================
   scheme   multiplier per hour, references >= 2
   ======== ============================================================================================
   upstream U(0.3, 1.7) with probability 0.6, else 1, drawn independently every hour (CityLearn's design)
   held     the same draws, each held for a random block of 1..6 hours (this project's default)
   ======== ============================================================================================

   Reference 0 replays multiplier 1 (the physical check: it must reproduce the ideal run's temperature
   within ``max_replay_mad_c``), reference 1 (free float) is not simulated.

The ILV table has the columns of :mod:`surrogates.ilv` (no set-point column: heating and cooling set points
differ); temperatures are floor-area-weighted over the conditioned zones, occupants the summed zone occupant
count, and the loads the injected heat in kWh per hour, aggregated over the zones as ``SuiteSettings.loads``
says (:func:`aggregate_loads`):

======== ============================================================================================
loads    ``cooling_demand`` / ``heating_demand``
======== ============================================================================================
net      ``clip(cool - heat, 0)`` / ``clip(heat - cool, 0)``: at most one is > 0 in an hour (the default,
         and the aggregation of our own houses' tables and emitted demands, :mod:`surrogates.energyplus.ilv_runs`)
gross    sum of the zones' cooling / sum of the zones' heating (both can be > 0 in one hour: a kitchen
         cooled while the dining room is heated); an ablation: on the fast-food restaurant, the only suite
         house where it matters (14-27 % of hours), it trained worse surrogates (docs/surrogates.md)
======== ============================================================================================

Both aggregations come from the same replays, so one generation writes both tables.

Everything is cached under ``cache_dir`` (one parquet file per house, climate and scheme, written
atomically, plus the converted epJSON), so an interrupted suite resumes where it stopped.
"""

from __future__ import annotations

import copy
import hashlib
import json
import subprocess
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.errors import InputError
from surrogates.energyplus.engine import EnergyPlusError, find_energyplus, run_energyplus
from surrogates.energyplus.epw import read_epw_ground_temperatures
from surrogates.energyplus.ilv_runs import ILVCheckError, write_replay_schedule
from surrogates.energyplus.sqlite import area_weighted, read_report_variables, read_zone_floor_areas
from surrogates.ilv import write_ilv
from surrogates.sources.fmu import load_multipliers

#: object types kept from a reference model (everything else, i.e. HVAC, EMS, outputs, sizing, natural
#: ventilation, refrigeration, exterior equipment, is dropped)
KEEP_TYPES = frozenset({
    "Version", "Building", "GlobalGeometryRules", "Zone", "ZoneList", "Space", "SpaceList",
    "BuildingSurface:Detailed", "FenestrationSurface:Detailed", "Material", "Material:NoMass",
    "Material:AirGap", "Construction", "Construction:FfactorGroundFloor", "Construction:CfactorUndergroundWall",
    "InternalMass", "People", "Lights", "ElectricEquipment", "GasEquipment", "HotWaterEquipment",
    "SteamEquipment", "OtherEquipment", "ZoneInfiltration:DesignFlowRate",
    "ZoneInfiltration:EffectiveLeakageArea", "ZoneInfiltration:FlowCoefficient", "ZoneMixing",
    "ZoneCrossMixing", "Schedule:Compact", "Schedule:Constant", "Schedule:Year", "Schedule:Day:Interval",
    "Schedule:Day:Hourly", "Schedule:Day:List", "Schedule:Week:Daily", "Schedule:Week:Compact",
    "ScheduleTypeLimits", "Site:Location", "Site:GroundReflectance", "HeatBalanceAlgorithm",
    "SurfaceConvectionAlgorithm:Inside", "SurfaceConvectionAlgorithm:Outside", "ZoneAirHeatBalanceAlgorithm",
    "ShadowCalculation", "ConvergenceLimits",
})
KEEP_PREFIXES = ("Shading:", "WindowMaterial:", "WindowProperty:")
MONTHS = ("january", "february", "march", "april", "may", "june", "july", "august", "september", "october",
          "november", "december")
HEATING_SET_POINT_C = 20.0
COOLING_SET_POINT_C = 24.0
#: scheme -> hold_hours of :func:`surrogates.sources.fmu.load_multipliers`
SCHEMES: dict[str, int] = {"upstream": 1, "held": 6}
SITE = "ENVIRONMENT"
#: internal-gain fields scaled by ``gains_factor`` (per object type); ``floor_area_per_person`` is divided
GAIN_FIELDS = ("number_of_people", "people_per_floor_area", "design_level", "watts_per_floor_area",
               "watts_per_person", "power_per_floor_area", "power_per_person", "lighting_level")
GAIN_TYPES = ("People", "Lights", "ElectricEquipment", "GasEquipment", "HotWaterEquipment", "SteamEquipment",
              "OtherEquipment")
INFILTRATION_FIELDS = ("design_flow_rate", "flow_rate_per_floor_area", "flow_rate_per_exterior_surface_area",
                       "air_changes_per_hour")


@dataclass(frozen=True)
class ReferenceHouse:
    """One suite building: a shipped reference model and multiplicative envelope / internal-gain factors.

    ``model``: file stem in ``pyenergyplus/data/model``; ``infiltration_factor`` scales every infiltration
    flow field; ``window_u_factor`` the simple-glazing U-factor (capped at 5.8 W/m2K); ``gains_factor``
    people, lighting and equipment (dimensionless)."""

    name: str
    model: str
    infiltration_factor: float = 1.0
    window_u_factor: float = 1.0
    gains_factor: float = 1.0


#: The suite: four models of two sources (DOE 2004 reference buildings, ASHRAE 90.1-2019 prototypes) and
#: two variations far apart (leaky envelope + 2.5x gains, tight envelope + 0.3x gains).
SUITE_HOUSES: tuple[ReferenceHouse, ...] = (
    ReferenceHouse("office2004", "RefBldgSmallOfficeNew2004_Chicago"),
    ReferenceHouse("office2019", "ASHRAE901_OfficeSmall_STD2019_Denver"),
    ReferenceHouse("quickservice2004", "RefBldgQuickServiceRestaurantNew2004_Chicago"),
    ReferenceHouse("fastfood2019", "ASHRAE901_RestaurantFastFood_STD2019_Denver"),
    ReferenceHouse("office2004_leaky_highgain", "RefBldgSmallOfficeNew2004_Chicago", infiltration_factor=4.0,
                   window_u_factor=1.8, gains_factor=2.5),
    ReferenceHouse("office2019_tight_lowgain", "ASHRAE901_OfficeSmall_STD2019_Denver", infiltration_factor=0.25,
                   gains_factor=0.3),
)


def package_data_dir(kind: str) -> Path:
    """``pyenergyplus/data/<kind>`` (``model`` or ``weather``) of the installed ``pyenergyplus-lbnl``."""
    try:  # imported here: pyenergyplus-lbnl is optional (extra energyplus), its absence is this one error
        import pyenergyplus
    except ImportError:
        raise InputError("the reference models ship with pyenergyplus-lbnl: pip install "
                         "'districtgen[energyplus]'") from None
    return Path(pyenergyplus.__file__).parent / "data" / kind


def reference_idf(model: str) -> Path:
    """Path of a shipped reference model IDF (file stem ``model``)."""
    path = package_data_dir("model") / f"{model}.idf"
    if not path.is_file():
        raise InputError("no such reference model in pyenergyplus/data/model", file=path)
    return path


def read_reference_model(model: str, cache_dir: Path) -> dict:
    """The epJSON dict of a shipped reference model (converted once by ``energyplus --convert-only``,
    cached under ``cache_dir/models``)."""
    idf = reference_idf(model)
    out = Path(cache_dir) / "models"
    target = out / f"{model}.epJSON"
    if not target.is_file():
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=out) as tmp:
            proc = subprocess.run([str(find_energyplus()), "--convert-only", "-d", tmp, str(idf)],
                                  capture_output=True, text=True, timeout=300)
            made = Path(tmp) / f"{model}.epJSON"
            if proc.returncode != 0 or not made.is_file():
                raise EnergyPlusError(f"cannot convert to epJSON: {proc.stdout[-500:]}", file=idf)
            made.replace(target)
    return json.loads(target.read_text())


def hvac_free_model(model: Mapping[str, dict]) -> tuple[dict, list[str]]:
    """(whitelisted copy of ``model``, conditioned zone names). Pure; see the module docstring."""
    zones = sorted({str(v["zone_name"]) for v in model.get("ZoneHVAC:EquipmentConnections", {}).values()})
    if not zones:
        raise InputError("the model has no conditioned zone (no ZoneHVAC:EquipmentConnections)",
                         column="ZoneHVAC:EquipmentConnections")
    kept = {k: copy.deepcopy(v) for k, v in model.items() if k in KEEP_TYPES or k.startswith(KEEP_PREFIXES)}
    return kept, zones


def _scale(objects: Mapping[str, dict], fields: Iterable[str], factor: float) -> None:
    for fields_of in objects.values():
        for field in fields:
            if isinstance(fields_of.get(field), (int, float)):
                fields_of[field] = fields_of[field] * factor


def apply_variation(model: dict, house: ReferenceHouse) -> dict:
    """Scale infiltration, window U-factor and internal gains of an HVAC-free model (returns a copy)."""
    out = copy.deepcopy(model)
    for kind in ("ZoneInfiltration:DesignFlowRate", "ZoneInfiltration:EffectiveLeakageArea",
                 "ZoneInfiltration:FlowCoefficient"):
        _scale(out.get(kind, {}), INFILTRATION_FIELDS + ("effective_air_leakage_area", "flow_coefficient"),
               house.infiltration_factor)
    for glazing in out.get("WindowMaterial:SimpleGlazingSystem", {}).values():
        glazing["u_factor"] = min(5.8, glazing["u_factor"] * house.window_u_factor)
    for kind in GAIN_TYPES:
        _scale(out.get(kind, {}), GAIN_FIELDS, house.gains_factor)
        _scale(out.get(kind, {}), ("floor_area_per_person", "floor_area_per_equipment_level"),
               1.0 / house.gains_factor)
    return out


def _common(model: dict, ground_c: list[float], tph: int, year: int, outputs: list[str],
            frequency: str) -> dict:
    out = copy.deepcopy(model)
    ground = {f"{m}_ground_temperature": float(t) for m, t in zip(MONTHS, ground_c, strict=True)}
    out["Site:GroundTemperature:BuildingSurface"] = {"ground": dict(ground)}
    out["Site:GroundTemperature:FCfactorMethod"] = {"ground": dict(ground)}
    out["SimulationControl"] = {"control": {
        "do_zone_sizing_calculation": "No", "do_system_sizing_calculation": "No",
        "do_plant_sizing_calculation": "No", "run_simulation_for_sizing_periods": "No",
        "run_simulation_for_weather_file_run_periods": "Yes"}}
    out["Timestep"] = {"Timestep 1": {"number_of_timesteps_per_hour": tph}}
    out["RunPeriod"] = {"year": {"begin_month": 1, "begin_day_of_month": 1, "begin_year": year, "end_month": 12,
                                 "end_day_of_month": 31, "end_year": year,
                                 "use_weather_file_holidays_and_special_days": "No",
                                 "use_weather_file_daylight_saving_period": "No"}}
    out["Output:SQLite"] = {"Output:SQLite 1": {"option_type": "Simple"}}
    out["OutputControl:Files"] = {"OutputControl:Files 1": {
        "output_csv": "No", "output_mtr": "No", "output_eso": "No", "output_tabular": "No",
        "output_sqlite": "Yes", "output_json": "No"}}
    out["Output:Variable"] = {f"ilv_output_{i}": {"key_value": "*", "variable_name": name,
                                                  "reporting_frequency": frequency}
                              for i, name in enumerate(outputs)}
    out.setdefault("ScheduleTypeLimits", {})["ilv_any"] = {"numeric_type": "Continuous"}
    return out


BASE_OUTPUTS = ["Zone Mean Air Temperature", "Zone People Occupant Count", "Site Outdoor Air Drybulb Temperature",
                "Site Direct Solar Radiation Rate per Area", "Site Diffuse Solar Radiation Rate per Area"]


def ideal_model(model: dict, zones: list[str], ground_c: list[float], *, tph: int, year: int) -> dict:
    """Ideal-loads variant: dual set point 20/24 degC + sensible-only ideal air system per conditioned zone;
    reports at the zone timestep."""
    out = _common(model, ground_c, tph, year, BASE_OUTPUTS + [
        "Zone Ideal Loads Zone Sensible Cooling Rate", "Zone Ideal Loads Zone Sensible Heating Rate"], "Timestep")
    out.setdefault("Schedule:Constant", {}).update({
        "ilv_heating_set_point": {"schedule_type_limits_name": "ilv_any", "hourly_value": HEATING_SET_POINT_C},
        "ilv_cooling_set_point": {"schedule_type_limits_name": "ilv_any", "hourly_value": COOLING_SET_POINT_C},
        "ilv_dual_control": {"schedule_type_limits_name": "ilv_any", "hourly_value": 4.0}})
    out["ThermostatSetpoint:DualSetpoint"] = {"ilv_dual_set_point": {
        "heating_setpoint_temperature_schedule_name": "ilv_heating_set_point",
        "cooling_setpoint_temperature_schedule_name": "ilv_cooling_set_point"}}
    for kind in ("ZoneControl:Thermostat", "ZoneHVAC:IdealLoadsAirSystem", "ZoneHVAC:EquipmentList",
                 "ZoneHVAC:EquipmentConnections"):
        out[kind] = {}
    for zone in zones:
        system = f"{zone} ideal loads air system"
        out["ZoneControl:Thermostat"][f"{zone} ilv thermostat"] = {
            "zone_or_zonelist_name": zone, "control_type_schedule_name": "ilv_dual_control",
            "control_1_object_type": "ThermostatSetpoint:DualSetpoint", "control_1_name": "ilv_dual_set_point"}
        out["ZoneHVAC:IdealLoadsAirSystem"][system] = {
            "zone_supply_air_node_name": f"{zone} ilv supply", "heating_limit": "NoLimit",
            "cooling_limit": "NoLimit", "dehumidification_control_type": "ConstantSensibleHeatRatio",
            "cooling_sensible_heat_ratio": 1.0, "humidification_control_type": "None"}
        out["ZoneHVAC:EquipmentList"][f"{zone} ilv equipment"] = {"equipment": [{
            "zone_equipment_object_type": "ZoneHVAC:IdealLoadsAirSystem", "zone_equipment_name": system,
            "zone_equipment_cooling_sequence": 1, "zone_equipment_heating_or_no_load_sequence": 1}]}
        out["ZoneHVAC:EquipmentConnections"][f"{zone} ilv connections"] = {
            "zone_name": zone, "zone_conditioning_equipment_list_name": f"{zone} ilv equipment",
            "zone_air_inlet_node_or_nodelist_name": f"{zone} ilv supply",
            "zone_air_node_name": f"{zone} ilv air node", "zone_return_air_node_or_nodelist_name": f"{zone} ilv return"}
    return out


def replay_columns(zones: list[str]) -> list[str]:
    """Column order of the replay schedule CSV: per zone, cooling then heating (W >= 0)."""
    return [f"{zone} ILV {kind}" for zone in zones for kind in ("cool", "heat")]


def replay_model(model: dict, zones: list[str], ground_c: list[float], load_file: Path, *, tph: int,
                 year: int) -> dict:
    """Replay variant: no HVAC, convective ``OtherEquipment`` per conditioned zone from ``load_file``."""
    out = _common(model, ground_c, tph, year, BASE_OUTPUTS + ["Other Equipment Convective Heating Rate"],
                  "Hourly")
    schedules, equipment = out.setdefault("Schedule:File", {}), out.setdefault("OtherEquipment", {})
    for column, name in enumerate(replay_columns(zones), start=1):
        schedules[f"{name} schedule"] = {
            "schedule_type_limits_name": "ilv_any", "file_name": str(load_file), "column_number": column,
            "rows_to_skip_at_top": 1, "number_of_hours_of_data": 8760, "column_separator": "Comma",
            "interpolate_to_timestep": "No", "minutes_per_item": 60 // tph}
        equipment[name] = {"fuel_type": "None", "zone_or_zonelist_or_space_or_spacelist_name": name.split(" ILV ")[0],
                           "schedule_name": f"{name} schedule", "design_level_calculation_method": "EquipmentLevel",
                           "design_level": -1.0 if name.endswith("cool") else 1.0, "fraction_latent": 0.0,
                           "fraction_radiant": 0.0, "fraction_lost": 0.0}
    return out


LOAD_AGGREGATIONS = ("gross", "net")


def aggregate_loads(cool_kwh: np.ndarray, heat_kwh: np.ndarray, loads: str) -> tuple[np.ndarray, np.ndarray]:
    """(cooling, heating) demand in kWh per hour (both >= 0) from the zones' summed cooling and summed heating
    (kWh per hour, >= 0). ``loads="gross"`` returns the sums; ``"net"`` nets them, so that at most one of the
    two is non-zero in an hour. Pure."""
    if loads not in LOAD_AGGREGATIONS:
        raise InputError(f"unknown load aggregation {loads!r}; use one of {list(LOAD_AGGREGATIONS)}",
                         column="loads")
    cool, heat = np.asarray(cool_kwh, dtype=float), np.asarray(heat_kwh, dtype=float)
    if loads == "gross":
        return cool, heat
    return np.clip(cool - heat, 0.0, None), np.clip(heat - cool, 0.0, None)


def net_table(gross: pd.DataFrame) -> pd.DataFrame:
    """The ``loads="net"`` version of an ILV table with gross loads (same rows; only the two load columns
    change). Pure."""
    cooling, heating = aggregate_loads(gross["cooling_demand"].to_numpy(), gross["heating_demand"].to_numpy(),
                                       "net")
    return gross.assign(cooling_demand=cooling, heating_demand=heating)


def parse_replay_hours(frame: pd.DataFrame, reference: int, zones: list[str], areas: Mapping[str, float],
                       loads: str = "gross") -> pd.DataFrame:
    """ILV rows of one hourly replay output (:func:`read_report_variables` frame); temperatures weighted by
    the conditioned zones' floor areas, loads (kWh in the hour) the zones' injected convective heat summed
    per direction and aggregated by :func:`aggregate_loads` (``loads``: "gross" or "net")."""
    begin = frame.index - pd.Timedelta(hours=1)
    other = frame["Other Equipment Convective Heating Rate"].abs()
    cool = sum(other[f"{z} ILV cool".upper()].to_numpy() for z in zones) / 1000.0
    heat = sum(other[f"{z} ILV heat".upper()].to_numpy() for z in zones) / 1000.0
    cooling, heating = aggregate_loads(cool, heat, loads)
    keys = [z.upper() for z in zones]
    temps = frame["Zone Mean Air Temperature"][keys]
    return pd.DataFrame({
        "reference": reference, "timestamp": begin, "month": begin.month.astype("int64"),
        "hour": begin.hour.astype("int64") + 1, "day_type": frame[("day_type", "")].to_numpy(),
        "direct_solar_irradiance": frame[("Site Direct Solar Radiation Rate per Area", SITE)].to_numpy(),
        "diffuse_solar_irradiance": frame[("Site Diffuse Solar Radiation Rate per Area", SITE)].to_numpy(),
        "outdoor_dry_bulb_temperature": frame[("Site Outdoor Air Drybulb Temperature", SITE)].to_numpy(),
        "occupant_count": frame["Zone People Occupant Count"][keys].sum(axis=1).to_numpy(),
        "cooling_demand": cooling, "heating_demand": heating,
        "indoor_dry_bulb_temperature": area_weighted(pd.concat({"t": temps}, axis=1), "t",
                                                     {k: areas[k] for k in keys}).to_numpy(),
    })


def _key(*parts: object) -> str:
    return hashlib.sha256(json.dumps([str(p) for p in parts]).encode()).hexdigest()[:12]


@dataclass(frozen=True)
class SuiteSettings:
    """Generation settings shared by the suite: partial references ``2..2+partial_runs-1``, zone timesteps
    per hour, calendar year (weekdays), multiplier range and probability, base seed, replay check (degC),
    and how the zones' loads are aggregated into the table's two load columns (``loads``: "net", the
    default, or "gross"; see the module docstring).

    ``timesteps_per_hour`` is 4, the reference models' own setting (4; the 2004 office has 6): with 1, the
    suite's first tables, the hourly zone solution carried a white error that no input explains and the
    surrogates of the restaurants could not go below about 0.5 degC (docs/surrogates.md, section 9)."""

    partial_runs: int = 6
    timesteps_per_hour: int = 4
    year: int = 2018
    multiplier_range: tuple[float, float] = (0.3, 1.7)
    probability: float = 0.6
    seed: int = 0
    max_replay_mad_c: float = 0.2
    loads: str = "net"

    def __post_init__(self):
        if self.loads not in LOAD_AGGREGATIONS:  # before any EnergyPlus run
            raise InputError(f"unknown load aggregation {self.loads!r}; use one of {list(LOAD_AGGREGATIONS)}",
                             column="loads")


def settings_text(settings: SuiteSettings) -> str:
    """The text the cache key hashes: the dataclass repr, without ``loads`` when it is "net" (so the net
    tables written before the field existed keep their names)."""
    shown = [f.name for f in fields(settings) if not (f.name == "loads" and settings.loads == "net")]
    return f"SuiteSettings({', '.join(f'{name}={getattr(settings, name)!r}' for name in shown)})"


def table_path(cache_dir: Path, house: ReferenceHouse, climate: str, scheme: str, settings: SuiteSettings) -> Path:
    """Cache file of one ILV table (the name carries a hash of the house and settings)."""
    key = _key(house, settings_text(settings))
    return Path(cache_dir) / "ilv" / f"{house.name}__{climate}__{scheme}__{key}.parquet"


def generate_reference_ilv(house: ReferenceHouse, climate: str, epw: Path, cache_dir: Path,
                           schemes: Iterable[str] = tuple(SCHEMES), settings: SuiteSettings = SuiteSettings()
                           ) -> dict[str, Path]:
    """ILV tables (parquet paths, one per scheme) of ``house`` on weather ``epw``; tables already in the
    cache are reused, missing ones generated (ideal run + multiplier-1 replay + partial replays); a
    generation writes the tables of both load aggregations (``settings.loads`` and the other one).

    Raises :class:`ILVCheckError` when the multiplier-1 replay misses the ideal run's temperature by more
    than ``settings.max_replay_mad_c`` (mean absolute hourly deviation, degC)."""
    cache_dir = Path(cache_dir)
    wanted = {s: table_path(cache_dir, house, climate, s, settings) for s in schemes}
    unknown = [s for s in wanted if s not in SCHEMES]
    if unknown:
        raise InputError(f"unknown multiplier scheme; use one of {sorted(SCHEMES)}", column=unknown[0])
    missing = [s for s, p in wanted.items() if not p.is_file()]
    if not missing:
        return wanted
    base, zones = hvac_free_model(read_reference_model(house.model, cache_dir))
    base = apply_variation(base, house)
    ground = read_epw_ground_temperatures(Path(epw))
    tph, year = settings.timesteps_per_hour, settings.year
    seed = int(_key(house.name, climate)[:6], 16) + settings.seed
    (cache_dir / "runs").mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f"{house.name}_{climate}_", dir=cache_dir / "runs") as tmp:
        tmp = Path(tmp)
        sql = run_energyplus(ideal_model(base, zones, ground, tph=tph, year=year), epw, tmp, "ideal")
        ideal = read_report_variables(sql, year=year, frequency="Zone Timestep")
        areas = read_zone_floor_areas(sql)
        loads = pd.DataFrame({
            f"{z} ILV {kind}": ideal[(f"Zone Ideal Loads Zone Sensible {label} Rate",
                                      f"{z} IDEAL LOADS AIR SYSTEM".upper())]
            for z in zones for kind, label in (("cool", "Cooling"), ("heat", "Heating"))}).clip(lower=0.0)
        hours = len(loads) // tph

        def replay(reference: int, multipliers: np.ndarray) -> pd.DataFrame:
            schedule = tmp / f"loads_{reference}.csv"
            write_replay_schedule(loads, multipliers, schedule, year=year, timesteps_per_hour=tph)
            out = run_energyplus(replay_model(base, zones, ground, schedule, tph=tph, year=year), epw, tmp,
                                 f"replay_{reference}")
            return parse_replay_hours(read_report_variables(out, year=year), reference, zones, areas)

        ideal_run = replay(0, np.ones(hours))
        keys = [z.upper() for z in zones]
        ideal_t = area_weighted(pd.concat({"t": ideal["Zone Mean Air Temperature"][keys]}, axis=1), "t",
                                {k: areas[k] for k in keys}).resample("1h", closed="right", label="right").mean()
        mad = float(np.mean(np.abs(ideal_run["indoor_dry_bulb_temperature"].to_numpy() - ideal_t.to_numpy())))
        if not mad <= settings.max_replay_mad_c:
            raise ILVCheckError(f"multiplier-1 replay deviates from the ideal run by {mad:.3f} C on average",
                                file=epw, row=f"{house.name}/{climate}")
        for scheme in missing:
            frames = [ideal_run]
            for reference in range(2, 2 + settings.partial_runs):
                frames.append(replay(reference, load_multipliers(
                    hours, reference, seed, settings.multiplier_range, settings.probability, SCHEMES[scheme])))
            gross = pd.concat(frames, ignore_index=True)
            for aggregation in LOAD_AGGREGATIONS:  # both aggregations from the same replays
                path = table_path(cache_dir, house, climate, scheme, replace(settings, loads=aggregation))
                if aggregation == settings.loads or not path.is_file():
                    write_ilv(gross if aggregation == "gross" else net_table(gross), path)
    return wanted
