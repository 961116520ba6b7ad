"""The CSV/parquet ILV source, including upstream CityLearn's export without a timestamp column."""

from __future__ import annotations

import pandas as pd
import pytest

from pipeline.errors import InputError
from surrogates.sources.csv import read_ilv_table
from tests.surrogates.test_ilv import make_table


def upstream_export(table: pd.DataFrame) -> pd.DataFrame:
    """The table as CityLearn's select_lstm_training_data.sql writes it: month, day, hour; no timestamp."""
    stamps = pd.to_datetime(table["timestamp"])
    out = table.drop(columns="timestamp")
    out.insert(1, "day", stamps.dt.day)
    out.insert(1, "reference_name", out["reference"].map({0: "ideal", 2: "partial_1"}))
    return out


def test_timestamp_rebuilt_from_month_day_hour(tmp_path):
    table = make_table()
    upstream_export(table).to_csv(tmp_path / "lstm.csv", index=False)
    back = read_ilv_table(tmp_path / "lstm.csv", year=2026)
    # hour 1 on 5 January -> the interval beginning 2026-01-05 00:00; hour 24 -> 23:00
    assert back["timestamp"].iloc[0] == pd.Timestamp("2026-01-05 00:00")
    assert back["timestamp"].iloc[23] == pd.Timestamp("2026-01-05 23:00")
    assert len(back) == len(table)


def test_year_needed_and_bad_day(tmp_path):
    upstream = upstream_export(make_table())
    upstream.to_csv(tmp_path / "lstm.csv", index=False)
    with pytest.raises(InputError, match="give the year"):
        read_ilv_table(tmp_path / "lstm.csv")
    upstream.loc[3, "day"] = 32
    upstream.to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(InputError) as info:
        read_ilv_table(tmp_path / "bad.csv", year=2026)
    assert (info.value.column, info.value.row) == ("day", 3)


def test_contract_table_passes_through(tmp_path):
    make_table().to_parquet(tmp_path / "t.parquet")
    assert read_ilv_table(tmp_path / "t.parquet")["reference"].unique().tolist() == [0, 2]
