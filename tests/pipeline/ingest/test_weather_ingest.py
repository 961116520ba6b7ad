"""Weather: the real Austin TMY3 EPW and ResStock CSV against their own rows; forecasts; bad input."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pipeline.errors import InputError
from pipeline.ingest.timeindex import period_index
from pipeline.ingest.weather import (
    ForecastSpec,
    check_weather,
    citylearn_weather,
    read_epw,
    read_resstock_weather,
    read_weather_file,
)


@pytest.fixture(scope="module")
def epw_lines(epw_path):
    return epw_path.read_text().splitlines()


@pytest.fixture(scope="module")
def austin(epw_path):
    return read_epw(epw_path, tmy_year=2018)


def _epw_row(lines, month, day, hour):
    for line in lines[8:]:
        fields = line.split(",")
        if (int(fields[1]), int(fields[2]), int(fields[3])) == (month, day, hour):
            return fields
    raise AssertionError("row not found")


def test_epw_location_and_hour_convention(austin, epw_lines):
    frame, meta = austin
    assert (meta["latitude"], meta["longitude"], meta["utc_offset_hours"]) == (30.32, -97.77, -6.0)
    assert meta["typical"] is True
    assert len(frame) == 8760 and frame.index[0] == pd.Timestamp("2018-01-01 00:00")
    assert frame.index[-1] == pd.Timestamp("2018-12-31 23:00")  # EPW hour 24 of Dec 31 starts at 23:00
    first = epw_lines[8].split(",")
    assert frame.iloc[0]["outdoor_dry_bulb_temperature_c"] == float(first[6])
    last = epw_lines[-1].split(",")
    assert (int(last[1]), int(last[2]), int(last[3])) == (12, 31, 24)
    assert frame.iloc[-1]["outdoor_relative_humidity_pct"] == float(last[8])


def test_citylearn_june_rows_equal_epw_rows(austin, epw_lines):
    frame, _ = austin
    table = citylearn_weather(frame, period_index("2018-06-01", "2018-06-30"))
    assert table.shape == (720, 16)
    for row, (day, hour) in ((0, (1, 1)), (13, (1, 14)), (719, (30, 24))):
        fields = _epw_row(epw_lines, 6, day, hour)  # CityLearn row 0 = EPW hour 1 (00:00-01:00)
        assert table.iloc[row]["outdoor_dry_bulb_temperature"] == float(fields[6])
        assert table.iloc[row]["outdoor_relative_humidity"] == float(fields[8])
        assert table.iloc[row]["diffuse_solar_irradiance"] == float(fields[15])
        assert table.iloc[row]["direct_solar_irradiance"] == float(fields[14])
    ahead = _epw_row(epw_lines, 6, 1, 7)  # perfect 6 h forecast at row 0 = EPW hour 7
    assert table.iloc[0]["outdoor_dry_bulb_temperature_predicted_6h"] == float(ahead[6])
    july = _epw_row(epw_lines, 7, 1, 24)  # 24 h forecast of the last June row reads July 1 from the file
    assert table.iloc[719]["direct_solar_irradiance_predicted_24h"] == float(july[14])


def test_units_and_ranges(austin):
    frame, _ = austin
    assert frame["outdoor_relative_humidity_pct"].between(0, 100).all()
    for column in ("ghi_w_m2", "dni_w_m2", "dhi_w_m2"):
        assert (frame[column] >= 0).all() and frame[column].max() < 1200  # W/m2 hourly means
    night = frame.index.hour.isin([0, 1, 2, 3, 22, 23])
    assert (frame.loc[night, "ghi_w_m2"] == 0).all()
    assert 15 < frame.loc["2018-07", "outdoor_dry_bulb_temperature_c"].mean() < 35  # Austin July, degC
    assert len(frame.loc["2018-03-11"]) == 24 and len(frame.loc["2018-11-04"]) == 24  # standard time: no DST


def test_noisy_forecasts_are_seeded_independent_and_bounded(austin):
    frame, _ = austin
    index = period_index("2018-06-01", "2018-06-30")
    perfect = citylearn_weather(frame, index)
    noisy = citylearn_weather(frame, index, ForecastSpec(mode="noisy", seed=7))
    again = citylearn_weather(frame, index, ForecastSpec(mode="noisy", seed=7))
    pd.testing.assert_frame_equal(noisy, again)
    err6 = noisy["outdoor_dry_bulb_temperature_predicted_6h"] - perfect["outdoor_dry_bulb_temperature_predicted_6h"]
    err24 = noisy["outdoor_dry_bulb_temperature_predicted_24h"] - perfect["outdoor_dry_bulb_temperature_predicted_24h"]
    assert err6.abs().max() <= 1.0 and err24.abs().max() <= 2.0 and err24.abs().max() > 1.5
    assert abs(np.corrcoef(err6, err24)[0, 1]) < 0.2  # independent draws per horizon
    rel_rh = noisy["outdoor_relative_humidity_predicted_6h"] / perfect["outdoor_relative_humidity_predicted_6h"] - 1
    rel_dni = noisy["direct_solar_irradiance_predicted_6h"] / perfect["direct_solar_irradiance_predicted_6h"] - 1
    both = perfect["direct_solar_irradiance_predicted_6h"].to_numpy() > 0
    both &= noisy["outdoor_relative_humidity_predicted_6h"].to_numpy() < 100
    assert abs(np.corrcoef(rel_rh[both], rel_dni[both])[0, 1]) < 0.2  # independent draws per column
    assert noisy["outdoor_relative_humidity_predicted_12h"].max() <= 100
    assert (noisy[perfect["diffuse_solar_irradiance_predicted_6h"] == 0]["diffuse_solar_irradiance_predicted_6h"]
            == 0).all()
    assert not noisy.equals(citylearn_weather(frame, index, ForecastSpec(mode="noisy", seed=8)))


def test_resstock_csv_is_hour_ending(resstock_weather_path):
    frame, _ = read_resstock_weather(resstock_weather_path)
    raw = pd.read_csv(resstock_weather_path, nrows=2)
    assert frame.index[0] == pd.Timestamp("2012-01-01 00:00")  # date_time 01:00 ends the first hour
    assert frame.iloc[0]["outdoor_dry_bulb_temperature_c"] == raw["Dry Bulb Temperature [°C]"].iloc[0]
    assert frame.iloc[1]["dhi_w_m2"] == raw["Diffuse Horizontal Radiation [W/m2]"].iloc[1]
    assert len(frame) == 8784 and frame.index[-1] == pd.Timestamp("2012-12-31 23:00")


# ---------------------------------------------------------------- bad input
def _edited_epw(tmp_path, epw_lines, row, edit):
    lines = list(epw_lines)
    edit(lines, 8 + row)
    path = tmp_path / "bad.epw"
    path.write_text("\n".join(lines) + "\n")
    return path


def _set_field(index, value):
    def edit(lines, i):
        fields = lines[i].split(",")
        fields[index] = value
        lines[i] = ",".join(fields)
    return edit


@pytest.mark.parametrize(
    ("edit", "message", "column", "row"),
    [
        (_set_field(8, "104"), "RH above 100", "outdoor_relative_humidity_pct", 110),
        (_set_field(6, "warm"), "non-numeric value 'warm'", "outdoor_dry_bulb_temperature_c (field 7)", 110),
        (_set_field(14, "-5"), "outside [0.0, 1500.0]", "dni_w_m2", 110),
        (lambda lines, i: lines.pop(i), "gap", "timestamp", 110),
        (lambda lines, i: lines.insert(i, lines[i]), "duplicate timestamp", "timestamp", 111),
    ],
    ids=["rh", "non-numeric", "negative-irradiance", "gap", "duplicate"],
)
def test_epw_bad_input(tmp_path, epw_lines, edit, message, column, row):
    path = _edited_epw(tmp_path, epw_lines, 101, edit)  # data row 101 = file line 110
    with pytest.raises(InputError) as caught:
        read_epw(path, tmy_year=2018)
    text = str(caught.value)
    assert message in text and str(path) in text and repr(column) in text and f"row {row}" in text


def test_typical_year_needs_a_year(epw_path):
    with pytest.raises(InputError, match="typical-year file"):
        read_epw(epw_path)


def test_resstock_missing_column_and_period_outside(tmp_path, resstock_weather_path):
    raw = pd.read_csv(resstock_weather_path, nrows=48)
    path = tmp_path / "w.csv"
    raw.drop(columns="Relative Humidity [%]").to_csv(path, index=False)
    with pytest.raises(InputError, match=r"column/key 'Relative Humidity \[%\]', row 1: missing column"):
        read_resstock_weather(path)
    raw.to_csv(path, index=False)
    frame, _ = read_resstock_weather(path)
    with pytest.raises(InputError, match="outside the file") as caught:
        citylearn_weather(frame, period_index("2012-01-02", "2012-01-03"), file=path)
    assert str(path) in str(caught.value) and "2012-01-03 00:00:00" in str(caught.value)


def test_weather_check_by_hand():
    index = pd.date_range("2018-06-01", periods=4, freq="h")
    weather = pd.Series([20.0, 22.0, 24.0, 26.0], index=index)
    assert check_weather(weather + 1.0, weather, what="t", file="f") == pytest.approx(1.0)
    with pytest.raises(InputError, match=r"t was simulated on other weather.*mean \|dT_out\| = 2.00"):
        check_weather(weather - 2.0, weather, what="t", file="f")
    with pytest.raises(InputError, match="no hour in common"):
        check_weather(weather.set_axis(index + pd.Timedelta(days=1)), weather, what="t", file="f")


def test_weather_file_reader_picks_the_format_by_suffix(epw_path, resstock_weather_path):
    frame, meta = read_weather_file(epw_path, tmy_year=2018)
    assert meta["latitude"] == pytest.approx(30.32, abs=0.01) and len(frame) == 8760
    assert frame.index[0] == pd.Timestamp("2018-01-01 00:00")
    frame, meta = read_weather_file(resstock_weather_path)
    assert "latitude" not in meta and "outdoor_dry_bulb_temperature_c" in frame.columns
