"""CityLearn CSV writer: both layouts, integer calendar columns, atomic writes, column checks."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from citylearn_env.dataset import BUILDING_COLUMNS, BUILDING_REQUIRED, CARBON_COLUMNS
from pipeline.ingest.citylearn_csv import write_citylearn_csv


def _building(rows=3):
    frame = pd.DataFrame({name: np.full(rows, 1.5) for name in BUILDING_COLUMNS})
    frame["hour"] = [1.0, 2.0, 3.0]
    return frame


def test_both_layouts(tmp_path):
    frame = _building()
    new = write_citylearn_csv(frame, BUILDING_COLUMNS, tmp_path / "b22.csv", "v2.2")
    old = write_citylearn_csv(frame, BUILDING_COLUMNS, tmp_path / "b21.csv", "v2.1")
    assert new.read_text().splitlines()[0].split(",") == list(BUILDING_COLUMNS)
    assert old.read_text().splitlines()[0].split(",") == list(BUILDING_COLUMNS.values())
    assert new.read_text().splitlines()[1].split(",")[:3] == ["2", "1", "2"]  # month, hour, day_type as int
    assert pd.read_csv(old).iloc[:, 7].tolist() == [1.5, 1.5, 1.5]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b21.csv", "b22.csv"]  # no temp files left


def test_optional_tail_may_be_left_out_but_not_a_middle_column(tmp_path):
    frame = _building().iloc[:, :BUILDING_REQUIRED]
    path = write_citylearn_csv(frame, BUILDING_COLUMNS, tmp_path / "b.csv", "v2.1", required=BUILDING_REQUIRED)
    assert len(pd.read_csv(path).columns) == BUILDING_REQUIRED
    with pytest.raises(ValueError, match="missing CityLearn column 'dhw_demand'"):
        write_citylearn_csv(frame.drop(columns="dhw_demand"), BUILDING_COLUMNS, tmp_path / "c.csv",
                            required=BUILDING_REQUIRED)
    assert not (tmp_path / "c.csv").exists()


def test_nan_is_refused_and_nothing_written(tmp_path):
    frame = pd.DataFrame({"carbon_intensity": [0.5, np.nan]})
    with pytest.raises(ValueError, match="NaN"):
        write_citylearn_csv(frame, CARBON_COLUMNS, tmp_path / "ci.csv", "v2.1")
    assert list(tmp_path.iterdir()) == []
    path = write_citylearn_csv(frame.fillna(0.4), CARBON_COLUMNS, tmp_path / "ci.csv", "v2.1")
    assert path.read_text() == "kg_CO2/kWh\n0.5\n0.4\n"
