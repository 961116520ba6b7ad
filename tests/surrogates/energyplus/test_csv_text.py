"""The fast CSV writer of the EnergyPlus schedule files writes what numpy.savetxt writes."""

from __future__ import annotations

import io

import numpy as np
import pytest

from surrogates.energyplus.csv_text import csv_text


@pytest.mark.parametrize("fmt", ["%.6g", "%.3f"])
def test_csv_text_equals_savetxt(fmt):
    rng = np.random.default_rng(4)
    table = rng.normal(size=(1000, 5)) * np.array([1e-6, 1.0, 110.0, 3e4, 0.0])
    table[::7, 2] = 0.0
    buffer = io.StringIO()
    np.savetxt(buffer, table, fmt=fmt, delimiter=",", header="a,b,c,d,e", comments="")
    assert csv_text(["a", "b", "c", "d", "e"], table, fmt) == buffer.getvalue()


def test_csv_text_of_no_rows_is_the_header_and_a_wrong_width_is_refused():
    assert csv_text(["a", "b"], np.empty((0, 2))) == "a,b\n"
    with pytest.raises(ValueError, match="for 2 columns"):
        csv_text(["a", "b"], np.zeros((3, 3)))
