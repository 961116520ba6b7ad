"""Surrogates across climates: stock rows of every Building America climate zone the stock holds, each house
simulated over a full year on a weather of (or nearest to) its own climate, trained with the build's recipe and
judged on fresh EnergyPlus runs.

    .venv/bin/python benchmarks/surrogate_climates.py [raw/district.toml] [--per-climate 1] [--bldg-ids 73 68]
        [--data /tmp/districtgen_judge] [--set start=random ...] [--wind-input [SHIFT_HOURS]] [--weather NAME]
        [--weather-table]

The configuration gives the stock (``inputs.characteristics``: raw/'s 100 ResStock dwellings), the
``[simulation]`` settings and the ``[surrogate]`` training settings; its period becomes the whole year of its
start (:func:`surrogate_judge.full_year`), so each house trains like a full-year build's house
(:func:`pipeline.builder.surrogates.train_config`: the build's recipe, every month) on the build's ILV data
(:func:`pipeline.builder.surrogates.ilv_config`, the households' clocks in the weather site's time zone) and is
judged like a full-year build's (:func:`surrogates.judge.judge_ilv_config`: 20 timesteps/h, another seed, the
multiplier-1 replay and two unseen partial-load runs of the year, closed loop from each run's first hour;
:func:`surrogate_judge.judge_house` does both). Houses: :data:`HOUSES`, single-family detached and occupied,
none of them a default-district house nor a row the generic start was trained on.

Weathers (:data:`WEATHERS`): Austin TX AMY2018 (raw/, the default district's), Burlington VT AMY2018 (upstream
CityLearn's Vermont county neighbourhood), Albany NY 2012 (ResStock's county CSV G3600010, turned into an EPW on
the 2018 calendar by :func:`albany_epw`), Sand Point AK (pvlib's copy of NREL's TMY3 703165, an EPW on the 2018
calendar by :func:`tmy3_epw`) and the TMY3 EPWs EnergyPlus ships (:func:`reference_houses.package_data_dir`): each
house gets a weather of its own Building America climate, the nearest station (:data:`HOUSES`), except
Mixed-Dry, which has none here (:data:`OWN_WEATHER`). Mixed-Dry (39, Prescott AZ 4B) gets
Oklahoma City: of the available weathers the only one meeting every temperature test of the Mixed-Dry definition
(HDD65 <= 5,400, CDD50 >= 4,500, a month's mean below 45 F; ``--weather-table`` computes them,
:func:`degree_days`); the definition's other test, under 20 in. of rain a year, no file can show (the TMY3
precipitation fields are mostly missing) and Oklahoma City fails it (a humid 3A station), while the dry ones
fail the winter test (Las Vegas, Fresno: no month below 45 F) or the heating one (Colorado: HDD65 over 5,900);
``--weather boulder`` and ``--weather fresno`` judge 39 on the dry stations either side of its climate.
Very Cold (79, Fargo ND, continental) gets Sand Point, a maritime station of the same class (IECC 7 by its
borough; HDD65 9,141 within Very Cold's 9,000-12,600; ``--weather vermont`` judges it on Cold Vermont instead).
The TMY3 files are used as they are: their rows
carry the years of their source months, but the house model's ``RunPeriod`` names 2018 and leaves "treat weather
as actual" at No, so EnergyPlus takes the rows by month and day and the weekdays from 2018 (Monday 1 January;
neither calendar has a 29 February), and the ILV tables read month, day and hour from its output on 2018
(:func:`surrogates.energyplus.sqlite.read_report_variables`); no part of the runs reads the EPW's year.
``--wind-input [SHIFT_HOURS]`` is a trial, not the recipe (:func:`wind_input`): the weather file's wind speed
as one more input, to measure what the houses' closed-loop error owes to a driver no CityLearn observation
carries. One JSON line per house, then a markdown table for benchmarks/README.md and the CPU and load.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pvlib  # noqa: E402
from reference_houses import package_data_dir  # noqa: E402
from surrogate_judge import cpu_model, full_year, judge_house, parse_settings  # noqa: E402

from pipeline.builder.surrogates import ilv_config, train_config  # noqa: E402
from pipeline.config import read_build_config  # noqa: E402
from pipeline.ingest.stock import read_characteristics_row  # noqa: E402
from pipeline.ingest.weather import EPW_HEADER_LINES, read_resstock_weather  # noqa: E402
from surrogates.judge import MEDIAN_BOUND_C, WORST_BOUND_C, JudgeConfig, judge_ilv_config  # noqa: E402

SHARED = ROOT.parent / "shared" / "data"
if not SHARED.is_dir():  # a worktree beside the main checkout: /work/wt/<branch>
    SHARED = Path("/work/shared/data")
VERMONT_EPW = SHARED / "citylearn" / "upstream" / "v2.4.2" / "vt_chittenden_county_neighborhood" / "weather.epw"
ALBANY_CSV = SHARED / "weather" / "G3600010.csv"

#: the weathers by name: what each is and whether it is a climate's own (see :data:`OWN_WEATHER`)
WEATHERS = {
    "austin": "Austin TX (Travis County) AMY2018 EPW, IECC 2A",
    "vermont": "Burlington VT (Chittenden County) AMY2018 EPW, IECC 6A",
    "albany": "Albany NY (Albany County) 2012 ResStock CSV G3600010 as an EPW on the 2018 calendar, IECC 5A",
    "las_vegas": "Las Vegas NV McCarran Intl Ap TMY3 (EnergyPlus's), IECC 3B",
    "phoenix": "Phoenix AZ Sky Harbor Intl Ap TMY3 (EnergyPlus's), IECC 2B",
    "oklahoma_city": "Oklahoma City OK Will Rogers World Ap TMY3 (EnergyPlus's), IECC 3A",
    "newark": "Newark NJ Intl Ap TMY3 (EnergyPlus's), IECC 4A",
    "sterling": "Sterling VA Washington Dulles Intl Ap TMY3 (EnergyPlus's), IECC 4A",
    "san_francisco": "San Francisco CA Intl Ap TMY3 (EnergyPlus's), IECC 3C",
    "chicago": "Chicago IL O'Hare Intl Ap TMY3 (EnergyPlus's), IECC 5A",
    "sand_point": "Sand Point AK TMY3 (pvlib's copy, 703165TY) as an EPW on the 2018 calendar, IECC 7",
    "boulder": "Boulder CO Broomfield-Jefferson County Ap TMY3 (EnergyPlus's), IECC 5B",
    "fresno": "Fresno CA Air Terminal TMY3 (EnergyPlus's), IECC 3B",
}
#: pvlib's copy of NREL's TMY3 of Sand Point AK (Aleutians East Borough, IECC 7: Building America's Very Cold;
#: HDD65 9,141), in the folder ``pvlib/data``
SAND_POINT_TMY3 = "703165TY.csv"
#: :data:`WEATHERS` among the EPWs EnergyPlus ships (pyenergyplus/data/weather), by file name
TMY3 = {"las_vegas": "USA_NV_Las.Vegas-McCarran.Intl.AP.723860_TMY3.epw",
        "phoenix": "USA_AZ_Phoenix-Sky.Harbor.Intl.AP.722780_TMY3.epw",
        "oklahoma_city": "USA_OK_Oklahoma.City-Will.Rogers.World.AP.723530_TMY3.epw",
        "newark": "USA_NJ_Newark.Intl.AP.725020_TMY3.epw",
        "sterling": "USA_VA_Sterling-Washington.Dulles.Intl.AP.724030_TMY3.epw",
        "san_francisco": "USA_CA_San.Francisco.Intl.AP.724940_TMY3.epw",
        "chicago": "USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw",
        "boulder": "USA_CO_Boulder-Broomfield-Jefferson.County.AP.724699_TMY3.epw",
        "fresno": "USA_CA_Fresno.Air.Terminal.723890_TMY3.epw"}
#: the Building America climate zone of each weather's site (its IECC zone as the stock maps it): a house's
#: weather is its own climate's where it is listed under the house's zone; none for Mixed-Dry
OWN_WEATHER = {"Hot-Humid": ("austin",), "Hot-Dry": ("las_vegas", "phoenix"),
               "Mixed-Humid": ("newark", "sterling", "oklahoma_city"), "Marine": ("san_francisco",),
               "Cold": ("vermont", "albany", "chicago"), "Very Cold": ("sand_point",)}
#: (bldg_id, climate zone, weather) by climate, the first of each climate first: occupied single-family
#: detached rows, none of the default district's (8, 21, 43, 47, 61, 69) nor the generic start's
#: (surrogates/data/generic_lstm.json); each on its own climate's nearest station (32 Las Vegas, 57 Phoenix,
#: 84 Yuma -> Phoenix, 94 Islip -> Newark, 63 Lexington and 28 Manassas -> Sterling, 89 Bellingham, 96 San
#: Jose and 82 Santa Rosa -> San Francisco, 68 Albany, 64 Lawrence -> Vermont, 81 Milwaukee -> Chicago; the
#: Hot-Humid rows on Austin; 79 Fargo -> Sand Point), and 39 (Prescott, Mixed-Dry) on Oklahoma City, not its own
#: (module docstring)
HOUSES: tuple[tuple[int, str, str], ...] = (
    (73, "Hot-Humid", "austin"), (90, "Hot-Humid", "austin"), (25, "Hot-Humid", "austin"),
    (32, "Hot-Dry", "las_vegas"), (57, "Hot-Dry", "phoenix"), (84, "Hot-Dry", "phoenix"),
    (39, "Mixed-Dry", "oklahoma_city"),
    (94, "Mixed-Humid", "newark"), (63, "Mixed-Humid", "sterling"), (28, "Mixed-Humid", "sterling"),
    (89, "Marine", "san_francisco"), (96, "Marine", "san_francisco"), (82, "Marine", "san_francisco"),
    (68, "Cold", "albany"), (64, "Cold", "vermont"), (81, "Cold", "chicago"),
    (79, "Very Cold", "sand_point"),
)

#: EPW data-row fields (0-based) :func:`albany_epw` and :func:`tmy3_epw` write
(DRY_BULB, DEW_POINT, HUMIDITY, PRESSURE, EXTRA_HORIZONTAL, EXTRA_NORMAL, INFRARED, GHI, DNI, DHI, GH_ILLUM,
 DN_ILLUM, DH_ILLUM, ZENITH_LUM, WIND_DIR, WIND_SPEED, SKY, OPAQUE_SKY, VISIBILITY, CEILING, PRESENT_FLAG,
 PRESENT_CODES, PRECIPITABLE_WATER, AOD, SNOW, SNOW_DAYS, ALBEDO, RAIN, RAIN_HOURS) = range(6, 35)
#: EPW fields written the same in every row by :func:`albany_epw` and :func:`tmy3_epw`: the horizontal
#: infrared missing (EnergyPlus computes it from the sky cover), no snow on the ground
NO_INFRARED_NO_SNOW = {INFRARED: "9999", SNOW: "0", SNOW_DAYS: "88"}


def epw_column(lines: list[str], field: int) -> np.ndarray:
    """One field (0-based, e.g. :data:`DRY_BULB`) of an EPW's data rows (its text ``lines``), as floats."""
    return np.array([float(line.split(",")[field]) for line in lines[EPW_HEADER_LINES:] if line.strip()])


def degree_days(lines: list[str]) -> dict[str, float]:
    """An EPW's (its text ``lines``) heating and cooling degree days [F day] from its daily mean dry bulb,
    HDD65, CDD50 and CDD65, and its coldest month's mean dry bulb [F]: the temperature tests of the Building
    America climate definitions."""
    fahrenheit = epw_column(lines, DRY_BULB) * 1.8 + 32.0
    months = epw_column(lines, 1).astype(int)
    daily = fahrenheit.reshape(-1, 24).mean(axis=1)
    return {"hdd65": round(float(np.clip(65.0 - daily, 0, None).sum())),
            "cdd50": round(float(np.clip(daily - 50.0, 0, None).sum())),
            "cdd65": round(float(np.clip(daily - 65.0, 0, None).sum())),
            "coldest_month_f": round(float(min(fahrenheit[months == m].mean() for m in set(months))), 1)}


def dew_point_c(dry_bulb_c: np.ndarray, humidity_pct: np.ndarray) -> np.ndarray:
    """Dew point [degC] of air at ``dry_bulb_c`` [degC] and relative humidity ``humidity_pct`` [%] (Magnus
    formula over water, a = 17.625, b = 243.04 degC)."""
    gamma = np.log(np.clip(humidity_pct, 1.0, 100.0) / 100.0) + 17.625 * dry_bulb_c / (243.04 + dry_bulb_c)
    return 243.04 * gamma / (17.625 - gamma)


def sky_cover_tenths(frame: pd.DataFrame) -> np.ndarray:
    """Opaque sky cover [tenths] per hour from each day's diffuse fraction (daily diffuse / global horizontal
    irradiation): 0.2 or less -> 0 (clear), 1 -> 10 (overcast), linear between; the CSV has no cloud field and
    EnergyPlus derives the sky's infrared radiation from this cover where the EPW leaves it missing."""
    daily = frame[["dhi_w_m2", "ghi_w_m2"]].groupby(frame.index.normalize()).transform("sum")
    fraction = (daily["dhi_w_m2"] / daily["ghi_w_m2"].where(daily["ghi_w_m2"] > 0)).fillna(1.0).to_numpy()
    return np.clip(np.round(10 * (fraction - 0.2) / 0.8), 0, 10).astype(int)


def albany_epw(csv: Path, template: Path, folder: Path) -> Path:
    """The ResStock county CSV ``csv`` (Albany 2012, a leap year) as an EPW on ``template``'s calendar (the
    Vermont AMY2018 EPW: 8,760 hour-ending rows from Monday 1 January): 29 February dropped, the other hours in
    order onto the template's rows; dry bulb, humidity, dew point (:func:`dew_point_c`), global, direct normal
    and diffuse irradiance, wind speed and direction from the CSV; sky cover from its diffuse fraction
    (:func:`sky_cover_tenths`), the horizontal infrared left missing (EnergyPlus computes it), no snow; pressure
    and the rest from the template; the header's LOCATION Albany's and its ground temperatures the template's
    shifted by the difference of the two annual mean air temperatures [degC]. Written once under ``folder``,
    named by its content's hash (the ILV cache keys name the file)."""
    frame, _ = read_resstock_weather(csv)
    frame = frame[~((frame.index.month == 2) & (frame.index.day == 29))]
    direction = pd.read_csv(csv, usecols=["date_time", "Wind Direction [Deg]"])
    direction = direction[~direction["date_time"].str.startswith("2012-02-29 ")]["Wind Direction [Deg]"]
    if len(direction) != len(frame):
        raise ValueError(f"{csv}: {len(frame)} hours without 29 February, {len(direction)} wind directions")
    dry_bulb = frame["outdoor_dry_bulb_temperature_c"].to_numpy()
    cover = sky_cover_tenths(frame)
    humidity = frame["outdoor_relative_humidity_pct"].to_numpy()
    columns = {DRY_BULB: dry_bulb, DEW_POINT: dew_point_c(dry_bulb, humidity), HUMIDITY: humidity,
               GHI: frame["ghi_w_m2"].to_numpy(), DNI: frame["dni_w_m2"].to_numpy(), DHI: frame["dhi_w_m2"].to_numpy(),
               WIND_DIR: direction.to_numpy(), WIND_SPEED: frame["wind_speed_m_s"].to_numpy(), SKY: cover,
               OPAQUE_SKY: cover}
    template_mean = float(epw_column(template.read_text().splitlines(), DRY_BULB).mean())
    return epw_on_template(
        columns, NO_INFRARED_NO_SNOW, template, folder, "albany_G3600010_2012_on_2018",
        "LOCATION,Albany County Ap,NY,USA,ResStock G3600010 2012 on 2018,725180,42.75,-73.80,-5.0,89.0",
        "ResStock county weather G3600010 (2012)",
        lambda line: shifted_ground(line, float(dry_bulb.mean()) - template_mean))


def tmy3_epw(csv: Path, template: Path, folder: Path) -> Path:
    """A TMY3 CSV (``csv``: pvlib's copy of NREL's Sand Point AK file, 703165TY) as an EPW on ``template``'s
    2018 calendar: its 8,760 hour-ending local-standard-time rows in order onto the template's (both start at
    1 January 01:00); dry bulb, dew point, humidity, pressure, extraterrestrial, global, direct normal and
    diffuse irradiance, illuminances, wind, total and opaque sky cover, visibility, ceiling height,
    precipitable water, aerosol optical depth and albedo from the TMY3 (a missing visibility as 9999); the
    horizontal infrared left missing (EnergyPlus computes it from the sky cover), no present-weather codes, no
    rain, no snow; the header's LOCATION the station's, its ground temperatures from its own monthly air
    temperatures (:func:`ground_temperatures`), no design conditions or typical periods. Written once under
    ``folder``, named by its content's hash."""
    data, meta = pvlib.iotools.read_tmy3(csv, map_variables=True)
    if len(data) != 8760 or data[["temp_air", "temp_dew", "relative_humidity", "pressure"]].isna().any().any():
        raise ValueError(f"{csv}: {len(data)} rows or missing air fields; a TMY3 year has 8,760 complete rows")
    columns = {DRY_BULB: data["temp_air"], DEW_POINT: data["temp_dew"], HUMIDITY: data["relative_humidity"],
               PRESSURE: data["pressure"] * 100.0, EXTRA_HORIZONTAL: data["ghi_extra"],
               EXTRA_NORMAL: data["dni_extra"], GHI: data["ghi"], DNI: data["dni"], DHI: data["dhi"],
               GH_ILLUM: data["GH illum (lx)"], DN_ILLUM: data["DN illum (lx)"], DH_ILLUM: data["DH illum (lx)"],
               ZENITH_LUM: data["Zenith lum (cd/m^2)"], WIND_DIR: data["wind_direction"],
               WIND_SPEED: data["wind_speed"], SKY: data["TotCld (tenths)"], OPAQUE_SKY: data["OpqCld (tenths)"],
               VISIBILITY: (data["Hvis (m)"] / 1000.0).where(data["Hvis (m)"] >= 0, 9999.0),
               CEILING: data["CeilHgt (m)"],
               PRECIPITABLE_WATER: data["precipitable_water"] * 10.0, AOD: data["AOD (unitless)"],
               ALBEDO: data["albedo"]}
    monthly = data["temp_air"].groupby(data.index.month).mean().to_numpy()
    name = meta["Name"].strip('"').title()
    return epw_on_template(
        {field: np.asarray(values, dtype=float) for field, values in columns.items()},
        {**NO_INFRARED_NO_SNOW, PRESENT_FLAG: "9", PRESENT_CODES: "999999999", RAIN: "0", RAIN_HOURS: "0"},
        template, folder, f"tmy3_{meta['USAF']}",
        f"LOCATION,{name},{meta['State']},USA,TMY3 on 2018,{meta['USAF']},{meta['latitude']:.3f},"
        f"{meta['longitude']:.3f},{meta['TZ']:.1f},{meta['altitude']:.1f}",
        f"NREL TMY3 {meta['USAF']} {name} {meta['State']} (pvlib's copy)",
        lambda line: ground_temperatures(monthly),
        {1: "DESIGN CONDITIONS,0", 2: "TYPICAL/EXTREME PERIODS,0",
         6: "COMMENTS 2,ground temperatures: Kusuda and Achenbach, soil diffusivity "
            f"{SOIL_DIFFUSIVITY_M2_DAY} m2/day"})


def epw_on_template(columns: dict[int, np.ndarray], fixed: dict[int, str], template: Path, folder: Path, stem: str,
                    location: str, source: str, ground: Callable[[str], str],
                    header_lines: dict[int, str] | None = None) -> Path:
    """``template``'s EPW (its calendar and flags) with the data-row ``columns`` (0-based field -> one value
    per row; sky covers as whole tenths, the others to 2 decimals) and the ``fixed`` fields (field -> the text
    of every row) written in; the header's LOCATION line ``location``, COMMENTS 1 naming ``source``, its GROUND
    TEMPERATURES line ``ground(line)`` and any other ``header_lines`` (0-based line -> text). Written once under
    ``folder`` as ``<stem>_<hash>.epw`` (the ILV cache keys name the file)."""
    lines = template.read_text().splitlines()
    header, rows = lines[:EPW_HEADER_LINES], [line.split(",") for line in lines[EPW_HEADER_LINES:] if line.strip()]
    for field, values in columns.items():
        if len(values) != len(rows):
            raise ValueError(f"{source}: {len(values)} hours for EPW field {field}, the template {len(rows)}")
    for i, row in enumerate(rows):
        for field, values in columns.items():
            row[field] = f"{values[i]:.2f}" if field not in (SKY, OPAQUE_SKY) else str(int(round(values[i])))
        for field, text in fixed.items():
            row[field] = text
    header = [ground(line) if line.upper().startswith("GROUND TEMPERATURES") else line for line in header]
    header[0] = location
    header[5] = f"COMMENTS 1,districtgen benchmarks/surrogate_climates.py: {source}"
    for index, line in (header_lines or {}).items():
        header[index] = line
    text = "\n".join([*header, *(",".join(row) for row in rows)]) + "\n"
    path = folder / f"{stem}_{hashlib.sha256(text.encode()).hexdigest()[:12]}.epw"
    if not path.exists():
        folder.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return path


#: soil thermal diffusivity [m2/day]: 0.025 ft2/h, Kusuda's typical soil (the EPW files' header comments give
#: the same number, 2.322576e-3, in m2 per hour but label it per day)
SOIL_DIFFUSIVITY_M2_DAY = 2.322576e-3 * 24.0
#: the day of the year (1 January = 0) in the middle of each month, where the monthly ground temperatures are taken
MID_MONTH_DAYS = np.array([15, 46, 74, 105, 135, 166, 196, 227, 258, 288, 319, 349], dtype=float)


def ground_temperatures(monthly_air_c: np.ndarray, depths_m: tuple[float, ...] = (0.5, 2.0, 4.0)) -> str:
    """An EPW ``GROUND TEMPERATURES`` line from 12 monthly mean air temperatures [degC] (Kusuda and Achenbach):
    at depth z and day t, ``mean - A exp(-z r) cos(2 pi (t - t0) / 365 - z r)`` with ``r = sqrt(pi / (365 a))``
    [1/m], ``a`` :data:`SOIL_DIFFUSIVITY_M2_DAY`, ``A`` half the monthly means' range and ``t0`` the middle
    of the coldest month, evaluated at the middle of each month."""
    days = MID_MONTH_DAYS
    mean, amplitude = float(np.mean(monthly_air_c)), float(np.ptp(monthly_air_c)) / 2.0
    coldest = days[int(np.argmin(monthly_air_c))]
    r = np.sqrt(np.pi / (365.0 * SOIL_DIFFUSIVITY_M2_DAY))
    fields = ["GROUND TEMPERATURES", str(len(depths_m))]
    for z in depths_m:
        t = mean - amplitude * np.exp(-z * r) * np.cos(2 * np.pi * (days - coldest) / 365.0 - z * r)
        fields += [f"{z:g}", "", "", "", *(f"{v:.2f}" for v in t)]
    return ",".join(fields)


def shifted_ground(line: str, shift: float) -> str:
    """An EPW ``GROUND TEMPERATURES`` header line with every depth's 12 monthly temperatures raised by
    ``shift`` [degC] (per depth: depth, conductivity, density, specific heat, then the 12 temperatures)."""
    fields = line.split(",")
    for depth in range(int(fields[1])):
        first = 2 + 16 * depth + 4
        fields[first:first + 12] = [f"{float(v) + shift:.2f}" for v in fields[first:first + 12]]
    return ",".join(fields)


def hourly_wind(epw: Path) -> np.ndarray:
    """The EPW's wind speed [m/s] per hour of the year (index 0: 00:00-01:00 of 1 January): the mean of the
    hour's hour-ending row and the row before it, the alignment the tables' outdoor temperature has with the
    EPW (EnergyPlus interpolates between the rows)."""
    ending = epw_column(epw.read_text().splitlines(), WIND_SPEED)
    return (ending + np.concatenate([ending[:1], ending[:-1]])) / 2.0


def wind_input(recipe, epw: Path, shift_hours: int = 0):
    """A trial (``--wind-input``): the recipe with the weather file's wind speed as one more input (before the
    indoor temperature), and the table transform adding that column ``wind_speed`` [m/s] by the tables' hour
    of year; ``shift_hours`` rolls the series (a placebo: the same values at the wrong hours). Registers the
    column with :mod:`surrogates.ilv` for this process: CityLearn's weather has no wind, so no schema input
    carries it, and the trial is not a recipe."""
    import surrogates.ilv as ilv

    if "wind_speed" not in ilv.OPTIONAL_COLUMNS:
        ilv.OPTIONAL_COLUMNS = (*ilv.OPTIONAL_COLUMNS, "wind_speed")
        ilv.FLOAT_RANGES["wind_speed"] = (0.0, 60.0)
    wind = np.roll(hourly_wind(epw), shift_hours)

    def prepare(table: pd.DataFrame) -> pd.DataFrame:
        stamps = pd.to_datetime(table["timestamp"])
        return table.assign(wind_speed=wind[((stamps.dt.dayofyear - 1) * 24 + stamps.dt.hour).to_numpy()])

    return replace(recipe, inputs=(*recipe.inputs[:-1], "wind_speed", recipe.inputs[-1])), prepare


def chosen(per_climate: int, bldg_ids: list[int] | None) -> list[tuple[int, str, str]]:
    """The houses to judge: ``bldg_ids`` of :data:`HOUSES` in that order, else the first ``per_climate`` of each
    climate, climate by climate."""
    if bldg_ids:
        known = {house[0]: house for house in HOUSES}
        return [known[i] for i in bldg_ids]
    climates = list(dict.fromkeys(climate for _, climate, _ in HOUSES))
    return [house for climate in climates for house in [h for h in HOUSES if h[1] == climate][:per_climate]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=str(ROOT / "raw" / "district.toml"))
    parser.add_argument("--per-climate", type=int, default=1, help="houses of each climate (its first ones)")
    parser.add_argument("--bldg-ids", type=int, nargs="+", choices=[h[0] for h in HOUSES],
                        help="these houses of HOUSES instead")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                        help="TrainConfig settings over the build's recipe (a trial; the table is the recipe's)")
    parser.add_argument("--data", type=Path, default=Path(os.environ.get("TMPDIR", "/tmp")) / "districtgen_judge")
    parser.add_argument("--wind-input", type=int, nargs="?", const=0, metavar="SHIFT_HOURS",
                        help="a trial: the EPW's wind speed as one more input (rolled by SHIFT_HOURS: a placebo)")
    parser.add_argument("--weather", choices=list(WEATHERS),
                        help="judge the chosen houses on this weather instead of their own (a comparison)")
    parser.add_argument("--weather-table", action="store_true",
                        help="print the degree days of the EPWs EnergyPlus ships and of WEATHERS, and stop")
    args = parser.parse_args()
    config = full_year(read_build_config(args.config))
    # the build's: BUILD_RECIPE with the [surrogate] keys, every month (and the trial's --set over it)
    recipe = replace(train_config(config), **parse_settings(args.set))
    # the households' clocks in the weather site's own zone (None: the EPW's), not the district's
    training_ilv = replace(ilv_config(config), timezone=None)
    judge_ilv = judge_ilv_config(training_ilv, JudgeConfig())
    weathers = {"austin": Path(config.inputs.weather), "vermont": VERMONT_EPW,
                "albany": albany_epw(ALBANY_CSV, VERMONT_EPW, args.data),
                "sand_point": tmy3_epw(Path(pvlib.__file__).parent / "data" / SAND_POINT_TMY3, VERMONT_EPW,
                                       args.data),
                **{name: package_data_dir("weather") / file for name, file in TMY3.items()}}
    if args.weather_table:
        own = [weathers[name] for name in ("austin", "vermont", "albany", "sand_point")]
        for path in sorted(package_data_dir("weather").glob("*.epw")) + own:
            print(json.dumps({"epw": path.name, **degree_days(path.read_text().splitlines())}))
        return
    rows = []
    for bldg_id, climate, weather in chosen(args.per_climate, args.bldg_ids):
        weather = args.weather or weather
        row = read_characteristics_row(config.inputs.characteristics, bldg_id)
        if row.get("in.building_america_climate_zone") != climate:
            raise ValueError(f"row {bldg_id} is {row.get('in.building_america_climate_zone')!r}, not {climate!r}")
        trial, prepare = (recipe, None) if args.wind_input is None else wind_input(recipe, weathers[weather],
                                                                                   args.wind_input)
        result = judge_house(row, weathers[weather], training_ilv, judge_ilv, trial, args.data, set(range(1, 13)),
                             prepare)
        line = {"house": bldg_id, "set": args.set, "wind_input": args.wind_input, "climate": climate,
                "state": row.get("in.state"), "weather": weather,
                "own_climate": weather in OWN_WEATHER.get(climate, ()),
                "met": result["median_c"] <= MEDIAN_BOUND_C and result["worst_c"] <= WORST_BOUND_C, **result}
        rows.append(line)
        print(json.dumps(line), flush=True)
    for line in rows:
        print(f"| {line['house']} | {line['climate']} ({line['state']}) | {line['weather']} | "
              f"{line['median_c']:.3f} / {line['worst_c']:.2f} | {line['ideal_mean_abs_c']:.2f} | "
              f"{line['train_cpu_s']:.1f} | {'yes' if line['met'] else '**no**'} |")
    print(json.dumps({"cpu": cpu_model(), "load_average": os.getloadavg(), "recipe": recipe.record()}))


if __name__ == "__main__":
    main()
