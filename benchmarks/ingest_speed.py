"""Ingest speed: our readers next to the plain library reads they build on (median of repeated runs).

Run: ``.venv/bin/python benchmarks/ingest_speed.py [--repeat 5]`` from the repository root. Needs
``../shared/data`` for the ERCOT workbook and the EPW; the EULP year is generated in a temp folder.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

SHARED = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
WORKBOOK = SHARED / "ercot" / "IntGenbyFuel2017.xlsx"
EPW = SHARED / "weather" / "USA_TX_Austin-Camp.Mabry.722544_TMY3.epw"


def median_seconds(func, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def eulp_year(folder: Path) -> Path:
    ends = pd.date_range("2018-01-01 00:15", "2019-01-01 00:00", freq="15min")
    rng = np.random.default_rng(0)
    frame = pd.DataFrame({"timestamp": ends})
    for use in ("interior_lighting", "plug_loads", "refrigerator", "cooling", "heating", "water_systems"):
        frame[f"out.electricity.{use}.energy_consumption"] = rng.uniform(0, 0.3, len(ends))
    for load in ("cooling", "heating", "hot_water"):
        frame[f"out.load.{load}.energy_delivered.kbtu"] = rng.uniform(0, 2, len(ends))
    frame["out.zone_mean_air_temp.conditioned_space.c"] = rng.uniform(20, 26, len(ends))
    path = folder / "1-0.parquet"
    frame.to_parquet(path, index=False)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    import openpyxl
    import pvlib

    from pipeline.ingest.eulp import building_loads, read_eulp_timeseries
    from pipeline.ingest.fuel_mix import read_fuel_mix_workbook
    from pipeline.ingest.tariff import hourly_prices, read_tariff
    from pipeline.ingest.weather import read_epw
    from pipeline.pv import PVSite, pv_yield

    def raw_workbook():
        book = openpyxl.load_workbook(WORKBOOK, read_only=True, data_only=True)
        for name in book.sheetnames[4:]:
            sheet = book[name]
            sheet.reset_dimensions()
            list(sheet.iter_rows(values_only=True))
        book.close()

    weather, meta = read_epw(EPW, tmy_year=2018)
    site = PVSite(meta["latitude"], meta["longitude"])
    tariff = read_tariff(Path(__file__).resolve().parents[1] / "raw" / "tariffs" / "austin_energy_tou_2018.toml")
    year = pd.date_range("2018-01-01", "2018-12-31 23:00", freq="h")
    metadata = pd.Series({"in.cooling_setpoint": "76F", "in.heating_setpoint": "68F", "in.occupants": "3"},
                         name=1)
    with tempfile.TemporaryDirectory() as folder:
        series = eulp_year(Path(folder))
        rows = [
            ("ERCOT workbook 2017 -> hourly CST by fuel", lambda: read_fuel_mix_workbook(WORKBOOK),
             "openpyxl cell read only", raw_workbook),
            ("EPW year -> canonical frame", lambda: read_epw(EPW, tmy_year=2018),
             "pvlib.iotools.read_epw", lambda: pvlib.iotools.read_epw(EPW)),
            ("PV yield, 8760 h", lambda: pv_yield(weather, site, -6.0), None, None),
            ("tariff prices, 8760 h", lambda: hourly_prices(tariff, year), None, None),
            ("EULP 15-min year -> hourly building frame",
             lambda: building_loads(read_eulp_timeseries(series)[0], metadata),
             "pandas.read_parquet only", lambda: pd.read_parquet(series)),
        ]
        print(f"median of {args.repeat} runs [s]")
        for name, ours, base_name, base in rows:
            ours_s = median_seconds(ours, args.repeat)
            line = f"{name:45s} {ours_s:8.3f}"
            if base is not None:
                base_s = median_seconds(base, args.repeat)
                line += f"   {base_name}: {base_s:.3f}   ratio {ours_s / base_s:.2f}"
            print(line)


if __name__ == "__main__":
    main()
