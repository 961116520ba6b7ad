"""The ILV table contract: a valid table passes unchanged, every kind of bad input fails once and clearly."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pipeline.errors import InputError
from surrogates.ilv import REQUIRED_COLUMNS, calendar_columns, read_ilv, validate_ilv, write_ilv


def make_table(hours: int = 48, references: tuple[int, ...] = (0, 2)) -> pd.DataFrame:
    """A small valid table; 2026-01-05 is a Monday."""
    frames = []
    for ref in references:
        stamps = pd.date_range("2026-01-05 00:00", periods=hours, freq="h")
        frame = pd.DataFrame({"reference": ref, "timestamp": stamps.strftime("%Y-%m-%d %H:%M:%S")})
        frame = pd.concat([frame, calendar_columns(stamps)], axis=1)
        frame["direct_solar_irradiance"] = 100.0
        frame["diffuse_solar_irradiance"] = 50.0
        frame["outdoor_dry_bulb_temperature"] = 5.0
        frame["occupant_count"] = 2.0
        frame["cooling_demand"] = 0.0
        frame["heating_demand"] = 1.5
        frame["indoor_dry_bulb_temperature"] = 20.0 + ref
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def test_calendar_columns_by_hand():
    stamps = pd.DatetimeIndex(["2026-01-05 00:00", "2026-01-11 23:00", "2026-12-25 10:00"])
    cal = calendar_columns(stamps, holidays={pd.Timestamp("2026-12-25").date()})
    # Monday 00:00 -> hour 1, day_type 1; Sunday 23:00 -> hour 24, day_type 7; Christmas -> holiday 8
    assert cal["hour"].tolist() == [1, 24, 11]
    assert cal["day_type"].tolist() == [1, 7, 8]
    assert cal["month"].tolist() == [1, 1, 12]


def test_valid_table_round_trips_csv_and_parquet(tmp_path):
    table = make_table()
    shuffled = table.sample(frac=1.0, random_state=0)
    clean = validate_ilv(shuffled)
    assert list(clean.columns) == list(REQUIRED_COLUMNS)
    assert clean["reference"].tolist() == [0] * 48 + [2] * 48
    assert clean["timestamp"].iloc[0] == pd.Timestamp("2026-01-05 00:00")
    assert clean["indoor_dry_bulb_temperature"].iloc[-1] == 22.0
    for name in ("t.csv", "t.parquet"):
        path = write_ilv(table, tmp_path / name)
        back = read_ilv(path)
        pd.testing.assert_frame_equal(back, clean)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv", "t.parquet"]  # no temp files left


def test_set_point_column_kept():
    table = make_table()
    table["indoor_dry_bulb_temperature_set_point"] = 21.0
    assert validate_ilv(table)["indoor_dry_bulb_temperature_set_point"].eq(21.0).all()


def test_non_shiftable_load_kept_and_checked():
    table = make_table()
    table["non_shiftable_load"] = 0.4
    assert list(validate_ilv(table).columns)[-1] == "non_shiftable_load"
    table.loc[7, "non_shiftable_load"] = -0.1  # electricity in the hour cannot be negative
    assert (error_of(table).column, error_of(table).row) == ("non_shiftable_load", 7)


def error_of(table: pd.DataFrame, **kwargs) -> InputError:
    with pytest.raises(InputError) as info:
        validate_ilv(table, source="ilv.csv", **kwargs)
    return info.value


def test_missing_column():
    error = error_of(make_table().drop(columns="occupant_count"))
    assert error.column == "occupant_count" and "ilv.csv" in str(error)


def test_nan_names_first_row():
    table = make_table()
    table.loc[[7, 30], "outdoor_dry_bulb_temperature"] = np.nan
    error = error_of(table)
    assert (error.column, error.row) == ("outdoor_dry_bulb_temperature", 7)


def test_gap_in_hours():
    table = make_table().drop(index=[60]).reset_index(drop=True)  # reference 2, hour 12 missing
    error = error_of(table)
    assert error.column == "timestamp" and "gap of 2 h" in str(error)
    assert error.row == 60 and "2026-01-05 13:00" in str(error)


def test_duplicated_hour():
    table = make_table()
    table = pd.concat([table, table.iloc[[5]]], ignore_index=True)
    assert "duplicated timestamp" in str(error_of(table))


def test_only_one_reference_run():
    error = error_of(make_table(references=(0,)))
    assert error.column == "reference" and "1 reference run" in str(error)


def test_negative_load_and_wrong_calendar():
    table = make_table()
    table.loc[3, "cooling_demand"] = -1.0
    assert (error_of(table).column, error_of(table).row) == ("cooling_demand", 3)
    table = make_table()
    table.loc[4, "hour"] = 4  # 04:00 is hour-ending 5
    assert (error_of(table).column, error_of(table).row) == ("hour", 4)
    table = make_table()
    table.loc[2, "day_type"] = 3  # a Monday
    assert error_of(table).column == "day_type"


def test_unparseable_timestamp_and_text_number(tmp_path):
    table = make_table()
    table.loc[9, "timestamp"] = "yesterday"
    assert (error_of(table).column, error_of(table).row) == ("timestamp", 9)
    table = make_table()
    table["occupant_count"] = table["occupant_count"].astype(str)
    table.loc[1, "occupant_count"] = "two"
    assert (error_of(table).column, error_of(table).row) == ("occupant_count", 1)


def test_read_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_ilv(tmp_path / "nope.csv")
    (tmp_path / "t.txt").write_text("x")
    with pytest.raises(InputError, match="unknown ILV table format"):
        read_ilv(tmp_path / "t.txt")
