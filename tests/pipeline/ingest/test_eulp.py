"""EULP: generated fixtures in the real column layout -> CityLearn building rows; HTTP download; bad input."""

from __future__ import annotations

import hashlib

import numpy as np
import pandas as pd
import pytest

from pipeline.errors import InputError
from pipeline.ingest.commands import write_building
from pipeline.ingest.eulp import read_eulp_timeseries, timeseries_path

KWH_PER_KBTU = 1055.05585262 / 3600  # International Table Btu: 1055.05585262 J; kBtu -> kWh
START = pd.Timestamp("2018-06-01")
HEAT_HOUR = pd.Timestamp("2018-06-02 05:00")  # the hour 05:00-06:00 has a heating load larger than cooling


def _timeseries(step="15min", days=3) -> pd.DataFrame:
    """A building in the EULP timeseries layout: timestamp = END of the interval, kWh and kBtu per interval."""
    ends = pd.date_range(START + pd.Timedelta(step), START + pd.Timedelta(days=days), freq=step)
    n = len(ends)
    per_hour = int(pd.Timedelta("1h") / pd.Timedelta(step))
    plug = np.full(n, 0.1)
    plug[0] = 1.0  # the interval ending 00:15 belongs to the hour 00:00-01:00 (CityLearn row 0, hour 1)
    if per_hour > 1:
        plug[per_hour - 1] = 0.5  # the interval ending 01:00 too
    heating = np.zeros(n)
    begins = ends - pd.Timedelta(step)
    heating[begins.floor("h") == HEAT_HOUR] = 2.0
    temperature = np.tile(np.linspace(24.0, 24.6, per_hour), n // per_hour)
    frame = pd.DataFrame({
        "timestamp": ends,
        "bldg_id": 1001,
        "out.electricity.interior_lighting.energy_consumption": np.full(n, 0.05),
        "out.electricity.plug_loads.energy_consumption": plug,
        "out.electricity.cooling.energy_consumption": np.full(n, 0.3),
        "out.electricity.fans_cooling.energy_consumption": np.full(n, 0.02),
        "out.electricity.water_systems.energy_consumption": np.full(n, 0.2),
        "out.electricity.pv.energy_consumption": np.full(n, -0.1),
        "out.electricity.total.energy_consumption": 0.05 + plug + 0.3 + 0.02 + 0.2,
        "out.natural_gas.heating.energy_consumption": np.zeros(n),
        "out.electricity.plug_loads.energy_consumption_intensity": plug / 2000,
        "out.load.cooling.energy_delivered.kbtu": np.full(n, 1.0),
        "out.load.heating.energy_delivered.kbtu": heating,
        "out.load.hot_water.energy_delivered.kbtu": np.full(n, 0.25),
        "out.zone_mean_air_temp.conditioned_space.c": temperature,
    })
    return frame


def _metadata() -> pd.DataFrame:
    return pd.DataFrame({"bldg_id": [1001, 1002], "in.state": ["TX", "TX"], "in.county": ["G4804530"] * 2,
                         "in.cooling_setpoint": ["76F", "78F"], "in.heating_setpoint": ["68F", "70F"],
                         "in.occupants": ["3", "2"]})


@pytest.fixture
def release(tmp_path):
    """A local release folder laid out as the OEDI data lake, with a SHA256SUMS file."""
    root = tmp_path / "resstock_amy2018_release_2"
    (root / "metadata").mkdir(parents=True)
    _metadata().to_parquet(root / "metadata" / "metadata.parquet", index=False)
    series = root / timeseries_path(1001, 0, "TX")
    series.parent.mkdir(parents=True)
    _timeseries().to_parquet(series, index=False)
    _write_sums(root, ["metadata/metadata.parquet", timeseries_path(1001, 0, "TX")])
    return root


def _write_sums(root, relatives, wrong=()):
    lines = []
    for relative in relatives:
        digest = hashlib.sha256((root / relative).read_bytes()).hexdigest()
        lines.append(f"{'0' * 64 if relative in wrong else digest}  {relative}")
    (root / "SHA256SUMS").write_text("\n".join(lines) + "\n")


def _convert(source, tmp_path, **kwargs):
    out = write_building(source, 1001, "2018-06-01", "2018-06-03", tmp_path / "out" / "Building_1.csv",
                         cache_dir=tmp_path / "cache", **kwargs)
    return pd.read_csv(out)


def test_local_release_converts_with_exact_units_and_interval_shift(release, tmp_path):
    table = _convert(release, tmp_path)
    assert len(table) == 72 and table["hour"].tolist()[:3] == [1, 2, 3] and table["day_type"].iloc[0] == 5
    # hour 00:00-01:00 = the four intervals ending 00:15 .. 01:00: lighting 4 x 0.05 + plug 1.0 + 0.1 + 0.1 + 0.5
    assert table["non_shiftable_load"].iloc[0] == pytest.approx(0.2 + 1.7, abs=1e-12)
    assert table["non_shiftable_load"].iloc[1] == pytest.approx(0.2 + 0.4, abs=1e-12)
    cooling = table["cooling_demand"].to_numpy()
    # the files hold 10 significant digits ("%.10g"): relative error <= 5e-10
    assert cooling[0] == pytest.approx(4 * KWH_PER_KBTU, rel=1e-9)
    assert table["dhw_demand"].to_numpy() == pytest.approx(np.full(72, 1.0 * KWH_PER_KBTU), rel=1e-9)
    heat_row = 24 + 5
    assert table["heating_demand"].iloc[heat_row] == pytest.approx(8 * KWH_PER_KBTU, rel=1e-9)
    assert cooling[heat_row] == 0.0 and table["hvac_mode"].iloc[heat_row] == 2
    assert ((table["cooling_demand"] * table["heating_demand"]) == 0).all()
    assert table["indoor_dry_bulb_temperature"].to_numpy() == pytest.approx(np.full(72, 24.3))
    set_point = table["indoor_dry_bulb_temperature_set_point"]
    assert set_point.iloc[0] == pytest.approx((76 - 32) / 1.8) and set_point.iloc[heat_row] == pytest.approx(20.0)
    assert table["average_unmet_cooling_setpoint_difference"].iloc[0] == pytest.approx(24.3 - (76 - 32) / 1.8)
    assert (table["occupant_count"] == 3).all() and (table["solar_generation"] == 0).all()


def test_hourly_csv_timeseries_and_v21_layout(release, tmp_path):
    hourly = _timeseries(step="1h")
    path = release / timeseries_path(1001, 0, "TX")
    path.unlink()
    hourly.to_csv(path.with_suffix(".csv"), index=False)
    out = write_building(release, 1001, "2018-06-01", "2018-06-01", tmp_path / "b.csv", layout="v2.1",
                         cache_dir=tmp_path / "cache")
    table = pd.read_csv(out)
    assert table.columns[7] == "Equipment Electric Power (kWh)"
    assert table.iloc[0, 7] == pytest.approx(0.05 + 1.0)  # the row ending 01:00 is hour 1
    assert table.iloc[1, 7] == pytest.approx(0.05 + 0.1)
    assert table.iloc[0, 9] == pytest.approx(KWH_PER_KBTU)


def test_http_source_matches_local_and_reuses_cache(release, tmp_path, http_server):
    base, state = http_server(release.parent)
    url = f"{base}/{release.name}"
    remote = _convert(url, tmp_path)
    pd.testing.assert_frame_equal(remote, _convert(release, tmp_path))
    count = len(state["requests"])
    _convert(url, tmp_path)
    assert len(state["requests"]) == count  # everything came from the verified cache
    cached = list((tmp_path / "cache").rglob("*.parquet"))
    assert len(cached) == 2 and all(p.with_name(p.name + ".sha256").exists() for p in cached)


def test_truncated_download_is_refused_and_not_cached(release, tmp_path, http_server):
    base, state = http_server(release.parent)
    relative = f"/{release.name}/{timeseries_path(1001, 0, 'TX')}"
    state["truncate"].add(relative)
    with pytest.raises(InputError, match="truncated download: received") as caught:
        _convert(f"{base}/{release.name}", tmp_path)
    assert relative in str(caught.value)
    assert not [p for p in (tmp_path / "cache").rglob("*") if p.is_file() and "1001-0" in p.name]


def test_checksum_mismatch_is_refused_and_not_cached(release, tmp_path, http_server):
    _write_sums(release, ["metadata/metadata.parquet", timeseries_path(1001, 0, "TX")],
                wrong={timeseries_path(1001, 0, "TX")})
    base, _ = http_server(release.parent)
    with pytest.raises(InputError, match="checksum mismatch") as caught:
        _convert(f"{base}/{release.name}", tmp_path)
    assert "1001-0.parquet" in str(caught.value)
    assert not [p for p in (tmp_path / "cache").rglob("*") if p.is_file() and "1001-0" in p.name]


def test_corrupted_cache_file_is_fetched_again(release, tmp_path, http_server):
    base, state = http_server(release.parent)
    url = f"{base}/{release.name}"
    _convert(url, tmp_path)
    cached = next((tmp_path / "cache").rglob("1001-0.parquet"))
    cached.write_bytes(b"garbage")
    _convert(url, tmp_path)
    assert state["requests"].count(f"/{release.name}/{timeseries_path(1001, 0, 'TX')}") == 2


# ---------------------------------------------------------------- bad input (CSV timeseries)
def _csv(tmp_path, frame):
    path = tmp_path / "1001-0.csv"
    frame.to_csv(path, index=False)
    return path


def _text_edit(frame: pd.DataFrame, row: int, column: str, value: str) -> pd.DataFrame:
    frame = frame.astype({column: object})
    frame.loc[row, column] = value
    return frame


@pytest.mark.parametrize(
    ("edit", "message", "column", "row"),
    [
        (lambda f: f.drop(columns="out.load.hot_water.energy_delivered.kbtu"), "missing column",
         "out.load.hot_water.energy_delivered.kbtu", 1),
        (lambda f: _text_edit(f, 10, "out.load.cooling.energy_delivered.kbtu", "lots"), "non-numeric",
         "out.load.cooling.energy_delivered.kbtu", 12),
        (lambda f: _text_edit(f, 20, "out.electricity.plug_loads.energy_consumption", "-0.4"), "negative energy",
         "out.electricity.plug_loads.energy_consumption", 22),
        (lambda f: f.drop(index=30), "gap", "timestamp", 32),
        (lambda f: pd.concat([f.iloc[:41], f.iloc[40:]]), "duplicate timestamp", "timestamp", 43),
    ],
    ids=["missing-column", "non-numeric", "negative", "gap", "duplicate"],
)
def test_timeseries_bad_input(tmp_path, edit, message, column, row):
    path = _csv(tmp_path, edit(_timeseries(days=1)))
    with pytest.raises(InputError) as caught:
        read_eulp_timeseries(path)
    text = str(caught.value)
    assert message in text and str(path) in text and repr(column) in text and f"row {row}" in text


def test_period_outside_the_file(release, tmp_path):
    with pytest.raises(InputError, match="outside the file") as caught:
        write_building(release, 1001, "2018-06-03", "2018-06-04", tmp_path / "b.csv", cache_dir=tmp_path / "c")
    assert "1001-0.parquet" in str(caught.value) and "2018-06-04 00:00:00" in str(caught.value)
    assert not (tmp_path / "b.csv").exists()


def test_unknown_building_and_bad_setpoint(release, tmp_path):
    with pytest.raises(InputError, match="building 1003"):
        write_building(release, 1003, "2018-06-01", "2018-06-01", tmp_path / "b.csv", cache_dir=tmp_path / "c")
    meta = _metadata()
    meta.loc[0, "in.cooling_setpoint"] = "cool"
    meta.to_parquet(release / "metadata" / "metadata.parquet", index=False)
    with pytest.raises(InputError, match="'in.cooling_setpoint', row bldg_id 1001: expected a set point"):
        write_building(release, 1001, "2018-06-01", "2018-06-01", tmp_path / "b.csv", cache_dir=tmp_path / "c")


def test_solar_noon_lag_detects_an_eastern_time_series():
    from pipeline.ingest.eulp import solar_noon_lag_hours

    hours = pd.date_range("2018-06-01", periods=24 * 10, freq="h")
    # a symmetric day centred on Austin's mean solar noon in CST: 12 h + (-90 + 97.77) / 15 = 12.52 h
    centre = 12.0 + (-90.0 + 97.77) / 15.0
    mid = hours.hour + 0.5
    local = pd.Series(np.clip(np.cos((mid - centre) / 24 * 2 * np.pi), 0, None), index=hours, name="pv")
    assert solar_noon_lag_hours(local, -97.77, -6.0) == pytest.approx(0.0, abs=0.05)
    # the same output labelled in Eastern standard time appears one hour later on the clock
    eastern = pd.Series(local.to_numpy(), index=hours + pd.Timedelta(hours=1), name="pv")
    assert solar_noon_lag_hours(eastern, -97.77, -6.0) == pytest.approx(1.0, abs=0.05)


def test_command_notes_pv_output_off_solar_noon(release, tmp_path, epw_path, capsys):
    frame = _timeseries()
    begins = frame["timestamp"] - pd.Timedelta("15min")
    mid = begins.dt.hour + begins.dt.minute / 60 + 0.125
    # PV output centred 1 h after Austin's solar noon in CST, as Eastern-time labels would show it
    shape = np.clip(np.cos((mid - 13.52) / 24 * 2 * np.pi), 0, None)
    frame["out.electricity.pv.energy_consumption"] = -0.5 * shape
    frame.to_parquet(release / timeseries_path(1001, 0, "TX"), index=False)
    table = _convert(release, tmp_path, weather=epw_path)
    assert "try --timestamp-offset -1" in capsys.readouterr().err
    assert table["solar_generation"].max() > 300  # W/kW around noon from the EPW


def test_standard_time_series_has_no_gap_on_dst_change_days(tmp_path):
    """EULP timestamps are standard time: the spring and fall change days keep 24 hours each."""
    from pipeline.ingest.calendar import calendar_columns
    from pipeline.ingest.eulp import building_loads

    for day in ("2018-03-11", "2018-11-04"):
        ends = pd.date_range(pd.Timestamp(day) + pd.Timedelta("15min"), pd.Timestamp(day) + pd.Timedelta("1D"),
                             freq="15min")
        frame = _timeseries().iloc[: len(ends)].assign(timestamp=ends)
        path = tmp_path / f"{day}.parquet"
        frame.to_parquet(path, index=False)
        series, meta = read_eulp_timeseries(path)
        loads = building_loads(series, _metadata().set_index("bldg_id").loc[1001])
        assert len(loads) == 24 and loads.index[0] == pd.Timestamp(day)
        status = calendar_columns(loads.index, timezone="America/Chicago")["daylight_savings_status"]
        assert status.sum() == (22 if day.startswith("2018-03") else 1)
