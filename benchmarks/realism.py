"""Realism benchmark: the houses of a built district against real EULP-derived houses of the same climate and
season.

Real reference (read in place from ``../shared/data/citylearn``): the Austin TX single-family homes of the
CityLearn 2023 challenge (ResStock/End-Use Load Profiles dwellings re-simulated in EnergyPlus by the
CityLearn authors; June-August, hourly), in both published layouts (v2.4.2 named columns, v2.1.2 positional
columns). The datasets repeat the same homes: house-months are de-duplicated by content, which leaves the six
phase-3 homes (June-August, their evaluation weather) and three of them again in phase 1 (June, Austin AMY
2018 weather, the same weather as the default district). The 2022 challenge sets (Fontana CA, no cooling
or heating columns) and the 2020/2021 sets (DOE prototype buildings) are not EULP houses of this climate and
are not used; the EULP county neighbourhoods are not in ../shared (only their building ids).

The real sets carry no floor area (neither schema nor CSV), so the per-m2 statistics have no real band; the
benchmark adds the absolute monthly cooling energy, which has one.

Built houses: a built district folder (``artifacts/<name>/``: schema.json, the building CSVs and
buildings.json for the floor areas), or ``--simulate``: the district's houses simulated directly (one
EnergyPlus ideal-loads pass over the period per house, no ILV replays, no training), from the district TOML,
the stock rows of the folder's selection.csv (or ``inputs.buildings``) and the current house model.

Months of a season with real house-months are compared with them; a district with several months per house
gets one column per house (its median over the months and how many of them are in the real band); months of
a season without real house-months (the real homes cover June-August) are reported without a band.

Statistics per house and month (:mod:`pipeline.realism`): hourly DHW peak [kWh], hourly plug-load
(``non_shiftable_load``) peak [kWh], cooling and heating [kWh/m2], cooling [kWh], daily load factor of the
electric-equivalent total, and the L1 distance of the normalised hour-of-day profile of that total to the
real median profile.

Usage::

    .venv/bin/python benchmarks/realism.py                       # artifacts/default (the make-run district)
    .venv/bin/python benchmarks/realism.py --district artifacts/default --simulate raw/district.toml
    .venv/bin/python benchmarks/realism.py --simulate raw/district.toml --schedule-seeds 1 2 3 4
    .venv/bin/python benchmarks/realism.py --same-month      # real June house-months only (for a June district)
    .venv/bin/python benchmarks/realism.py --simulate raw/district.toml --own-row   # + each row's own year
                                                                              # and heat-loss coefficient
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pipeline.realism import (  # noqa: E402
    cooling_degree_days,
    daily_load_factor,
    electric_equivalent_kwh,
    energy_per_area_kwh_m2,
    hour_of_day_profile,
    hourly_peak_kwh,
    in_band,
    median_profile,
    median_ratio_pct,
    percentile_band,
    profile_l1_distance,
)
from surrogates.energyplus.end_uses import END_USE_GROUPS  # noqa: E402

CITYLEARN = ROOT.parent / "shared" / "data" / "citylearn"
#: where the 2023 challenge datasets lie under the citylearn data folder (both layouts and a plain copy)
REAL_DATASETS = ("upstream/v2.4.2/citylearn_challenge_2023_*", "upstream/v2.1.2/citylearn_challenge_2023_*",
                 "citylearn_challenge_2023_*")
DEFAULT_DISTRICT = ROOT / "artifacts" / "default"
#: the v2.1 positional layout: column index of each named column
V21_POSITIONS = {"month": 0, "hour": 1, "non_shiftable_load": 7, "dhw_demand": 8, "cooling_demand": 9,
                 "heating_demand": 10}
LOAD_COLUMNS = ["month", "hour", "non_shiftable_load", "dhw_demand", "cooling_demand", "heating_demand"]
SEASONS = {12: "DJF", 1: "DJF", 2: "DJF", 3: "MAM", 4: "MAM", 5: "MAM", 6: "JJA", 7: "JJA", 8: "JJA",
           9: "SON", 10: "SON", 11: "SON"}
#: statistic key -> (label, decimals)
STATISTICS = {
    "dhw_peak_kwh": ("hourly DHW peak [kWh]", 2),
    "plug_peak_kwh": ("hourly plug-load peak [kWh]", 2),
    "cooling_kwh": ("cooling in the month [kWh]", 0),
    "heating_kwh": ("heating in the month [kWh]", 0),
    "cooling_kwh_m2": ("cooling [kWh/m2 month]", 2),
    "heating_kwh_m2": ("heating [kWh/m2 month]", 2),
    "daily_load_factor": ("daily load factor (mean/peak) [-]", 3),
    "profile_l1": ("hour-of-day shape, L1 to real median [-]", 3),
}


@dataclass
class HouseMonth:
    """One house's hourly loads in one month (CityLearn columns, kWh per hour) and its statistics."""

    name: str
    month: int
    loads: pd.DataFrame
    floor_area_m2: float | None = None
    stats: dict[str, float] = field(default_factory=dict)


def read_building_csv(path: Path) -> pd.DataFrame:
    """A CityLearn building CSV in either layout -> :data:`LOAD_COLUMNS`."""
    frame = pd.read_csv(path)
    if "cooling_demand" in frame.columns:
        return frame[LOAD_COLUMNS]
    return pd.DataFrame({name: frame.iloc[:, i] for name, i in V21_POSITIONS.items()})[LOAD_COLUMNS]


def split_months(name: str, loads: pd.DataFrame, floor_area_m2: float | None = None) -> list[HouseMonth]:
    """One :class:`HouseMonth` per month present with at least 28 whole days of hours."""
    return [HouseMonth(name, int(month), part.reset_index(drop=True), floor_area_m2)
            for month, part in loads.groupby("month", sort=False) if len(part) >= 28 * 24]


def fingerprint(item: HouseMonth) -> tuple[float, ...]:
    """What identifies a house-month across dataset copies and layouts (which differ in float formatting):
    the month and each load column's monthly total rounded to 0.1 kWh."""
    sums = item.loads[["non_shiftable_load", "dhw_demand", "cooling_demand", "heating_demand"]].sum()
    return (float(item.month), *(round(float(v), 1) for v in sums))


def real_datasets(root: Path = CITYLEARN) -> list[Path]:
    """The 2023 challenge dataset folders under ``root`` (:data:`REAL_DATASETS`, in that order, each sorted)."""
    return [folder for pattern in REAL_DATASETS for folder in sorted(root.glob(pattern)) if folder.is_dir()]


def real_house_months(root: Path = CITYLEARN, season: str = "JJA") -> list[HouseMonth]:
    """De-duplicated house-months of the 2023 challenge homes (Austin TX, ResStock single-family) in
    ``season``, from every copy of the datasets under ``root``."""
    files = [path for folder in real_datasets(root) for path in sorted(folder.glob("Building_*.csv"))]
    seen: dict[tuple[float, ...], HouseMonth] = {}
    for path in files:
        for item in split_months(f"{path.parent.name}/{path.stem}", read_building_csv(path)):
            if SEASONS[item.month] != season:
                continue
            seen.setdefault(fingerprint(item), item)
    return list(seen.values())


def real_weather_months(root: Path = CITYLEARN) -> dict[int, list[np.ndarray]]:
    """The outdoor dry-bulb temperatures [degC] of the 2023 challenge homes' weather, per calendar month:
    month -> one array per distinct weather (every dataset copy carries its own weather.csv, most the same)."""
    seen: dict[tuple[int, float], np.ndarray] = {}
    for folder in real_datasets(root):
        if not (folder / "weather.csv").is_file() or not (folder / "Building_1.csv").is_file():
            continue
        weather = pd.read_csv(folder / "weather.csv")
        months = read_building_csv(folder / "Building_1.csv")["month"].to_numpy()
        column = "outdoor_dry_bulb_temperature" if "outdoor_dry_bulb_temperature" in weather else weather.columns[0]
        temperature = weather[column].to_numpy(dtype=float)[: len(months)]
        for month in np.unique(months):
            values = temperature[months[: len(temperature)] == month]
            if len(values) >= 28 * 24:
                seen.setdefault((int(month), round(float(values.sum()), 1)), values)
    out: dict[int, list[np.ndarray]] = {}
    for (month, _), values in seen.items():
        out.setdefault(month, []).append(values)
    return out


def built_weather_months(config_path: Path | None, district: Path) -> dict[int, list[np.ndarray]]:
    """The built district's outdoor dry-bulb temperatures [degC] per calendar month: the configuration's EPW
    (``--simulate``) or the district folder's weather.csv (months from its first building's table)."""
    if config_path is not None:
        from pipeline.config import read_build_config
        from pipeline.ingest.weather import read_epw

        config = read_build_config(config_path)
        frame, _ = read_epw(config.inputs.weather, tmy_year=config.period.start.year)
        temperature = frame["outdoor_dry_bulb_temperature_c"]
        period = (temperature.index.date >= config.period.start) & (temperature.index.date <= config.period.end)
        temperature = temperature[period]
        months, values = temperature.index.month.to_numpy(), temperature.to_numpy(dtype=float)
    else:
        schema = json.loads((district / "schema.json").read_text())
        first = next(iter(schema["buildings"].values()))
        months = read_building_csv(district / first["energy_simulation"])["month"].to_numpy()
        weather = pd.read_csv(district / "weather.csv")
        values = weather["outdoor_dry_bulb_temperature"].to_numpy(dtype=float)[: len(months)]
    return {int(m): [values[months == m]] for m in np.unique(months) if (months == m).sum() >= 28 * 24}


def weather_line(built: dict[int, list[np.ndarray]], built_months: set[int], real: dict[int, list[np.ndarray]],
                 real_months: set[int]) -> str:
    """One line: the mean outdoor temperature [degC] and cooling degree-days per 30 days [K day, 18.3 degC base]
    of the built house-months' weather (``built_months``) and of the real ones' (``real_months``): cooling
    compares weathers as much as houses."""
    def summary(by_month: dict[int, list[np.ndarray]], months: set[int]) -> tuple[float, float]:
        series = [v for m in sorted(months) for v in by_month.get(m, [])]
        if not series:
            return float("nan"), float("nan")
        return (float(np.mean([v.mean() for v in series])),
                float(np.mean([cooling_degree_days(v) * 30.0 * 24 / len(v) for v in series])))

    (built_t, built_cdd), (real_t, real_cdd) = summary(built, built_months), summary(real, real_months)
    ratio = f" ({(built_cdd / real_cdd - 1) * 100:+.0f} %)" if real_cdd > 0 else ""
    return (f"weather, cooling degree-days (18.3 degC base) per 30 days: real (months {sorted(real_months)}) "
            f"{_fmt(real_cdd, 0)}, mean {_fmt(real_t, 1)} degC; built (months {sorted(built_months)}) "
            f"{_fmt(built_cdd, 0)}{ratio}, mean {_fmt(built_t, 1)} degC")


def built_house_months(district: Path) -> list[HouseMonth]:
    """The house-months of a built district folder (schema.json building CSVs; floor areas from
    buildings.json when present)."""
    schema = json.loads((district / "schema.json").read_text())
    info_path = district / "buildings.json"
    info = json.loads(info_path.read_text()) if info_path.is_file() else {}
    out = []
    for name, building in schema["buildings"].items():
        area = info.get(name, {}).get("floor_area_m2")
        out += split_months(name, read_building_csv(district / building["energy_simulation"]), area)
    return out


def _district_houses(config, district: Path | None) -> list[tuple[str, int]]:
    """(building name, stock bldg_id) of the district: its folder's selection.csv, else ``inputs.buildings``."""
    if district is not None and (district / "selection.csv").is_file():
        selection = pd.read_csv(district / "selection.csv")
        return list(zip(selection["building"], selection["bldg_id"], strict=True))
    if config.inputs.buildings:
        return [(f"Building_{i + 1}", b) for i, b in enumerate(config.inputs.buildings)]
    raise SystemExit("--simulate needs the district folder's selection.csv or inputs.buildings")


def _ideal_loads(config, row: dict, run_period, year: int, schedule_seed: int = 0) -> tuple[pd.DataFrame, object]:
    """One EnergyPlus ideal-loads pass of a stock row (the build's house model and timestep; the build's
    schedules at ``schedule_seed`` 0, other draws of the same method otherwise): (hourly loads of
    :func:`surrogates.energyplus.ilv_runs.hourly_loads`, the house parameters)."""
    from surrogates.energyplus.engine import run_energyplus
    from surrogates.energyplus.epw import read_epw_ground_temperatures, read_epw_latitude, read_epw_mains_mean
    from surrogates.energyplus.house import build_house_model
    from surrogates.energyplus.ilv_runs import hourly_loads
    from surrogates.energyplus.metadata import house_parameters_from_metadata
    from surrogates.energyplus.sqlite import read_report_variables, read_zone_floor_areas

    epw = Path(config.inputs.weather)
    house = house_parameters_from_metadata(row)
    model = build_house_model(house, mode="ideal", ground_temperatures_c=read_epw_ground_temperatures(epw),
                              run_period=run_period, year=year,
                              timesteps_per_hour=config.simulation.timesteps_per_hour,
                              reporting_frequency="Timestep", latitude_deg=read_epw_latitude(epw),
                              mains_mean_c=read_epw_mains_mean(epw), schedule_seed=schedule_seed,
                              clock_zone=config.timezone)
    with tempfile.TemporaryDirectory(prefix="realism_") as tmp:
        sql = run_energyplus(model, epw, Path(tmp), "ideal")
        ideal = read_report_variables(sql, year=year, frequency="Zone Timestep")
        areas = read_zone_floor_areas(sql)
    return hourly_loads(ideal, areas, house), house


def simulated_house_months(config_path: Path, district: Path | None, schedule_seed: int = 0) -> list[HouseMonth]:
    """The district's houses simulated now (ideal-loads pass over the configured period, current model;
    occupant schedules drawn with ``schedule_seed``, 0 = the build's)."""
    from pipeline.config import read_build_config
    from pipeline.ingest.stock import read_characteristics_row

    config = read_build_config(config_path)
    out = []
    for name, bldg_id in _district_houses(config, district):
        row = read_characteristics_row(config.inputs.characteristics, bldg_id)
        out += simulated_house(config, name, row, schedule_seed)
    return out


def simulated_house(config, name: str, row: dict, schedule_seed: int = 0) -> list[HouseMonth]:
    """One house's ideal-loads pass over ``config``'s period (:func:`_ideal_loads`), split into months."""
    start, end = config.period.start, config.period.end
    loads, house = _ideal_loads(config, row, ((start.month, start.day), (end.month, end.day)), start.year,
                                schedule_seed)
    frame = pd.DataFrame({"month": loads.index.month, "hour": loads.index.hour + 1,
                          "non_shiftable_load": loads["non_shiftable_load_kwh"].to_numpy(),
                          "dhw_demand": loads["dhw_demand_kwh"].to_numpy(),
                          "cooling_demand": loads["cooling_demand_kwh"].to_numpy(),
                          "heating_demand": loads["heating_demand_kwh"].to_numpy()})
    return split_months(name, frame, house.floor_area_m2)


def _stock_kwh(column: str):
    """The stock row's annual ``column`` [MBtu] in kWh (NaN when the row does not carry it)."""
    from surrogates.energyplus.end_uses import KWH_PER_MBTU

    return lambda raw, uses: float(raw[column]) * KWH_PER_MBTU if column in raw.index else float("nan")


def _end_uses_kwh(*groups: str):
    """The house's own end uses of ``groups`` (:class:`surrogates.energyplus.end_uses.EndUses`) in kWh/year."""
    return lambda raw, uses: sum(getattr(uses, g) for g in groups) * 365.0 if uses else float("nan")


#: the stock row's own annual results compared with a full-year ideal pass: (our column, the row's kWh/year
#: from (the raw stock row, the house's end uses), label); the building's electricity is every end-use group
OWN_ROW = (("cooling_demand_kwh", _stock_kwh("report_simulation_output.load_cooling_delivered_m_btu"), "cooling"),
           ("heating_demand_kwh", _stock_kwh("report_simulation_output.load_heating_delivered_m_btu"), "heating"),
           ("dhw_demand_kwh", _end_uses_kwh("dhw_delivered"), "hot water"),
           ("non_shiftable_load_kwh", _end_uses_kwh(*END_USE_GROUPS), "plug + lighting"))


#: the stock row's Manual J heating design loads [Btu/h] by component (buildstockbatch results layout)
DESIGN_LOAD_COLUMN = "report_simulation_output.hvac_design_load_heating_{}_btu_h"
DESIGN_TEMPERATURE_COLUMN = "report_simulation_output.hvac_design_temperature_heating_f"
WEATHER_CITY_COLUMN = "build_existing_model.weather_file_city"


def stock_row_heat_loss(raw: pd.Series):
    """The row's heat-loss coefficients (:func:`surrogates.energyplus.envelope.stock_heat_loss`), or None when
    the row carries no design loads."""
    from surrogates.energyplus.envelope import stock_heat_loss

    if DESIGN_TEMPERATURE_COLUMN not in raw.index or not np.isfinite(float(raw[DESIGN_TEMPERATURE_COLUMN])):
        return None
    loads = {k: float(raw.get(DESIGN_LOAD_COLUMN.format(k), 0.0))
             for k in ("walls", "doors", "windows", "ceilings", "roofs", "infiltration_ventilation")}
    loads["infiltration"] = loads.pop("infiltration_ventilation")
    return stock_heat_loss(loads, float(raw[DESIGN_TEMPERATURE_COLUMN]))


def own_row_table(config_path: Path, district: Path | None) -> str:
    """Markdown table: each house's full-year ideal pass (calendar year of the period, the district's weather)
    against the annual results ResStock published for the same row [kWh/year], which were simulated on the
    row's own weather (named in the table with its heating design temperature), and the climate-independent
    heat-loss coefficient [W/K] of the house model against the row's Manual J design loads. ResStock's
    delivered loads count latent heat and duct losses, our ideal loads are sensible zone loads."""
    from pipeline.config import read_build_config
    from pipeline.ingest.stock import read_characteristics_row
    from surrogates.energyplus.envelope import house_heat_loss

    config = read_build_config(config_path)
    stock = pd.read_parquet(config.inputs.characteristics)
    id_column = "bldg_id" if "bldg_id" in stock.columns else "building_id"
    header = ["house", "bldg_id", "row's weather (heating design F)",
              *(f"{label}: ours / stock's [kWh]" for *_, label in OWN_ROW),
              "heat loss w/o slab, ducts: ours / stock's [W/K]"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, bldg_id in _district_houses(config, district):
        row = read_characteristics_row(config.inputs.characteristics, bldg_id)
        loads, house = _ideal_loads(config, row, ((1, 1), (12, 31)), config.period.start.year)
        raw = stock[stock[id_column] == bldg_id].iloc[0]
        weather = (f"{raw[WEATHER_CITY_COLUMN]} ({float(raw[DESIGN_TEMPERATURE_COLUMN]):.0f})"
                   if WEATHER_CITY_COLUMN in raw.index and DESIGN_TEMPERATURE_COLUMN in raw.index else "n/a")
        cells = [weather]
        for ours, stock_kwh, _label in OWN_ROW:
            theirs, mine = stock_kwh(raw, house.end_uses), float(loads[ours].sum())
            ratio = f" ({mine / theirs:.2f}x)" if theirs > 0 else ""
            cells.append(f"{mine:,.0f} / {theirs:,.0f}{ratio}")
        theirs_ua, mine_ua = stock_row_heat_loss(raw), house_heat_loss(house)
        cells.append(f"{mine_ua.total:,.0f} / {theirs_ua.total:,.0f} ({mine_ua.total / theirs_ua.total:.2f}x)"
                     if theirs_ua else f"{mine_ua.total:,.0f} / n/a")
        lines.append(f"| {name} | {bldg_id} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def total_kwh(loads: pd.DataFrame) -> pd.Series:
    """The electric-equivalent total of a house-month's loads [kWh per hour]."""
    return electric_equivalent_kwh(loads["non_shiftable_load"], loads["cooling_demand"], loads["heating_demand"],
                                   loads["dhw_demand"])


def fill_statistics(items: list[HouseMonth], reference_profile: np.ndarray) -> None:
    """Compute every statistic of :data:`STATISTICS` for each house-month (in place)."""
    for item in items:
        loads, area = item.loads, item.floor_area_m2
        total = total_kwh(loads)
        item.stats = {
            "dhw_peak_kwh": hourly_peak_kwh(loads["dhw_demand"]),
            "plug_peak_kwh": hourly_peak_kwh(loads["non_shiftable_load"]),
            "cooling_kwh": float(loads["cooling_demand"].sum()),
            "heating_kwh": float(loads["heating_demand"].sum()),
            "cooling_kwh_m2": energy_per_area_kwh_m2(loads["cooling_demand"], area) if area else float("nan"),
            "heating_kwh_m2": energy_per_area_kwh_m2(loads["heating_demand"], area) if area else float("nan"),
            "daily_load_factor": daily_load_factor(total),
            "profile_l1": profile_l1_distance(hour_of_day_profile(total, loads["hour"]), reference_profile),
        }


def _fmt(value: float, decimals: int) -> str:
    return "n/a" if not np.isfinite(value) else f"{value:,.{decimals}f}"


def realism_table(built: list[HouseMonth], real: list[HouseMonth]) -> tuple[str, dict[str, object]]:
    """The markdown table (one row per statistic) and a summary: houses in band and medians within 25 %."""
    names = [f"{b.name}" + (f" m{b.month}" if len({x.month for x in built}) > 1 else "") for b in built]
    header = ["statistic", "real 5 %", "real median", "real 95 %", *names, "built median vs real"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    summary: dict[str, object] = {}
    for key, (label, decimals) in STATISTICS.items():
        band = percentile_band([r.stats[key] for r in real])
        values = [b.stats[key] for b in built]
        cells = []
        flags = []
        for value in values:
            flag = in_band(value, band)
            flags.append(flag)
            cells.append(f"{_fmt(value, decimals)} " + {True: "yes", False: "**no**", None: "-"}[flag])
        ratio = median_ratio_pct(values, band[1])
        ratio_cell = "n/a" if not np.isfinite(ratio) else f"{ratio:+.0f} %"
        lines.append("| " + " | ".join([label, *(_fmt(v, decimals) for v in band), *cells, ratio_cell]) + " |")
        summary[key] = {"band": band, "values": values, "in_band": flags, "median_vs_real_pct": ratio}
    return "\n".join(lines), summary


def house_names(items: list[HouseMonth]) -> list[str]:
    """The houses of ``items`` in first-seen order."""
    return list(dict.fromkeys(item.name for item in items))


def per_house_table(built: list[HouseMonth], real: list[HouseMonth] | None) -> str:
    """Markdown table of a district with several months per house: per statistic and house the median over
    its months and, against ``real`` (None: no real reference), how many of its months are in the real
    5-95 % band; the last column: the median over all house-months against the real median."""
    names = house_names(built)
    header = ["statistic", *(["real 5 %", "real median", "real 95 %"] if real else []), *names,
              *(["built median vs real"] if real else [])]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for key, (label, decimals) in STATISTICS.items():
        band = percentile_band([r.stats[key] for r in real]) if real else None
        cells = []
        for name in names:
            values = [b.stats[key] for b in built if b.name == name]
            cell = _fmt(float(np.median(values)), decimals)
            flags = [in_band(v, band) for v in values] if band else [None]
            if None not in flags:
                cell += f" ({sum(flags)}/{len(flags)})"
            cells.append(cell)
        if band is None:
            lines.append("| " + " | ".join([label, *cells]) + " |")
            continue
        ratio = median_ratio_pct([b.stats[key] for b in built], band[1])
        ratio_cell = "n/a" if not np.isfinite(ratio) else f"{ratio:+.0f} %"
        lines.append("| " + " | ".join([label, *(_fmt(v, decimals) for v in band), *cells, ratio_cell]) + " |")
    return "\n".join(lines)


def seed_table(runs: dict[int, list[HouseMonth]], real: list[HouseMonth]) -> str:
    """How often each built house is inside the real 5-95 % band over schedule draws: one row per statistic,
    per house "k/n" (draws in band), and the range over draws of the built median against the real one."""
    seeds = sorted(runs)
    first = runs[seeds[0]]
    names = [b.name + (f" m{b.month}" if len({x.month for x in first}) > 1 else "") for b in first]
    header = ["statistic", *names, "built median vs real (min..max)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for key, (label, _) in STATISTICS.items():
        band = percentile_band([r.stats[key] for r in real])
        if in_band(first[0].stats[key], band) is None:
            continue
        hits = np.zeros(len(first), dtype=int)
        ratios = []
        for seed in seeds:
            values = [b.stats[key] for b in runs[seed]]
            hits += [bool(in_band(v, band)) for v in values]
            ratios.append(median_ratio_pct(values, band[1]))
        cells = [f"{h}/{len(seeds)}" for h in hits]
        lines.append("| " + " | ".join([label, *cells, f"{min(ratios):+.0f} .. {max(ratios):+.0f} %"]) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--district", type=Path, default=DEFAULT_DISTRICT,
                        help="built district folder (default: artifacts/default, the make-run district)")
    parser.add_argument("--simulate", type=Path, metavar="DISTRICT_TOML",
                        help="simulate the district's houses now (ideal pass over the period) instead of "
                             "reading the folder's building CSVs")
    parser.add_argument("--real", type=Path, default=CITYLEARN, help="the citylearn data folder of ../shared")
    parser.add_argument("--own-row", action="store_true",
                        help="with --simulate: also a full-year pass per house against the stock row's own "
                             "annual results (cooling, heating, hot water, plug + lighting; the row's weather) and "
                             "the heat-loss coefficient against the row's Manual J design loads")
    parser.add_argument("--schedule-seeds", type=int, nargs="+", metavar="SEED",
                        help="with --simulate: also simulate the houses with these occupant-schedule seeds (0 = "
                             "the build's) and tabulate how often each house is in band: single-month peaks "
                             "are extremes of a random draw")
    parser.add_argument("--same-month", action="store_true",
                        help="real house-months of the built months only (default: the whole season)")
    args = parser.parse_args(argv)
    if not args.real.is_dir():
        print(f"real reference data not found: {args.real} (needs ../shared/data/citylearn)")
        return 2
    built = (simulated_house_months(args.simulate, args.district) if args.simulate
             else built_house_months(args.district))
    source = f"simulated from {args.simulate}" if args.simulate else f"built folder {args.district}"
    real_by_season = {season: real_house_months(args.real, season)
                      for season in sorted({SEASONS[b.month] for b in built})}
    if args.same_month:
        real_by_season = {season: [r for r in items if r.month in {b.month for b in built}]
                          for season, items in real_by_season.items()}
    compared = sorted(season for season, items in real_by_season.items() if items)
    real = [r for season in compared for r in real_by_season[season]]
    shown = [b for b in built if SEASONS[b.month] in compared]
    unmatched = [b for b in built if SEASONS[b.month] not in compared]
    if real:
        reference = median_profile([hour_of_day_profile(total_kwh(r.loads), r.loads["hour"]) for r in real])
        fill_statistics(real, reference)
        fill_statistics(shown, reference)
        scope = f"month(s) {sorted({r.month for r in real})}" if args.same_month else f"season {', '.join(compared)}"
        print(f"built: {len(shown)} house-months ({source}); real: {len(real)} house-months of the 2023 "
              f"challenge homes (Austin TX, {scope})\n")
        several = len(shown) > len(house_names(shown))
        print(per_house_table(shown, real) if several else realism_table(shown, real)[0])
        print("\n" + weather_line(built_weather_months(args.simulate, args.district), {b.month for b in shown},
                                  real_weather_months(args.real), {r.month for r in real}))
    if unmatched:
        fill_statistics(unmatched, np.full(24, np.nan))
        months = sorted({b.month for b in unmatched})
        print(f"\nbuilt: {len(unmatched)} house-months of month(s) {months} ({source}): no real house-months of "
              f"season(s) {sorted({SEASONS[m] for m in months})} in {args.real} (the 2023 challenge homes cover "
              "June-August); the built statistics, median over each house's months:\n")
        print(per_house_table(unmatched, None))
    if not real and not unmatched:
        return 2
    if args.schedule_seeds and args.simulate and real:
        runs = {0: shown}
        for seed in args.schedule_seeds:
            if seed not in runs:
                runs[seed] = [b for b in simulated_house_months(args.simulate, args.district, seed)
                              if SEASONS[b.month] in compared]
                fill_statistics(runs[seed], reference)
        print(f"\nOver occupant-schedule seeds {sorted(runs)}: draws with the house in the real 5-95 % band\n")
        print(seed_table(runs, real))
    if args.own_row and args.simulate:
        print(f"\nFull year {args.simulate}: the ideal pass against the stock row's own annual results\n")
        print(own_row_table(args.simulate, args.district))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
