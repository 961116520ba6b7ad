"""ERCOT fuel mix: the real 2017 workbook (totals, DST days, June carbon profile) and bad input."""

from __future__ import annotations

import datetime as dt

import numpy as np
import openpyxl
import pandas as pd
import pytest

from pipeline.carbon import carbon_intensity
from pipeline.errors import InputError
from pipeline.ingest.carbon import read_carbon_intensity
from pipeline.ingest.fuel_mix import read_emission_factors, read_fuel_mix_csv, read_fuel_mix_workbook

FUELS = ("Biomass", "Coal", "Gas", "Gas-CC", "Hydro", "Nuclear", "Other", "Solar", "Wind")
LABELS = [f"{(m // 60) % 24}:{m % 60:02d}" for m in range(15, 1441, 15)]


def _starts_in_daylight_time(day: dt.date) -> bool:
    """US DST 2017: local midnight is CDT from 2017-03-13 to 2017-11-05 inclusive."""
    return dt.date(2017, 3, 13) <= day <= dt.date(2017, 11, 5)


def test_real_workbook_covers_every_standard_hour_once(workbook_hourly):
    hourly = workbook_hourly
    assert list(hourly.columns) == sorted(FUELS)
    assert len(hourly) == 8760
    assert hourly.index[0] == pd.Timestamp("2017-01-01 00:00")
    assert hourly.index[-1] == pd.Timestamp("2017-12-31 23:00")
    assert (hourly.index[1:] - hourly.index[:-1] == pd.Timedelta(hours=1)).all()
    assert not hourly.isna().any().any()


def test_real_workbook_hourly_sums_match_daily_total_column(workbook_hourly, workbook_rows):
    """Each standard-time day = the workbook's Total, less/plus the 00:00-01:00 CDT hour that moves days."""
    hourly = workbook_hourly
    daily = hourly.groupby(hourly.index.date).sum()
    for (day, fuel), (total, cells) in workbook_rows.items():
        expected = total
        if _starts_in_daylight_time(day):
            expected -= sum(cells[:4])  # 00:00-01:00 CDT belongs to the previous standard day
        nxt = workbook_rows.get((day + dt.timedelta(days=1), fuel))
        if nxt is not None and _starts_in_daylight_time(day + dt.timedelta(days=1)):
            expected += sum(nxt[1][:4])
        assert daily.at[day, fuel] == pytest.approx(expected, rel=1e-9, abs=1e-6), (day, fuel)
    for fuel in FUELS:
        year_total = sum(t for (_, f), (t, _) in workbook_rows.items() if f == fuel)
        assert hourly[fuel].sum() == pytest.approx(year_total, rel=1e-10)


def test_real_workbook_dst_days(workbook_hourly, workbook_rows):
    hourly = workbook_hourly
    spring = workbook_rows[(dt.date(2017, 3, 12), "Coal")][1]
    assert sum(c is None for c in spring[:96]) == 4 and all(c is None for c in spring[8:12])  # 2:15-3:00
    # 01:00-02:00 CST = labels 1:15..2:00; 02:00-03:00 CST = 03:00-04:00 CDT = labels 3:15..4:00
    assert hourly.at[pd.Timestamp("2017-03-12 01:00"), "Coal"] == pytest.approx(sum(spring[4:8]))
    assert hourly.at[pd.Timestamp("2017-03-12 02:00"), "Coal"] == pytest.approx(sum(spring[12:16]))
    fall = workbook_rows[(dt.date(2017, 11, 5), "Coal")][1]
    assert len(fall) == 100 and all(c is not None for c in fall)
    # first pass 01:00-02:00 CDT = 00:00-01:00 CST (regular columns), second pass = 01:00-02:00 CST ((DST) columns)
    assert hourly.at[pd.Timestamp("2017-11-05 00:00"), "Coal"] == pytest.approx(sum(fall[4:8]))
    assert hourly.at[pd.Timestamp("2017-11-05 01:00"), "Coal"] == pytest.approx(sum(fall[96:100]))
    assert hourly.at[pd.Timestamp("2017-11-04 23:00"), "Coal"] == pytest.approx(sum(fall[0:4]))


def test_june_carbon_intensity_is_plausible(workbook_hourly):
    june = carbon_intensity(workbook_hourly.loc["2017-06"])
    assert len(june) == 720
    assert 0.35 < june.min() and june.max() < 0.70  # documented in docs/ingest.md: 0.39-0.63 kg/kWh
    profile = june.groupby(june.index.hour).mean()
    assert profile.idxmin() in range(0, 6)  # night minimum (wind, low gas)
    assert profile.idxmax() in range(10, 17)  # midday maximum (gas peakers, coal ramps)


# ---------------------------------------------------------------- synthetic workbooks for bad input
def _write_workbook(path, rows, header=None):
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.title = "Jun"
    sheet.append(header or ["Date", "Fuel", "Settlement Type", "Total", *LABELS])
    for row in rows:
        sheet.append(row)
    book.save(path)
    return path


def _row(day, fuel, value=1.0):
    return [dt.datetime(2018, 6, day), fuel, "FINAL", 96 * value, *([value] * 96)]


def _good_rows():
    return [_row(day, fuel, v) for day in (1, 2, 3) for fuel, v in (("Coal", 2.0), ("Wind", 1.0))]


def test_synthetic_workbook_june_is_shifted_to_standard_time(tmp_path):
    hourly, _ = read_fuel_mix_workbook(_write_workbook(tmp_path / "f.xlsx", _good_rows()))
    # June is CDT: the data start at 00:00 CDT = 23:00 CST the day before
    assert hourly.index[0] == pd.Timestamp("2018-05-31 23:00")
    assert len(hourly) == 72
    assert (hourly["Coal"] == 8.0).all() and (hourly["Wind"] == 4.0).all()
    assert carbon_intensity(hourly).iloc[0] == pytest.approx((2 * 1001 + 12) / 3 / 1000)


@pytest.mark.parametrize(
    ("mutate", "message", "column", "row"),
    [
        (lambda rows: rows, "missing column", "Total", 1),
        (lambda rows: rows.__setitem__(2, _row(2, "Lignite")), "unknown fuel 'Lignite'", "Fuel", 4),
        (lambda rows: rows[3].__setitem__(10, "n/a"), "non-numeric cell 'n/a'", "1:45", 5),
        (lambda rows: rows.pop(2), "gap in timestamps", "Coal", 5),
        (lambda rows: rows.__setitem__(2, _row(1, "Coal", 2.0)), "duplicate row", "Date", 4),
        (lambda rows: rows.__setitem__(0, _row(1, "Coal", -2.0)), "negative energy", "0:15", 2),
        (lambda rows: rows[1].__setitem__(3, 95.0), "differs from the sum", "Total", 3),
    ],
    ids=["missing-column", "unknown-fuel", "non-numeric", "gap", "duplicate", "negative", "total"],
)
def test_workbook_bad_input(tmp_path, mutate, message, column, row):
    rows = _good_rows()
    header = None
    if message == "missing column":
        header = ["Date", "Fuel", "Settlement Type", "Sum", *LABELS]
    else:
        mutate(rows)
    path = _write_workbook(tmp_path / "bad.xlsx", rows, header)
    with pytest.raises(InputError) as caught:
        read_fuel_mix_workbook(path)
    text = str(caught.value)
    assert message in text and str(path) in text and "sheet Jun" in text
    assert f"'{column}'" in text or f"column/key {column!r}" in text
    assert f"row {row}" in text


def test_workbook_prefers_final_over_initial_rows(tmp_path):
    rows = _good_rows()
    rows.insert(0, [dt.datetime(2018, 6, 1), "Coal", "INITIAL", 960.0, *([10.0] * 96)])
    hourly, _ = read_fuel_mix_workbook(_write_workbook(tmp_path / "f.xlsx", rows))
    assert (hourly["Coal"] == 8.0).all()


# ---------------------------------------------------------------- long CSV
def _long_csv(path, stamps, fuels=("Coal", "Wind"), values=None):
    lines = ["timestamp,fuel,MWh"]
    for k, stamp in enumerate(stamps):
        for j, fuel in enumerate(fuels):
            value = values[k] if values is not None else 1.0 + j
            lines.append(f"{stamp},{fuel},{value}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_long_csv_prevailing_time_fall_back_day(tmp_path):
    # 15-min interval-ending labels in Central prevailing time for 2017-11-05, the repeated hour in order
    zone = pd.date_range("2017-11-05 00:15", "2017-11-06 00:00", freq="15min", tz="America/Chicago")
    assert len(zone) == 100
    labels = [t.strftime("%Y-%m-%d %H:%M") for t in zone.tz_localize(None)]
    values = np.arange(100, dtype=float)
    path = _long_csv(tmp_path / "mix.csv", labels, fuels=("Coal",), values=values)
    hourly, meta = read_fuel_mix_csv(path)
    assert meta["clock"] == "prevailing"
    assert hourly.index[0] == pd.Timestamp("2017-11-04 23:00") and len(hourly) == 25
    assert hourly.at[pd.Timestamp("2017-11-05 00:00"), "Coal"] == values[4:8].sum()  # first 01:00-02:00
    assert hourly.at[pd.Timestamp("2017-11-05 01:00"), "Coal"] == values[8:12].sum()  # second 01:00-02:00
    assert hourly["Coal"].sum() == values.sum()


def test_long_csv_hourly_with_utc_offsets(tmp_path):
    stamps = ["2018-06-01T01:00:00-05:00", "2018-06-01T02:00:00-05:00", "2018-06-01T03:00:00-05:00"]
    hourly, _ = read_fuel_mix_csv(_long_csv(tmp_path / "mix.csv", stamps))
    assert list(hourly.index) == list(pd.date_range("2018-05-31 23:00", periods=3, freq="h"))
    assert (hourly["Wind"] == 2.0).all()


@pytest.mark.parametrize(
    ("edit", "message", "column", "row"),
    [
        (lambda t: t.replace("timestamp,fuel,MWh", "time,fuel,MWh"), "missing column", "timestamp", 1),
        (lambda t: t.replace("Wind", "Fusion", 1), "unknown fuel 'Fusion'", "fuel", 3),
        (lambda t: t.replace(",Coal,1.0", ",Coal,x", 1), "non-numeric value 'x'", "mwh", 2),
        (lambda t: t.replace(",Coal,1.0", ",Coal,-1.0", 1), "negative energy", "mwh", 2),
    ],
    ids=["missing-column", "unknown-fuel", "non-numeric", "negative"],
)
def test_long_csv_bad_input(tmp_path, edit, message, column, row):
    stamps = [f"2018-01-01 {h:02d}:00" for h in range(1, 6)]
    path = _long_csv(tmp_path / "mix.csv", stamps)
    path.write_text(edit(path.read_text()))
    with pytest.raises(InputError) as caught:
        read_fuel_mix_csv(path, clock="standard")
    text = str(caught.value)
    assert message in text and str(path) in text and repr(column) in text and f"row {row}" in text


@pytest.mark.parametrize("kind", ["gap", "duplicate"])
def test_long_csv_gap_and_duplicate(tmp_path, kind):
    stamps = [f"2018-01-01 {h:02d}:00" for h in range(1, 6)]
    stamps = stamps[:2] + stamps[3:] if kind == "gap" else stamps[:3] + stamps[2:]
    path = _long_csv(tmp_path / "mix.csv", stamps, fuels=("Coal",))
    with pytest.raises(InputError, match=kind) as caught:
        read_fuel_mix_csv(path, clock="standard")
    row = 4 if kind == "gap" else 5  # the first row after the gap / the second copy (header = row 1)
    assert f"row {row}" in str(caught.value) and "'Coal'" in str(caught.value)


def test_period_outside_the_workbook(tmp_path):
    from pipeline.ingest.commands import write_carbon

    path = _write_workbook(tmp_path / "f.xlsx", _good_rows())
    out = tmp_path / "ci.csv"
    write_carbon(path, "2018-06-01", "2018-06-02", out)  # the data cover 2018-05-31 23:00 .. 06-03 22:00 CST
    with pytest.raises(InputError, match="outside the file") as caught:
        write_carbon(path, "2018-06-01", "2018-06-03", tmp_path / "ci3.csv")
    assert str(path) in str(caught.value) and "2018-06-03 23:00:00" in str(caught.value)
    assert not (tmp_path / "ci3.csv").exists()


def test_factor_table_holds_srren_medians_with_sources():
    factors = read_emission_factors()
    # IPCC SRREN Annex II Table A.II.4 medians [g CO2e/kWh]
    srren = {"Coal": 1001, "Gas": 469, "Gas-CC": 469, "Nuclear": 16, "Wind": 12, "Solar": 46, "Hydro": 4,
             "Biomass": 18}
    for fuel, value in srren.items():
        assert factors.at[fuel, "g_co2e_per_kwh"] == value
    assert factors["note"].str.len().min() > 10  # every row says where its number comes from
    assert pd.isna(factors.at["Power Storage", "g_co2e_per_kwh"])


def test_bad_factor_file(tmp_path):
    path = tmp_path / "f.csv"
    path.write_text("fuel,g_co2e_per_kwh,srren_technology,negative_allowed,note\nCoal,lots,Coal,false,x\n")
    with pytest.raises(InputError, match=r"column/key 'g_co2e_per_kwh', row 2"):
        read_emission_factors(path)


def test_carbon_intensity_of_a_period_from_a_long_csv(tmp_path):
    # two hours of standard-time generation: Coal 1 + Wind 3 MWh, then Coal 2 + Nuclear 2 MWh
    path = tmp_path / "mix.csv"
    path.write_text("timestamp,fuel,mwh\n2018-06-01 01:00,Coal,1\n2018-06-01 01:00,Wind,3\n"
                    "2018-06-01 02:00,Coal,2\n2018-06-01 02:00,Nuclear,2\n")
    index = pd.date_range("2018-06-01 00:00", periods=2, freq="h")
    table = read_carbon_intensity(path, index, clock="standard")
    assert list(table.columns) == ["carbon_intensity"] and list(table.index) == list(index)
    assert table["carbon_intensity"].tolist() == pytest.approx([(1001 + 3 * 12) / 4000, (2 * 1001 + 2 * 16) / 4000])
    with pytest.raises(InputError, match="mix.csv"):
        read_carbon_intensity(path, pd.date_range("2018-06-01 00:00", periods=3, freq="h"), clock="standard")
