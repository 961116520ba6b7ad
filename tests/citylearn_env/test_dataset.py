"""The dataset contract: CSV round trips in both layouts, v2.1 header matching, calendar, periodic encodings,
the LSTM dynamics block and the schema writer."""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import numpy as np
import pytest

from citylearn_env import dataset
from citylearn_env.dataset import (
    BUILDING_COLUMNS,
    DynamicsBlock,
    calendar,
    parse_dynamics,
    periodic_encoding,
    read_table,
    split_periodic_name,
    write_table,
)
from citylearn_env.emit import BuildingEntry, building_spec, schema_document
from citylearn_env.errors import SchemaError
from tests.conftest import SHARED, need_shared

UPSTREAM = SHARED / "data" / "citylearn" / "upstream" / "v2.1.2"


def _building(hours: int = 24) -> dict[str, np.ndarray]:
    """A building table of known values: 2018-06-01 (a Friday), loads with simple closed forms."""
    t = np.arange(hours, dtype=float)
    return {
        **calendar("2018-06-01T00", hours),
        "indoor_dry_bulb_temperature": 24.0 + 0.1 * t,
        "average_unmet_cooling_setpoint_difference": np.zeros(hours),
        "indoor_relative_humidity": np.full(hours, 50.0),
        "non_shiftable_load": 0.25 + 0.01 * t,
        "dhw_demand": np.full(hours, 0.125),
        "cooling_demand": 0.5 * (t % 2),
        "heating_demand": np.zeros(hours),
        "solar_generation": np.where((t > 6) & (t < 19), 400.0, 0.0),
        "occupant_count": np.full(hours, 3.0),
        "indoor_dry_bulb_temperature_set_point": np.full(hours, 24.0),
        "hvac_mode": np.ones(hours),
        "power_outage": np.zeros(hours),
    }


# ------------------------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("layout", ["v2.1", "v2.2"])
def test_building_round_trip(tmp_path, layout):
    data = _building()
    path = write_table(tmp_path / "b.csv", "building", data, layout)
    head = path.read_text().splitlines()[0].split(",")
    written = [c for c in BUILDING_COLUMNS if c in data]
    assert head == ([BUILDING_COLUMNS[c] for c in written] if layout == "v2.1" else written)
    assert path.read_text().splitlines()[1].split(",")[:3] == ["6", "1", "5"]  # June, hour 1, Friday
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o644
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.csv"]  # no temporary file left
    back = read_table(path, "building")
    assert set(back) == set(BUILDING_COLUMNS)
    for name, values in data.items():  # the reader rounds through float32, as CityLearn 2.1
        np.testing.assert_array_equal(back[name], values.astype(np.float32).astype(np.float64), err_msg=name)
    assert back["non_shiftable_load"][23] == np.float32(0.48)  # 0.25 + 0.01 x 23
    assert read_table(path, "building", n_rows=5)["hour"].tolist() == [1.0, 2.0, 3.0, 4.0, 5.0]


@pytest.mark.parametrize("layout", ["v2.1", "v2.2"])
def test_pricing_and_carbon_round_trip(tmp_path, layout):
    price = np.array([0.0289, 0.0291, 0.0587])
    pricing = {"electricity_pricing": price, "electricity_pricing_predicted_6h": price,
               "electricity_pricing_predicted_12h": price, "electricity_pricing_predicted_24h": price}
    p = write_table(tmp_path / "pricing.csv", "pricing", pricing, layout)
    c = write_table(tmp_path / "carbon.csv", "carbon", {"carbon_intensity": np.array([0.4, 0.45, 0.5])}, layout)
    assert c.read_text().splitlines()[0] == ("kg_CO2/kWh" if layout == "v2.1" else "carbon_intensity")
    assert p.read_text().splitlines()[1] == "0.0289,0.0289,0.0289,0.0289"
    assert read_table(p, "pricing")["electricity_pricing"][2] == np.float32(0.0587)
    assert read_table(c, "carbon")["carbon_intensity"].tolist() == [float(np.float32(v)) for v in (0.4, 0.45, 0.5)]


def test_optional_building_columns_default(tmp_path):
    data = {k: v for k, v in _building(4).items() if k in list(BUILDING_COLUMNS)[:12]}
    path = write_table(tmp_path / "b.csv", "building", data, "v2.1")
    assert len(path.read_text().splitlines()[0].split(",")) == 12
    assert read_table(path, "building")["hvac_mode"].tolist() == [1.0] * 4  # documented default: cooling
    assert read_table(path, "building", missing_hvac_mode_is_off=True)["hvac_mode"].tolist() == [0.0] * 4
    assert read_table(path, "building")["occupant_count"].tolist() == [0.0] * 4


def test_write_errors_name_file_and_column(tmp_path):
    data = _building(3)
    with pytest.raises(SchemaError, match=r"b.csv, column/key 'bogus'.*not a CityLearn building column"):
        write_table(tmp_path / "b.csv", "building", data | {"bogus": np.zeros(3)})
    with pytest.raises(SchemaError, match=r"b.csv, column/key 'dhw_demand'.*missing column"):
        write_table(tmp_path / "b.csv", "building", {k: v for k, v in data.items() if k != "dhw_demand"})
    with pytest.raises(SchemaError, match=r"b.csv, column/key 'occupant_count'.*positional"):
        write_table(tmp_path / "b.csv", "building", {k: v for k, v in data.items() if k != "occupant_count"},
                    "v2.1")
    bad = data | {"cooling_demand": np.array([0.0, np.nan, 0.0])}
    with pytest.raises(SchemaError, match=r"b.csv, column/key 'cooling_demand', row 1 \(file line 3\): NaN"):
        write_table(tmp_path / "b.csv", "building", bad)
    assert not (tmp_path / "b.csv").exists()


# ---------------------------------------------------------------------------------- v2.1 header matching
def _v21_file(tmp_path: Path) -> Path:
    return write_table(tmp_path / "Building_1.csv", "building", _building(6), "v2.1")


def _rewrite(path: Path, edit) -> None:
    rows = [line.split(",") for line in path.read_text().splitlines()]
    rows = [edit(list(r)) for r in rows]
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")


def _drop(column: int):
    return lambda r: r[:column] + r[column + 1:]


def test_v21_dropped_column(tmp_path):
    path = _v21_file(tmp_path)
    _rewrite(path, _drop(8))  # DHW Heating (kWh)
    with pytest.raises(SchemaError, match=r"Building_1.csv, column/key 'DHW Heating \(kWh\)': missing column"):
        read_table(path, "building")


def test_v21_extra_column(tmp_path):
    path = _v21_file(tmp_path)
    _rewrite(path, lambda r: r + (["Extra"] if r[0] == "Month" else ["1"]))
    with pytest.raises(SchemaError, match=r"Building_1.csv, column/key 'Extra': unexpected column 17 of 17"):
        read_table(path, "building")


def test_v21_renamed_column(tmp_path):
    path = _v21_file(tmp_path)
    _rewrite(path, lambda r: [("Cooling Loads" if c == "Cooling Load (kWh)" else c) for c in r])
    with pytest.raises(SchemaError, match=r"Building_1.csv, column/key 'Cooling Loads': unexpected column 10 "
                                          r"of 16 \(renamed\? CityLearn 2.1 expects 'Cooling Load \(kWh\)'"):
        read_table(path, "building")


def test_v21_swapped_columns(tmp_path):
    path = _v21_file(tmp_path)
    _rewrite(path, lambda r: r[:9] + [r[10], r[9]] + r[11:])  # cooling <-> heating load
    with pytest.raises(SchemaError, match=r"Building_1.csv, column/key 'Heating Load \(kWh\)': stands in column "
                                          r"10, where CityLearn 2.1 .* expects 'Cooling Load \(kWh\)'"):
        read_table(path, "building")


def test_v22_columns_are_read_by_name_in_any_order(tmp_path):
    path = write_table(tmp_path / "b.csv", "building", _building(6), "v2.2")
    _rewrite(path, lambda r: r[:9] + [r[10], r[9]] + r[11:])
    np.testing.assert_array_equal(read_table(path, "building")["cooling_demand"], 0.5 * (np.arange(6) % 2))


def test_square_bracket_spellings_are_the_same_columns(tmp_path):
    path = _v21_file(tmp_path)
    expected = read_table(path, "building")
    _rewrite(path, lambda r: [c.replace("(", "[").replace(")", "]") for c in r])
    assert path.read_text().startswith("Month,Hour,Day Type,Daylight Savings Status,Indoor Temperature [C],")
    got = read_table(path, "building")
    for name in expected:
        np.testing.assert_array_equal(got[name], expected[name])


def test_every_real_v21_header_spelling_is_accepted():
    """Header texts of real CityLearn 2.1.2 files (collected from all 16 data sets and the golden data set)."""
    need_shared(UPSTREAM / "baeda_3dem" / "pricing.csv", UPSTREAM / "citylearn_challenge_2020_climate_zone_1")
    prices = read_table(UPSTREAM / "baeda_3dem" / "pricing.csv", "pricing", n_rows=3)  # 1h/2h/3h forecasts
    assert set(prices) == set(dataset.PRICING_COLUMNS)
    weather = read_table(UPSTREAM / "citylearn_challenge_2020_climate_zone_1" / "weather.csv", "weather", n_rows=3)
    assert set(weather) == set(dataset.WEATHER_COLUMNS)  # "Relative Humidity [%]", "6h Prediction ..." texts
    for text in ("Indoor Temperature [C]", "Occupant Count [people]", "HVAC Mode [Off/Cooling/Heating]",
                 "6h Prediction Outdoor Drybulb Temperature [C]", "24h Outdoor Relative Humidity (%)"):
        assert text in dataset.V21_HEADERS


# ---------------------------------------------------------------------------------------------- calendar
def test_calendar_on_known_dates():
    cal = calendar(np.datetime64("2018-06-01T00"), 48, holidays=["2018-06-02"])
    # 2018-06-01 is a Friday (day_type 5); hour-ending: the row beginning 00:00 is hour 1, 23:00 is hour 24
    assert cal["month"][0] == 6 and cal["hour"][0] == 1 and cal["day_type"][0] == 5
    assert cal["hour"][23] == 24 and cal["day_type"][23] == 5
    assert cal["hour"][24] == 1 and (cal["day_type"][24:] == 8).all()  # Saturday 2 June made a holiday
    assert (cal["daylight_savings_status"] == 0).all()
    new_year = calendar("2018-12-31T23", 2)  # Monday 31 Dec 23:00, then Tuesday 1 Jan 00:00
    assert new_year["month"].tolist() == [12, 1] and new_year["hour"].tolist() == [24, 1]
    assert new_year["day_type"].tolist() == [1, 2]


def test_calendar_matches_the_pipeline_calendar():
    pytest.importorskip("pandas")
    from pipeline.ingest.calendar import calendar_columns
    from pipeline.ingest.timeindex import period_index

    index = period_index("2018-07-01", "2018-07-10")
    ours = calendar(index[0].to_datetime64(), len(index), holidays=["2018-07-04"])
    theirs = calendar_columns(index, holidays=["2018-07-04"])
    for name in ("month", "hour", "day_type", "daylight_savings_status"):
        np.testing.assert_array_equal(ours[name], theirs[name].to_numpy(dtype=float), err_msg=name)


# ------------------------------------------------------------------------------------- periodic encodings
def test_periodic_encoding_values():
    sin, cos = periodic_encoding([6.0, 24.0, 12.0], 24.0)  # angles pi/2, 2 pi, pi
    np.testing.assert_allclose(sin, [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(cos, [0.0, 1.0, -1.0], atol=1e-15)
    sin, cos = periodic_encoding(8.0, 7.0)  # a holiday wraps onto Monday: angle 2 pi / 7
    assert sin == pytest.approx(0.7818314824680298, abs=1e-15) and cos == pytest.approx(0.6234898018587336, abs=1e-15)
    x = np.arange(1.0, 25.0)
    sin, cos = periodic_encoding(x, 24.0)
    np.testing.assert_array_equal(sin, np.sin(2.0 * np.pi * x / 24.0))  # bit-identical to the old copies
    np.testing.assert_array_equal(cos, np.cos(2.0 * np.pi * x / 24.0))
    assert math.sin(2.0 * math.pi * 5.0 / 12.0) == periodic_encoding(5.0, 12.0)[0]


def test_split_periodic_name():
    assert split_periodic_name("hour_sin") == ("hour", "sin")
    assert split_periodic_name("day_type_cos") == ("day_type", "cos")
    assert split_periodic_name("cooling_demand") == ("cooling_demand", None)
    assert split_periodic_name("minute_sin") == ("minute_sin", None)  # not a periodic observation
    assert split_periodic_name("minute_sin", {"minute": 60.0}) == ("minute", "sin")


# ------------------------------------------------------------------------------------------ dynamics block
def _block(filename: str = "Building_1.pth") -> DynamicsBlock:
    return DynamicsBlock(filename, ("outdoor_dry_bulb_temperature", "hour_sin", "indoor_dry_bulb_temperature"),
                         (10.0, -1.0, 18.0), (40.0, 1.0, 30.0), hidden_size=8, num_layers=2, lookback=12)


def test_dynamics_block_round_trip(tmp_path):
    block = _block()
    entry = block.to_schema()
    assert entry["type"] == "citylearn.dynamics.LSTMDynamics"
    assert entry["attributes"]["input_size"] == 3 and entry["attributes"]["filename"] == "Building_1.pth"
    assert DynamicsBlock.from_schema(entry) == block
    (tmp_path / "Building_1.pth").write_bytes(b"")
    resolved = _block(str(tmp_path / "Building_1.pth"))
    assert parse_dynamics(entry, tmp_path) == (resolved, resolved)  # v2.2: one model for both modes
    pair = dataset.dynamics_entry(block, "v2.1")
    assert parse_dynamics(pair, tmp_path) == (resolved, resolved)  # v2.1: {cooling, heating}
    assert parse_dynamics({"cooling": entry, "heating": None}, tmp_path) == (resolved, None)


def test_dynamics_block_errors(tmp_path):
    entry = _block().to_schema()
    entry["attributes"]["input_size"] = 4
    with pytest.raises(SchemaError, match=r"'b.dynamics.attributes'.*disagree in length"):
        DynamicsBlock.from_schema(entry, where="b.dynamics")
    del entry["attributes"]["lookback"]
    with pytest.raises(SchemaError, match=r"'b.dynamics.attributes.lookback'.*missing attribute"):
        DynamicsBlock.from_schema(entry, where="b.dynamics")
    with pytest.raises(SchemaError, match=r"Building_1.pth.*weights file not found"):
        parse_dynamics(_block().to_schema(), tmp_path)


# ------------------------------------------------------------------------------------------- schema writer
def test_schema_document_keys():
    devices = {"dhw_device": {"nominal_power": 1.5, "efficiency": 0.9}, "pv": {"nominal_power": 4.0}}
    entry = BuildingEntry("Building_1", devices, dynamics=_block())
    spec = building_spec(entry, "v2.1")
    assert list(spec)[:8] == ["type", "include", "energy_simulation", "weather", "pricing", "carbon_intensity",
                              "inactive_observations", "inactive_actions"]
    assert spec["type"] == "citylearn.building.LSTMDynamicsBuilding" and spec["energy_simulation"] == "Building_1.csv"
    assert spec["dhw_device"] == {"type": "citylearn.energy_model.ElectricHeater", "autosize": False,
                                  "attributes": {"nominal_power": 1.5, "efficiency": 0.9}}
    assert set(spec["dynamics"]) == {"cooling", "heating"}
    schema = schema_document([entry], hours=48, observations=["hour", "net_electricity_consumption"],
                             shared_observations={"hour"}, active_actions={"dhw_storage"}, random_seed=7)
    assert schema["simulation_end_time_step"] == 47 and schema["random_seed"] == 7
    assert schema["observations"]["hour"] == {"active": True, "shared_in_central_agent": True}
    assert [a for a, v in schema["actions"].items() if v["active"]] == ["dhw_storage"]
    assert schema["buildings"]["Building_1"]["dynamics"]["type"] == "citylearn.dynamics.LSTMDynamics"
    assert "cooling_or_heating_device" in schema["actions"]  # v2.2 layout: the whole vocabulary


def test_v2_1_schema_leaves_out_newer_actions():
    """CityLearn 2.1.2 hands every schema action to its buildings, active or not, and fails on names it does
    not know: a v2.1-layout schema lists only 2.1's actions, and asking for a newer one is an error."""
    entry = BuildingEntry("Building_1", {}, dynamics=_block())
    kwargs = {"hours": 24, "observations": ["hour"], "shared_observations": {"hour"}, "layout": "v2.1"}
    schema = schema_document([entry], active_actions={"cooling_device"}, **kwargs)
    assert list(schema["actions"]) == ["cooling_storage", "heating_storage", "dhw_storage", "electrical_storage",
                                       "cooling_device", "heating_device"]
    with pytest.raises(ValueError, match="washing_machine.*v2.2 layout"):
        schema_document([entry], active_actions={"washing_machine"}, **kwargs)
