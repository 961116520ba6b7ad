"""Checks and selections on hourly time indexes (local standard time, interval-beginning, tz-naive)."""

from __future__ import annotations

import datetime as dt

import pandas as pd

from pipeline.errors import InputError

HOUR = pd.Timedelta(hours=1)


def parse_date(value: str | dt.date, *, key: str = "date") -> pd.Timestamp:
    """A calendar date (``YYYY-MM-DD``) as a midnight Timestamp; InputError naming ``key`` if malformed."""
    try:
        stamp = pd.Timestamp(value)
    except (ValueError, TypeError) as error:
        raise InputError(f"expected a date YYYY-MM-DD, got {value!r}", column=key) from error
    if stamp != stamp.normalize():
        raise InputError(f"expected a whole date YYYY-MM-DD, got {value!r}", column=key)
    return stamp


def period_index(start: str | dt.date, end: str | dt.date) -> pd.DatetimeIndex:
    """Hourly interval-beginning index from ``start`` 00:00 to ``end`` 23:00 (both dates inclusive)."""
    first, last = parse_date(start, key="start"), parse_date(end, key="end")
    if last < first:
        raise InputError(f"end {last.date()} is before start {first.date()}", column="end")
    return pd.date_range(first, last + pd.Timedelta(hours=23), freq="h")


def check_regular(index: pd.DatetimeIndex, step: pd.Timedelta, *, file: object, column: str,
                  first_row: int = 2) -> None:
    """Raise InputError on the first duplicate, out-of-order or missing timestamp.

    ``first_row`` is the file row (1-based) of ``index[0]``, so messages name the row a user sees.
    """
    if len(index) == 0:
        raise InputError("no data rows", file=file, column=column)
    diffs = index[1:] - index[:-1]
    bad = (diffs != step).nonzero()[0]
    if len(bad):
        i = int(bad[0]) + 1
        if diffs[i - 1] == pd.Timedelta(0):
            what = f"duplicate timestamp {index[i]}"
        elif diffs[i - 1] < pd.Timedelta(0):
            what = f"timestamp {index[i]} goes back in time after {index[i - 1]}"
        else:
            what = f"gap: {index[i - 1]} is followed by {index[i]} (expected a step of {step})"
        raise InputError(what, file=file, column=column, row=first_row + i)


def select_period(frame: pd.DataFrame, index: pd.DatetimeIndex, *, file: object) -> pd.DataFrame:
    """Rows of ``frame`` at exactly the hours of ``index``; InputError if the file does not cover them."""
    missing = index.difference(frame.index)
    if len(missing):
        covered = f"{frame.index[0]} .. {frame.index[-1]}" if len(frame) else "nothing"
        raise InputError(
            f"period {index[0]} .. {index[-1]} is outside the file (first missing hour {missing[0]}; "
            f"the file covers {covered}, local standard time, interval-beginning)",
            file=file,
        )
    return frame.loc[index]
