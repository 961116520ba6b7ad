"""The season a surrogate trains on: the period's months and a margin, segments cut at month gaps."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
import pytest

from pipeline.errors import InputError
from surrogates.config import TrainConfig, season_months
from surrogates.train import Segment, within_months


@pytest.mark.parametrize(("start", "end", "margin", "months"), [
    (dt.date(2018, 6, 1), dt.date(2018, 6, 30), 1, (5, 6, 7)),
    (dt.date(2018, 1, 1), dt.date(2018, 1, 31), 1, (1, 2, 12)),  # December before January: the year wraps
    (dt.date(2018, 12, 10), dt.date(2019, 2, 3), 1, (1, 2, 3, 11, 12)),
    (dt.date(2018, 6, 1), dt.date(2018, 6, 7), 0, (6,)),
    (dt.date(2018, 3, 1), dt.date(2018, 8, 31), 2, (1, 2, 3, 4, 5, 6, 7, 8, 9, 10)),
    (dt.date(2018, 1, 1), dt.date(2018, 12, 31), 1, ()),  # the whole year: every month
    (dt.date(2018, 1, 1), dt.date(2019, 1, 1), 0, ()),  # a year and a day: not "January"
    (dt.date(2018, 2, 1), dt.date(2018, 11, 30), 1, ()),  # ten months and a margin cover the year
])
def test_season_months(start, end, margin, months):
    assert season_months(start, end, margin) == months


def test_months_must_be_calendar_months():
    with pytest.raises(InputError, match="months"):
        TrainConfig(months=(0, 1))
    with pytest.raises(InputError, match="months"):
        TrainConfig(months=(13,))


def test_within_months_cuts_segments_at_gaps():
    # one run over a whole year: its December and January are two segments, never one sample across the gap
    months = pd.date_range("2018-01-01", "2018-12-31 23:00", freq="h").month
    table = pd.DataFrame({"reference": 2, "month": months})
    splits = {"train": [Segment(2, 0, len(table))], "validation": [Segment(2, 0, 744)], "test": []}
    cut = within_months(table, splits, (12, 1, 2))
    jan_feb = (31 + 28) * 24
    assert cut["train"] == [Segment(2, 0, jan_feb), Segment(2, len(table) - 31 * 24, len(table))]
    assert cut["validation"] == [Segment(2, 0, 744)]  # already inside
    assert cut["test"] == []
    rows = np.concatenate([np.arange(s.start, s.stop) for s in cut["train"]])
    assert set(table["month"].to_numpy()[rows]) == {12, 1, 2}
    assert len(rows) == int(np.isin(months, (12, 1, 2)).sum())
    assert within_months(table, splits, (7,))["validation"] == []
