"""Stock rows (pipeline/ingest/stock.py): a characteristics row and an EULP metadata row as plain JSON values;
a missing building or id column is one error naming the file and the column."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pipeline.errors import InputError
from pipeline.ingest.eulp import timeseries_path
from pipeline.ingest.stock import read_characteristics_row, read_eulp_metadata_row


def test_characteristics_row_keeps_the_inputs_as_plain_values(tmp_path):
    path = tmp_path / "stock.csv"
    pd.DataFrame({"bldg_id": [7, 8], "in.sqft": [1200.0, np.nan], "in.vintage": ["1980s", "2000s"],
                  "out.site_energy": [1.0, 2.0]}).to_csv(path, index=False)
    assert read_characteristics_row(path, 8) == {"bldg_id": 8, "in.sqft": None, "in.vintage": "2000s"}
    row = read_characteristics_row(path, 7)
    assert row == {"bldg_id": 7, "in.sqft": 1200.0, "in.vintage": "1980s"}
    assert type(row["bldg_id"]) is int and json.loads(json.dumps(row)) == row  # JSON values, no numpy
    with pytest.raises(InputError, match=r"stock.csv, column/key 'bldg_id': building 9 not in the characteristics"):
        read_characteristics_row(path, 9)
    pd.DataFrame({"id": [8]}).to_csv(path, index=False)
    with pytest.raises(InputError, match=r"stock.csv, column/key 'bldg_id': no building id column"):
        read_characteristics_row(path, 8)


def test_eulp_metadata_row_from_a_release_folder(tmp_path):
    (tmp_path / "metadata").mkdir()
    pd.DataFrame({"bldg_id": [1001, 1002], "in.state": ["TX", "TX"], "in.sqft": [1500, 900],
                  "in.heating_fuel": ["Electricity", None]}).to_parquet(tmp_path / "metadata" / "metadata.parquet",
                                                                     index=False)
    for bldg_id in (1001, 1002, 1003):  # 1003 has a timeseries but no metadata row
        series = tmp_path / timeseries_path(bldg_id, 0, "TX")
        series.parent.mkdir(parents=True, exist_ok=True)
        series.write_bytes(b"")
    row = read_eulp_metadata_row(str(tmp_path), 1002)
    assert row == {"bldg_id": 1002, "in.state": "TX", "in.sqft": 900, "in.heating_fuel": None}
    assert type(row["in.sqft"]) is int
    assert read_eulp_metadata_row(str(tmp_path), 1001, state="TX")["in.heating_fuel"] == "Electricity"
    with pytest.raises(InputError, match=r"metadata.parquet, column/key 'bldg_id': building 1003 not in the metadata"):
        read_eulp_metadata_row(str(tmp_path), 1003, state="TX")
