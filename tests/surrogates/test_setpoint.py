"""The one ResStock set-point parser (surrogates and pipeline ingest share it) on the real spellings."""

from __future__ import annotations

import pandas as pd
import pytest

from surrogates.energyplus.metadata import parse_setpoint
from tests.conftest import SHARED, need_shared

CHARACTERISTICS = SHARED / "data" / "eulp" / "resstock_characteristics_100_dwellings.parquet"


def test_spellings_by_hand():
    # 76 F = (76 - 32) x 5 / 9 = 24.444... degC; bare numbers in ResStock set-point columns are degF
    for cell in ("76F", "76 F", "76°F", " 76F ", "76", "76.0", 76, 76.0):
        assert parse_setpoint(cell) == pytest.approx(44 * 5 / 9, abs=1e-12), cell
    assert parse_setpoint("55F") == pytest.approx(23 * 5 / 9, abs=1e-12)  # 12.78 degC heating setback
    assert parse_setpoint("24C") == 24.0


@pytest.mark.parametrize("cell", ["72F w/ 3F offset", "cool", "", "None", True, "24"])
def test_unreadable_or_implausible(cell):
    # "24" is 24 degF = -4.4 degC: a Celsius value written without its unit
    with pytest.raises(ValueError, match="set point"):
        parse_setpoint(cell)


def test_every_real_resstock_spelling():
    need_shared(CHARACTERISTICS)
    frame = pd.read_parquet(CHARACTERISTICS)
    cells = set()
    for column in ("build_existing_model.cooling_setpoint", "build_existing_model.heating_setpoint"):
        cells |= set(frame[column].dropna().astype(str))
    assert {"76F", "55F", "80F"} <= cells
    for cell in cells:
        fahrenheit = float(cell.removesuffix("F"))
        assert parse_setpoint(cell) == pytest.approx((fahrenheit - 32.0) / 1.8, abs=1e-12), cell


def test_pipeline_ingest_uses_the_same_parser():
    from pipeline.errors import InputError
    from pipeline.ingest.eulp import metadata_set_point_c

    row = pd.Series({"in.cooling_setpoint": "78", "in.heating_setpoint": "24"}, name=1001)
    assert metadata_set_point_c(row, "in.cooling_setpoint", "meta.csv") == pytest.approx(46 / 1.8)
    with pytest.raises(InputError, match=r"meta.csv, column/key 'in.heating_setpoint', row bldg_id 1001"):
        metadata_set_point_c(row, "in.heating_setpoint", "meta.csv")
