"""The SYNTHETIC ERCOT fuel-mix workbook of raw/ (tools.synthetic_fuel_mix): DST layouts, determinism,
and that the ingest reader accepts it."""

from __future__ import annotations

import datetime as dt

import openpyxl
import pytest

from tools.synthetic_fuel_mix import day_intervals, write_synthetic_fuel_mix


def test_dst_day_layouts_follow_ercot():
    spring, autumn, normal = (day_intervals(dt.date(2018, 3, 11)), day_intervals(dt.date(2018, 11, 4)),
                              day_intervals(dt.date(2018, 6, 1)))
    assert (len(spring), len(autumn), len(normal)) == (92, 100, 96)
    assert [label for _, label in spring][7:9] == ["2:00", "3:15"]
    assert [label for _, label in autumn][8:13] == ["01:15 (DST)", "01:30 (DST)", "01:45 (DST)",
                                                    "02:00 (DST)", "2:15"]
    # labels are Central prevailing time; the ends in standard time are one hour earlier in summer
    assert normal[0] == (dt.datetime(2018, 5, 31, 23, 15), "0:15")


def test_synthetic_workbook_layout_and_determinism(tmp_path):
    a = write_synthetic_fuel_mix(tmp_path / "a.xlsx", months=(11,))
    b = write_synthetic_fuel_mix(tmp_path / "b.xlsx", months=(11,))
    assert a.read_bytes() == b.read_bytes()
    book = openpyxl.load_workbook(a)
    assert book.sheetnames == ["Disclaimer", "Nov"]
    assert "SYNTHETIC" in book["Disclaimer"]["A1"].value
    nov = list(book["Nov"].iter_rows(values_only=True))
    assert nov[0][:5] == ("Date", "Fuel", "Settlement Type", "Total", "0:15")
    assert nov[0][-5:] == ("0:00", "01:15 (DST)", "01:30 (DST)", "01:45 (DST)", "02:00 (DST)")
    fuels = {row[1] for row in nov[1:]}
    assert fuels == {"Biomass", "Coal", "Gas", "Gas-CC", "Hydro", "Nuclear", "Other", "Solar", "Wind"}
    for day, count in ((dt.datetime(2018, 11, 4), 100), (dt.datetime(2018, 11, 5), 96)):
        rows = [r for r in nov[1:] if r[0] == day]
        assert len(rows) == 9
        for row in rows:
            values = [v for v in row[4:] if v is not None]
            assert len(values) == count
            assert row[3] == pytest.approx(sum(values), abs=0.01)


def test_spring_forward_sheet_reads_with_the_ingest_reader(tmp_path):
    path = write_synthetic_fuel_mix(tmp_path / "IntGenbyFuel2018.xlsx", months=(3,))
    mar = list(openpyxl.load_workbook(path)["Mar"].iter_rows(values_only=True))
    spring = [r for r in mar[1:] if r[0] == dt.datetime(2018, 3, 11)]
    assert len(spring) == 9
    for row in spring:
        assert [mar[0][i] for i, v in enumerate(row) if v is None] == ["2:15", "2:30", "2:45", "3:00"]
    fuel_mix = pytest.importorskip("pipeline.ingest.fuel_mix")
    hourly, _ = fuel_mix.read_fuel_mix_workbook(path)
    # March in prevailing time: 31 days x 24 h - the skipped hour = 743 standard-time hours
    assert len(hourly) == 743
    assert hourly.index.to_series().diff().dropna().eq("1h").all()
