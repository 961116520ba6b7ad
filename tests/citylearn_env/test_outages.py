"""Power-outage signals: CityLearn 2.1 test vectors, the golden outage trace, and the corrected model."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from citylearn_env.errors import SchemaError
from citylearn_env.outages import csv_outage_signal, reliability_outage_signal
from tests.conftest import GOLDEN, need_shared


def _runs(signal: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) step of every run of ones."""
    padded = np.concatenate([[0], signal.astype(int), [0]])
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


@pytest.mark.parametrize(("seed", "n", "expected"), [
    (73055, 720, [(389, 403)]),  # day 16, start 5, 15.86 h -> 15 steps (spec §6.1)
    (65701, 720, [(312, 317), (373, 396)]),  # golden full_random_outage seed
    (65647, 720, []),  # the shipped schema seed: no outage in June
    (65647, 2208, [(1327, 1341), (1457, 1484)]),  # ... but two over the full 2208 h range
])
def test_legacy_reproduces_citylearn_vectors(seed, n, expected):
    signal = reliability_outage_signal(n, seed=seed, legacy=True)
    assert signal.shape == (n,)
    assert _runs(signal) == expected


def test_legacy_full_year_outage_days():
    runs = _runs(reliability_outage_signal(8760, seed=73055, legacy=True))
    assert sorted({first // 24 for first, _ in runs}) == [16, 320]


def test_legacy_matches_golden_outage_trace():
    path = GOLDEN / "full_random_outage" / "trace.parquet"
    need_shared(path)
    trace = pd.read_parquet(path, columns=["building", "time_step", "power_outage"])
    signal = reliability_outage_signal(720, saifi=1.436, caidi=331.2, seed=65701, legacy=True)
    for _, rows in trace.groupby("building"):
        np.testing.assert_array_equal(rows.sort_values("time_step")["power_outage"].to_numpy(), signal)


def test_legacy_day_zero_is_skipped_and_shifts_the_draws():
    # p = 0.5 per day; derive the CityLearn 2.1 signal by hand from the legacy stream (spec §6.1 order)
    seed, n_days = 3, 6
    rs = np.random.RandomState(seed)
    drawn = rs.binomial(1, 0.5, size=n_days)
    assert drawn[0] == 1 and drawn[1:].sum() >= 1, "pick a seed whose day 0 is drawn"
    starts = rs.choice(np.arange(24), size=drawn.sum())
    hours = rs.exponential(scale=240.0, size=drawn.sum()) / 60.0
    expected = np.zeros(n_days * 24, dtype=np.int8)
    for k, day in enumerate(np.flatnonzero(drawn[1:]) + 1):  # day k+... takes draw k (meant for the previous day)
        expected[int(day * 24 + starts[k]):int(day * 24 + starts[k] + hours[k])] = 1
    signal = reliability_outage_signal(n_days * 24, saifi=365 * 0.5, caidi=240.0, seed=seed, legacy=True)
    np.testing.assert_array_equal(signal, expected)
    assert not signal[:24].any()


def test_corrected_model_every_day_eligible_including_a_partial_last_day():
    # 1-min steps, p = 1: an outage starts at minute 2 of every day, day 0 and the partial day 4 included
    n = 4 * 1440 + 100
    signal = reliability_outage_signal(n, saifi=365.0, caidi=120.0, seed=1, seconds_per_time_step=60.0,
                                       start_time_steps=[2])
    assert signal.shape == (n,)
    assert [first for first, _ in _runs(signal)] == [2, 1442, 2882, 4322, 5762]
    with pytest.raises(SchemaError, match="whole number of days"):
        reliability_outage_signal(100, saifi=365.0, seed=1, legacy=True)


def test_durations_rounded_in_corrected_model_truncated_in_legacy():
    # p = 1, start at midnight, mean duration 2 h: runs never merge (a 22 h gap), so run length = duration.
    # E[rint(X)] = e^-0.25 / (1 - e^-0.5) = 1.979 h and E[floor(X)] = e^-0.5 / (1 - e^-0.5) = 1.541 h for X ~ Exp(2 h)
    n = 24 * 3650
    corrected = reliability_outage_signal(n, saifi=365.0, caidi=120.0, seed=7, start_time_steps=[0])
    legacy = reliability_outage_signal(n, saifi=365.0, caidi=120.0, seed=7, start_time_steps=[0], legacy=True)
    assert corrected.sum() / 3650 == pytest.approx(1.979, abs=0.15)
    assert legacy.sum() / 3649 == pytest.approx(1.541, abs=0.15)  # day 0 never has an outage
    assert not legacy[:24].any()


def test_sub_hourly_steps_scale_durations():
    # 15-min steps: 96 steps per day; the 2.1 generator converts minutes with 60 / 900 steps per minute
    hourly = _runs(reliability_outage_signal(720, seed=73055, legacy=True))
    quarter = _runs(reliability_outage_signal(720 * 4, seed=73055, seconds_per_time_step=900.0, legacy=True))
    assert len(quarter) == len(hourly) == 1
    assert quarter[0][0] // 96 == hourly[0][0] // 24 == 16
    length = quarter[0][1] - quarter[0][0] + 1
    assert 15 * 4 <= length <= 16 * 4  # 15.86 h


def test_bad_settings_are_refused():
    with pytest.raises(SchemaError, match="whole number of time steps"):
        reliability_outage_signal(720, seed=1, seconds_per_time_step=7000.0)
    with pytest.raises(SchemaError, match="start_time_steps"):
        reliability_outage_signal(720, seed=1, start_time_steps=[24])
    with pytest.raises(SchemaError, match="start_time_steps"):
        reliability_outage_signal(720, seed=1, start_time_steps=[2.5])
    with pytest.raises(SchemaError, match="random seed"):
        reliability_outage_signal(720, seed=-1, legacy=True)
    # integral floats (as read from JSON) are accepted
    np.testing.assert_array_equal(reliability_outage_signal(720, seed=5, start_time_steps=[3.0]),
                                  reliability_outage_signal(720, seed=5, start_time_steps=[3]))


def test_csv_outage_signal():
    np.testing.assert_array_equal(csv_outage_signal([0, 1, 1.0, 0]), [0, 1, 1, 0])
    with pytest.raises(SchemaError, match=r"b.csv, column/key 'power_outage', row 2: .*0.5"):
        csv_outage_signal([0, 1, 0.5, 2], file="b.csv")
    with pytest.raises(SchemaError, match="row 0"):
        csv_outage_signal([np.nan])
