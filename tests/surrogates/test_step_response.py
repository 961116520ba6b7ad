"""The trained surrogate reproduces the FMU's temperature response to a step in delivered heating/cooling.

FMU (Room2R2C) on an Austin TMY3 year -> ILV table (ideal, free float, 4 partial runs) -> train (defaults) ->
closed-loop stateful inference (the environment's mode). Steps: +1 kWh per hour for 6 hours on top of the
ideal loads, heating in January and cooling in July, each in a one-week episode. The expected responses
come from the FMU itself (simulated with and without the step), never from the surrogate.

Stated tolerance: over the 6 step hours and the 6 hours after, the surrogate's temperature change is within
0.35 K of the FMU's, and its peak change within 30 % of the FMU's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from surrogates.evaluate import predict_segment
from surrogates.sources.fmu import simulate_ilv_fmu
from surrogates.train import run_segments
from tests.surrogates.fmu.build import VARIABLE_MAP


def step_change(fmu: Path, loads, trained, start: int, column: str) -> tuple[np.ndarray, np.ndarray]:
    """(FMU, surrogate) temperature change over 12 h from a 6 h, +1 kWh/h step at row ``start``."""
    first = start - 5 * 24
    week = loads.iloc[first:first + 7 * 24]
    stepped = week.copy()
    stepped.iloc[start - first:start - first + 6, stepped.columns.get_loc(column)] += 1.0
    lookback = trained.config.lookback
    simulated, predicted = [], []
    for frame in (week, stepped):
        table = simulate_ilv_fmu(fmu, frame, VARIABLE_MAP, n_partial=0, start_values={"T0": 22.0})
        segment = run_segments(table)[0]
        predicted.append(predict_segment(trained.model, trained.normalization, trained.inputs, lookback, table,
                                         segment))
        simulated.append(table["indoor_dry_bulb_temperature"].to_numpy()[segment.start + lookback:segment.stop])
    k = start - first - lookback
    return (simulated[1] - simulated[0])[k:k + 12], (predicted[1] - predicted[0])[k:k + 12]


@pytest.mark.parametrize("start, column, sign", [
    (24 * 20 + 2, "heating_demand", 1.0),   # 21 January, 02:00
    (24 * 200 + 12, "cooling_demand", -1.0),  # 20 July, 12:00
])
def test_surrogate_reproduces_the_fmu_step(room_fmu, austin_surrogate, start, column, sign):
    loads, _, trained = austin_surrogate
    assert loads[column].iloc[start:start + 6].min() > 0.2  # the step is on top of a running load
    d_sim, d_pred = step_change(room_fmu, loads, trained, start, column)
    # the FMU itself: air-node jump in the first hour, more while the mass charges, decay afterwards
    assert 0.6 < sign * d_sim[0] < sign * d_sim[5] and sign * d_sim[6] < sign * d_sim[5]
    assert np.max(np.abs(d_pred - d_sim)) < 0.35, (d_sim.round(2), d_pred.round(2))
    assert np.max(sign * d_pred) == pytest.approx(np.max(sign * d_sim), rel=0.30)
