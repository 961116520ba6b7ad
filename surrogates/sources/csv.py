"""ILV tables from a precomputed CSV or parquet file.

Accepts the contract table (:mod:`surrogates.ilv`) and upstream CityLearn's LSTM training-data export
(``select_lstm_training_data.sql``: no ``timestamp`` but ``month``, ``day``, ``hour`` 1..24), for which the
interval-beginning timestamp is rebuilt from a given ``year``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.errors import InputError
from surrogates.ilv import read_ilv, validate_ilv


def read_ilv_table(path: str | os.PathLike, year: int | None = None) -> pd.DataFrame:
    """Read and validate an ILV table; ``year`` is needed only when the file has no ``timestamp`` column."""
    path = Path(path)
    if not path.is_file():
        raise InputError("ILV table not found", file=path)
    header = pd.read_parquet(path).columns if path.suffix.lower() in (".parquet", ".pq") else \
        pd.read_csv(path, nrows=0).columns
    if "timestamp" in header:
        return read_ilv(path)
    frame = pd.read_parquet(path) if path.suffix.lower() in (".parquet", ".pq") else pd.read_csv(path)
    return validate_ilv(with_timestamp(frame, year, path), source=path)


def with_timestamp(frame: pd.DataFrame, year: int | None, source: object = "<ILV table>") -> pd.DataFrame:
    """Add an interval-beginning ``timestamp`` from ``month``, ``day`` and hour-ending ``hour`` (1..24)."""
    for column in ("month", "day", "hour"):
        if column not in frame.columns:
            raise InputError("the table has no 'timestamp' column and cannot rebuild it (needs month, day, "
                             "hour)", file=source, column=column)
    if year is None:
        raise InputError("the table has no 'timestamp' column: give the year of the simulation", file=source,
                         column="timestamp")
    parts = {c: pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float) for c in ("month", "day", "hour")}
    for column, values in parts.items():
        if np.isnan(values).any():
            raise InputError("missing or non-numeric value", file=source, column=column,
                             row=int(np.flatnonzero(np.isnan(values))[0]))
    days = pd.to_datetime(pd.DataFrame({"year": year, "month": parts["month"], "day": parts["day"]}),
                          errors="coerce")
    if days.isna().any():
        row = int(np.flatnonzero(days.isna().to_numpy())[0])
        raise InputError("not a calendar date", file=source, column="day", row=row)
    out = frame.copy()
    out["timestamp"] = days + pd.to_timedelta(parts["hour"] - 1, unit="h")
    return out
