"""The ``districtgen weather|tariff|carbon|eulp`` commands: files written, row 0 = first hour, clean errors."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import openpyxl
import pandas as pd
import pytest

from citylearn_env.dataset import CARBON_COLUMNS, PRICING_COLUMNS, WEATHER_COLUMNS
from pipeline.cli import main

AUSTIN_TARIFF = Path(__file__).resolve().parents[3] / "raw" / "tariffs" / "austin_energy_tou_2018.toml"


def test_weather_command_both_layouts(tmp_path, epw_path, capsys):
    out = tmp_path / "weather.csv"
    assert main(["weather", str(epw_path), "--start", "2018-06-01", "--end", "2018-06-30", "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == list(WEATHER_COLUMNS) and len(table) == 720
    june_first = next(line.split(",") for line in epw_path.read_text().splitlines()[8:]
                      if line.split(",")[1:4] == ["6", "1", "1"])
    assert table["outdoor_dry_bulb_temperature"].iloc[0] == float(june_first[6])
    old = tmp_path / "weather21.csv"
    assert main(["weather", str(epw_path), "--start", "2018-06-01", "--end", "2018-06-02", "-o", str(old),
                 "--layout", "v2.1", "--forecast", "noisy", "--seed", "3"]) == 0
    assert list(pd.read_csv(old).columns) == list(WEATHER_COLUMNS.values())
    assert "wrote" in capsys.readouterr().out


def test_tariff_command(tmp_path):
    out = tmp_path / "pricing.csv"
    assert main(["tariff", str(AUSTIN_TARIFF), "--start", "2018-06-01", "--end", "2018-06-30", "-o", str(out),
                 "--layout", "v2.1"]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == list(PRICING_COLUMNS.values()) and len(table) == 720
    # row 0 = Friday 2018-06-01 00:00-01:00 (off-peak); row 15 = 15:00-16:00 (on-peak)
    assert table.iloc[0, 0] == 0.0289 and table.iloc[15, 0] == 0.0587 and table.iloc[22, 0] == 0.0289


def test_carbon_command_workbook(tmp_path):
    """A one-sheet workbook in the ERCOT layout (June, daylight time): row 0 = 00:00-01:00 CST = 01:00-02:00 CDT."""
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.title = "Jun"
    labels = [f"{(m // 60) % 24}:{m % 60:02d}" for m in range(15, 1441, 15)]
    sheet.append(["Date", "Fuel", "Settlement Type", "Total", *labels])
    for day in (1, 2):
        coal = [1.0] * 96
        coal[4:8] = [3.0] * 4  # 01:00-02:00 CDT
        sheet.append([dt.datetime(2018, 6, day), "Coal", "FINAL", sum(coal), *coal])
        sheet.append([dt.datetime(2018, 6, day), "Wind", "FINAL", 96.0, *([1.0] * 96)])
    path = tmp_path / "IntGenbyFuel2018.xlsx"
    book.save(path)
    out = tmp_path / "carbon_intensity.csv"
    assert main(["carbon", str(path), "--start", "2018-06-01", "--end", "2018-06-01", "-o", str(out),
                 "--layout", "v2.1"]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == list(CARBON_COLUMNS.values()) and len(table) == 24
    assert table.iloc[0, 0] == pytest.approx((3 * 1001 + 12) / 4 / 1000)
    assert table.iloc[1, 0] == pytest.approx((1001 + 12) / 2 / 1000)
    with pytest.raises(SystemExit):  # --start is required
        main(["carbon", str(path), "--end", "2018-06-01", "-o", str(out)])


def test_long_csv_carbon_command(tmp_path):
    path = tmp_path / "mix.csv"
    rows = ["timestamp,fuel,mwh"] + [f"2018-06-01 {h:02d}:00,{f},{v}" for h in range(1, 24)
                                     for f, v in (("Coal", 1), ("Wind", 3))]
    rows += [f"2018-06-02 00:00,{f},{v}" for f, v in (("Coal", 1), ("Wind", 3))]
    path.write_text("\n".join(rows) + "\n")
    out = tmp_path / "ci.csv"
    assert main(["carbon", str(path), "--clock", "standard", "--start", "2018-06-01", "--end", "2018-06-01",
                 "-o", str(out)]) == 0
    assert pd.read_csv(out)["carbon_intensity"].tolist() == pytest.approx([(1001 + 3 * 12) / 4000] * 24)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["tariff", "{tariff}", "--start", "2018-06-30", "--end", "2018-06-01"], "is before start"),
        (["tariff", "{tariff}", "--start", "2018-13-01", "--end", "2018-06-01"], "expected a date"),
        (["weather", "{missing}", "--start", "2018-06-01", "--end", "2018-06-01"], "missing.csv"),
        (["carbon", "{tariff}", "--start", "2018-06-01", "--end", "2018-06-01"], "cannot read CSV"),
        (["eulp", "{tmp}", "--building", "5", "--start", "2018-06-01", "--end", "2018-06-01"], "no metadata found"),
    ],
    ids=["reversed-period", "bad-date", "missing-file", "not-a-fuel-mix", "no-release"],
)
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, argv, message):
    values = {"tariff": str(AUSTIN_TARIFF), "missing": str(tmp_path / "missing.csv"), "tmp": str(tmp_path)}
    out = tmp_path / "out.csv"
    assert main([a.format(**values) for a in argv] + ["-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("districtgen: error:") and message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
