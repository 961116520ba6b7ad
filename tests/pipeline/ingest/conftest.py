"""Shared fixtures for the ingest tests: paths to ../shared/data and the real ERCOT workbook, parsed once."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[3] / ".." / "shared" / "data"
WORKBOOK = SHARED / "ercot" / "IntGenbyFuel2017.xlsx"
EPW = SHARED / "weather" / "USA_TX_Austin-Camp.Mabry.722544_TMY3.epw"
RESSTOCK_WEATHER = SHARED / "weather" / "G3600010.csv"


def need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"../shared/data not present: {path}")
    return path


@pytest.fixture(scope="session")
def workbook_hourly():
    """Hourly MWh per fuel parsed from the real 2017 workbook by the code under test."""
    from pipeline.ingest.fuel_mix import read_fuel_mix_workbook

    return read_fuel_mix_workbook(need(WORKBOOK))[0]


@pytest.fixture(scope="session")
def workbook_rows():
    """The workbook's own rows, read directly with openpyxl: {(date, fuel): (Total, [cells in column order])}."""
    import openpyxl

    book = openpyxl.load_workbook(need(WORKBOOK), read_only=True, data_only=True)
    rows = {}
    for name in ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"):
        sheet = book[name]
        sheet.reset_dimensions()
        for row in list(sheet.iter_rows(values_only=True))[1:]:
            if row and row[0] is not None:
                rows[(row[0].date(), row[1])] = (row[3], list(row[4:]))
    book.close()
    return rows


@pytest.fixture(scope="session")
def epw_path() -> Path:
    """The real Austin Camp Mabry TMY3 EPW (skips when ../shared/data is absent)."""
    return need(EPW)


@pytest.fixture(scope="session")
def resstock_weather_path() -> Path:
    """The real ResStock county weather CSV sample (skips when absent)."""
    return need(RESSTOCK_WEATHER)


@pytest.fixture(scope="session")
def workbook_path() -> Path:
    """The real ERCOT 2017 workbook (skips when absent)."""
    return need(WORKBOOK)
