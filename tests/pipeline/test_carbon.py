"""Carbon intensity from generation by fuel, against hand-computed weighted means of the SRREN medians."""

from __future__ import annotations

import pandas as pd
import pytest

from pipeline.carbon import carbon_intensity
from pipeline.errors import InputError


def test_weighted_mean_by_hand():
    generation = pd.DataFrame({"Coal": [1.0, 0.0], "Wind": [1.0, 3.0], "Nuclear": [2.0, 1.0]},
                              index=pd.date_range("2018-06-01", periods=2, freq="h"))
    ci = carbon_intensity(generation)
    assert ci.iloc[0] == pytest.approx((1001 + 12 + 2 * 16) / 4 / 1000)
    assert ci.iloc[1] == pytest.approx((3 * 12 + 16) / 4 / 1000)


def test_storage_excluded_and_negative_other_counts_as_zero():
    generation = pd.DataFrame({"Coal": [2.0], "Other": [-0.5], "Power Storage": [5.0]})
    assert carbon_intensity(generation).iloc[0] == pytest.approx(1.001)


def test_unknown_fuel():
    with pytest.raises(InputError, match="no emission factor for fuel 'Lignite'"):
        carbon_intensity(pd.DataFrame({"Lignite": [1.0]}))
