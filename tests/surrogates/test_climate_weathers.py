"""The weathers of the surrogate climate table (benchmarks/surrogate_climates.py): the TMY3 -> EPW conversion
read back by the project's own EPW readers, and the ground temperatures against the periodic solution of the
heat equation in a half-space (amplitude damped by exp(-z r), phase lagging by z r)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pvlib = pytest.importorskip("pvlib", reason="pvlib (the pipeline extra) holds the Sand Point TMY3")

from benchmarks import surrogate_climates as sc  # noqa: E402 (needs pvlib)
from pipeline.ingest.weather import read_epw  # noqa: E402
from surrogates.energyplus.epw import read_epw_ground_temperatures  # noqa: E402

SAND_POINT = Path(pvlib.__file__).parent / "data" / sc.SAND_POINT_TMY3
TEMPLATE = Path(__file__).resolve().parents[1] / "fixtures" / "synthetic_district" / "weather" / \
    "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"


def ground_values(line: str) -> dict[float, np.ndarray]:
    fields = line.split(",")
    return {float(fields[2 + 16 * i]): np.array(fields[6 + 16 * i:18 + 16 * i], dtype=float)
            for i in range(int(fields[1]))}


def test_ground_at_the_surface_follows_the_air_and_deeper_is_damped_and_late():
    air = 5.0 - 10.0 * np.cos(2 * np.pi * (sc.MID_MONTH_DAYS - sc.MID_MONTH_DAYS[0]) / 365.0)  # coldest in January, -5..15 C
    ground = ground_values(sc.ground_temperatures(air, depths_m=(0.0, 1.0, 3.0)))
    # no depth: the air's own wave (to 0.05 C: the months' unequal lengths move the 12 samples' mean off 5 C)
    np.testing.assert_allclose(ground[0.0], air, atol=0.05)
    r = np.sqrt(np.pi / (365.0 * sc.SOIL_DIFFUSIVITY_M2_DAY))
    for z in (1.0, 3.0):
        assert ground[z].mean() == pytest.approx(5.0, abs=0.1)
        half_range = (ground[z].max() - ground[z].min()) / 2.0
        # sampled monthly, the range is within a month's phase step of the amplitude 10 exp(-z r)
        assert 10.0 * np.exp(-z * r) * np.cos(np.pi / 12) <= half_range <= 10.0 * np.exp(-z * r) + 0.01
    assert np.argmin(ground[3.0]) > np.argmin(ground[1.0]) > np.argmin(ground[0.0])  # the cold arrives later


def test_tmy3_becomes_an_epw_the_readers_take(tmp_path):
    epw = sc.tmy3_epw(SAND_POINT, TEMPLATE, tmp_path)
    tmy3, meta = pvlib.iotools.read_tmy3(SAND_POINT, map_variables=True)
    frame, location = read_epw(epw, tmy_year=2018)
    assert (location["latitude"], location["longitude"], location["utc_offset_hours"]) == \
        (meta["latitude"], meta["longitude"], meta["TZ"])
    assert len(frame) == 8760 and frame.index[0].month == 1 and frame.index[0].day == 1
    np.testing.assert_allclose(frame["outdoor_dry_bulb_temperature_c"], tmy3["temp_air"], atol=0.005)
    np.testing.assert_allclose(frame["ghi_w_m2"], tmy3["ghi"], atol=0.005)
    np.testing.assert_allclose(frame["wind_speed_m_s"], tmy3["wind_speed"], atol=0.005)
    # the deepest ground temperatures the house model reads: near the station's annual mean air temperature
    ground = read_epw_ground_temperatures(epw)
    assert len(ground) == 12 and abs(np.mean(ground) - tmy3["temp_air"].mean()) < 0.1
    # Building America's Very Cold: 9,000 <= HDD65 < 12,600 (the station's class, IECC 7)
    assert 9000 <= sc.degree_days(epw.read_text().splitlines())["hdd65"] < 12600
    # written once, named by its content: a second call returns the same file
    assert sc.tmy3_epw(SAND_POINT, TEMPLATE, tmp_path) == epw
