"""Issue 16 hardening of the environment: finite physics, confined paths, one clear line for every bad input.

Each test is one finding of the 105-case audit; the expected values come from the case itself (the cell or
attribute we wrote, the row we put it in, the key we changed), never from the code's own output.
"""

from __future__ import annotations

import json
import os
import shutil
import zipfile
from pathlib import Path

import pytest

from citylearn_env import CityLearnEnv, SchemaError, load_schema, make_example_env
from citylearn_env.dynamics import read_pth_state_dict
from citylearn_env.example import write_example_district
from citylearn_env.ranges import ATTRIBUTE_RANGES, COLUMN_RANGES, markdown_table
from tests.conftest import DATASET, need_shared


@pytest.fixture()
def district(tmp_path) -> Path:
    """A 2-building, 48-hour synthetic district (v2.2 named columns); returns its schema path."""
    return write_example_district(tmp_path / "d", n_buildings=2, hours=48, seed=1)


def _set_cell(path: Path, column: str, data_row: int, text: str) -> None:
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[data_row + 1].split(",")
    cells[header.index(column)] = text
    lines[data_row + 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def _edit_schema(schema: Path, edit) -> None:
    raw = json.loads(schema.read_text())
    edit(raw)
    schema.write_text(json.dumps(raw))


def _one_line(error: pytest.ExceptionInfo) -> str:
    text = str(error.value)
    assert "\n" not in text and "Traceback" not in text
    return text


# ------------------------------------------------------------------------------ finding 3: non-finite data
@pytest.mark.parametrize("file, column, row, cell, says", [
    ("Building_1.csv", "non_shiftable_load", 7, "inf", "not a finite number: inf"),
    ("Building_1.csv", "non_shiftable_load", 3, "1e400", "not a finite number: inf"),   # overflows to inf
    ("Building_2.csv", "indoor_dry_bulb_temperature", 5, "-inf", "not a finite number: -inf"),
    ("carbon_intensity.csv", "carbon_intensity", 11, "inf", "not a finite number: inf"),
    ("weather.csv", "outdoor_dry_bulb_temperature", 20, "1e6", "1e\\+06 is outside the accepted range "
                                                               "-100 <= x <= 80 degC"),
    ("pricing.csv", "electricity_pricing", 0, "1e6", "outside the accepted range"),
    ("Building_1.csv", "month", 2, "13", "13 is outside the accepted range 1 <= x <= 12"),
    ("Building_1.csv", "hour", 2, "2.5", "outside the accepted range 1 <= x <= 24 \\(integer\\)"),
])
def test_non_finite_or_impossible_cell_names_file_column_row(district, file, column, row, cell, says):
    _set_cell(district.parent / file, column, row, cell)
    with pytest.raises(SchemaError) as error:
        load_schema(district)
    text = _one_line(error)
    assert f"{file}, column/key '{column}', row {row} (file line {row + 2})" in text
    import re

    assert re.search(says, text), text


@pytest.mark.parametrize("slot, key, value, says", [
    ("electrical_storage", "depth_of_discharge", 5, "5 is outside the accepted range 0 <= x <= 1"),
    ("electrical_storage", "efficiency", 50, "50 is outside the accepted range 0 < x <= 1"),
    ("electrical_storage", "capacity", 1e308, "1e\\+308 is outside the accepted range 0 <= x <= 1e\\+06 kWh"),
    ("cooling_device", "efficiency", 0, "0 is outside the accepted range 0 < x <= 1 Carnot fraction"),
    ("dhw_device", "efficiency", 0, "0 is outside the accepted range 0 < x <= 1"),
    ("dhw_storage", "loss_coefficient", -0.1, "outside the accepted range 0 <= x <= 1"),
    ("electrical_storage", "nominal_power", float("nan"), "not a finite number: nan"),
    ("pv", "nominal_power", float("inf"), "not a finite number: inf"),
    ("electrical_storage", "efficiency", "0.9", "expected a number, got str '0.9'"),
])
def test_impossible_device_attribute_names_the_key(district, slot, key, value, says):
    import re

    _edit_schema(district, lambda raw: raw["buildings"]["Building_2"][slot]["attributes"].__setitem__(key, value))
    with pytest.raises(SchemaError) as error:
        load_schema(district)
    text = _one_line(error)
    assert f"schema.json, column/key 'buildings.Building_2.{slot}.attributes.{key}'" in text
    assert re.search(says, text), text


def test_battery_curve_points_are_fractions(district):
    curve = [[0.0, 0.83], [0.5, 1.7], [1.0, 0.85]]   # 170 % efficiency at half power
    _edit_schema(district, lambda raw: raw["buildings"]["Building_1"]["electrical_storage"]["attributes"]
                 .__setitem__("power_efficiency_curve", curve))
    with pytest.raises(SchemaError, match=r"power_efficiency_curve\[1\]\[1\]'.*1.7 is outside"):
        load_schema(district)


def test_every_device_attribute_of_the_configs_has_a_range():
    """The table covers every numeric field of the device config dataclasses (a new field needs a range)."""
    from citylearn_env.config import Battery, ConversionDevice, Tank

    for cls, fields in (("HeatPump", ConversionDevice), ("StorageTank", Tank), ("Battery", Battery)):
        for name, field in fields.__dataclass_fields__.items():
            if field.type in ("float", float):
                assert (cls, name) in ATTRIBUTE_RANGES, (cls, name)
    assert "| `carbon_intensity` | 0 <= x <= 5 kg CO2e/kWh |" in markdown_table()
    assert COLUMN_RANGES["hour"].text() == "1 <= x <= 24 (integer) hour-ending"


def test_ranges_accept_every_upstream_data_set():
    """Every upstream CityLearn data set that loads must still load: the ranges are wide enough for real data
    (v2.1.2 and v2.4.2 sets; a set refused for another reason must not be refused by a range)."""
    root = DATASET.parent / "upstream"
    need_shared(root)
    for schema in sorted(root.glob("*/*/schema.json")):
        try:
            load_schema(schema)
        except SchemaError as error:
            assert "accepted range" not in str(error) and "finite" not in str(error), str(error)


# ------------------------------------------------------------------------------ findings 3 and 5: keys, types
def test_unknown_top_level_key_names_the_closest(district):
    _edit_schema(district, lambda raw: raw.__setitem__("simulation_end_timestep", 5))
    with pytest.raises(SchemaError) as error:
        load_schema(district)
    assert "column/key 'simulation_end_timestep': unknown top-level key; did you mean " \
           "'simulation_end_time_step'?" in _one_line(error)


@pytest.mark.parametrize("key, value", [
    ("seconds_per_time_step", "abc"), ("seconds_per_time_step", [3600]), ("seconds_per_time_step", 0),
    ("episode_time_steps", "abc"), ("episode_time_steps", [[1]]), ("episode_time_steps", [["a", 2]]),
    ("simulation_end_time_step", 47.5), ("simulation_start_time_step", -1), ("random_seed", "x"),
    ("central_agent", "yes"), ("observations", []), ("buildings", 3),
])
def test_wrong_json_type_is_one_line_naming_the_key(district, key, value):
    _edit_schema(district, lambda raw: raw.__setitem__(key, value))
    with pytest.raises(SchemaError) as error:
        load_schema(district)
    assert f"column/key '{key}'" in _one_line(error)


def test_wrong_types_inside_buildings(district):
    cases = {
        "buildings.Building_1.power_outage.stochastic_power_outage_model.attributes.saifi":
            lambda b: b.__setitem__("power_outage", {"stochastic_power_outage": True, "stochastic_power_outage_model": {
                "type": "citylearn.power_outage.ReliabilityMetricsPowerOutage", "attributes": {"saifi": "abc"}}}),
        "buildings.Building_1.weather": lambda b: b.__setitem__("weather", 3),
        "buildings.Building_1.include": lambda b: b.__setitem__("include", "no"),
        "buildings.Building_1.electrical_storage": lambda b: b.__setitem__("electrical_storage", "big"),
        "observations.month": None,
    }
    for key, edit in cases.items():
        schema = json.loads(district.read_text())
        if edit is None:
            schema["observations"]["month"] = 3
        else:
            edit(schema["buildings"]["Building_1"])
        with pytest.raises(SchemaError) as error:
            load_schema({**schema, "root_directory": str(district.parent)})
        assert f"column/key '{key}'" in _one_line(error), key


def test_schema_file_that_is_not_an_object_or_not_readable(tmp_path):
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(SchemaError, match=r"list.json: a schema must be a JSON object, got list"):
        load_schema(tmp_path / "list.json")
    (tmp_path / "folder.json").mkdir()
    with pytest.raises(SchemaError, match=r"folder.json: cannot read the schema file"):
        load_schema(tmp_path / "folder.json")
    (tmp_path / "binary.json").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(SchemaError, match=r"binary.json"):
        load_schema(tmp_path / "binary.json")


# ------------------------------------------------------------------------------ LSTM (real data set)
@pytest.fixture()
def lstm_district(tmp_path) -> Path:
    """The shared 2023 data set copied (48 hours), so its files and weights can be edited."""
    need_shared(DATASET / "schema.json")
    folder = tmp_path / "lstm"
    shutil.copytree(DATASET, folder)
    _edit_schema(folder / "schema.json", lambda raw: raw.__setitem__("simulation_end_time_step", 47))
    return folder / "schema.json"


def _lstm_attributes(raw: dict) -> dict:
    return raw["buildings"]["Building_1"]["dynamics"]["cooling"]["attributes"]


def test_unknown_lstm_input_name_is_one_line(lstm_district):
    _edit_schema(lstm_district, lambda raw: _lstm_attributes(raw)["input_observation_names"].__setitem__(
        0, "outdoor_dry_bulb_temprature"))
    with pytest.raises(SchemaError) as error:
        load_schema(lstm_district)
    text = _one_line(error)
    assert "column/key 'buildings.Building_1.dynamics.cooling.attributes.input_observation_names[0]'" in text
    assert "did you mean 'outdoor_dry_bulb_temperature'" in text


@pytest.mark.parametrize("value", ["abc", [16], 0, 1e9, True])
def test_lstm_hidden_size_of_a_wrong_type_is_one_line(lstm_district, value):
    _edit_schema(lstm_district, lambda raw: _lstm_attributes(raw).__setitem__("hidden_size", value))
    with pytest.raises(SchemaError) as error:
        load_schema(lstm_district)
    assert "column/key 'buildings.Building_1.dynamics.cooling.attributes.hidden_size'" in _one_line(error)


def test_lstm_weights_all_nan_are_refused(lstm_district):
    torch = pytest.importorskip("torch")
    pth = lstm_district.parent / "Building_1.pth"
    checkpoint = torch.load(pth, weights_only=True)
    state = checkpoint.get("model_state_dict", checkpoint)
    for value in state.values():
        value.fill_(float("nan"))
    torch.save(checkpoint, pth)
    config = load_schema(lstm_district)   # the weights are read when the environment builds its LSTM bank
    with pytest.raises(SchemaError) as error:
        CityLearnEnv(config)
    text = _one_line(error)
    assert "Building_1.pth" in text and "weights must be finite (found NaN or inf)" in text


def test_pth_with_a_pickle_payload_is_refused_and_never_run(tmp_path):
    """A weights file whose pickle calls os.system: refused before anything runs (the marker is not made)."""
    import pickle

    marker = tmp_path / "ran"

    class Payload:
        def __reduce__(self):
            return os.system, (f"touch {marker}",)

    payload = pickle.dumps(Payload(), protocol=2)   # dumping does not run it; loading would
    pth = tmp_path / "evil.pth"
    with zipfile.ZipFile(pth, "w") as archive:
        archive.writestr("evil/data.pkl", payload)
    with pytest.raises(SchemaError, match=r"evil.pth: refusing to load: global 'posix.system' is not allowed"):
        read_pth_state_dict(pth)
    assert not marker.exists()
    pth.write_bytes(payload)                         # a bare pickle (the pre-1.6 non-zip layout is tried)
    with pytest.raises(SchemaError, match=r"evil.pth: refusing to load: global 'posix.system' is not allowed"):
        read_pth_state_dict(pth)
    assert not marker.exists()


# ------------------------------------------------------------------------------ finding 6: confined paths
SECRET = "SECRET-FIRST-LINE-DO-NOT-ECHO"


@pytest.fixture()
def outside(tmp_path) -> Path:
    """A file outside the dataset folder whose first line must never appear in a message."""
    path = tmp_path / "private.txt"
    path.write_text(f"{SECRET}\n1,2,3\n")
    return path


def test_dotdot_file_name_is_refused_without_reading_it(district, outside):
    _edit_schema(district, lambda raw: raw["buildings"]["Building_1"].__setitem__("weather", "../private.txt"))
    with pytest.raises(SchemaError) as error:
        load_schema(district)
    text = _one_line(error)
    assert "column/key 'buildings.Building_1.weather': points outside the dataset folder" in text
    assert SECRET not in text


def test_absolute_file_name_and_root_directory_are_refused(district, outside):
    _edit_schema(district, lambda raw: raw["buildings"]["Building_1"].__setitem__("weather", str(outside)))
    with pytest.raises(SchemaError, match=r"'buildings.Building_1.weather': points outside") as error:
        load_schema(district)
    assert SECRET not in str(error.value)
    _edit_schema(district, lambda raw: raw.update(root_directory=str(outside.parent),
                                                   buildings={"Building_1": {**raw["buildings"]["Building_1"],
                                                                             "weather": "private.txt"}}))
    with pytest.raises(SchemaError, match=r"column/key 'root_directory': points outside") as error:
        load_schema(district)
    assert SECRET not in str(error.value)


def test_symlink_out_of_the_folder_is_refused_and_inside_is_fine(district, outside):
    folder = district.parent
    os.symlink(outside, folder / "link.csv")
    _edit_schema(district, lambda raw: raw["buildings"]["Building_1"].__setitem__("weather", "link.csv"))
    with pytest.raises(SchemaError, match=r"'buildings.Building_1.weather': points outside") as error:
        load_schema(district)
    assert SECRET not in str(error.value)
    os.symlink(folder / "weather.csv", folder / "inside.csv")     # a symlink that stays inside is allowed
    _edit_schema(district, lambda raw: raw["buildings"]["Building_1"].__setitem__("weather", "inside.csv"))
    assert load_schema(district).buildings[0].name == "Building_1"


def test_allow_outside_paths_is_the_explicit_escape(district, tmp_path):
    shared = tmp_path / "shared_weather.csv"
    shutil.copyfile(district.parent / "weather.csv", shared)
    _edit_schema(district, lambda raw: [b.__setitem__("weather", "../shared_weather.csv")
                                        for b in raw["buildings"].values()])
    with pytest.raises(SchemaError, match="allow_outside_paths=True"):
        load_schema(district)
    config = load_schema(district, allow_outside_paths=True)
    assert len(config.buildings) == 2


def test_lstm_weights_outside_the_folder_are_refused(lstm_district):
    _edit_schema(lstm_district, lambda raw: _lstm_attributes(raw).__setitem__("filename", "../../Building_1.pth"))
    with pytest.raises(SchemaError) as error:
        load_schema(lstm_district)
    assert "column/key 'buildings.Building_1.dynamics.cooling.attributes.filename': points outside" in \
        _one_line(error)


def test_docs_print_the_table_of_ranges():
    from tests.conftest import ROOT

    assert markdown_table() in (ROOT / "docs" / "bad_input.md").read_text()


@pytest.mark.parametrize("action", [["0.1", "0.2"], [None, 0.1], [[0.1], "x"]])
def test_an_action_that_is_not_numbers_is_one_line(action):
    env = make_example_env(n_buildings=1, hours=48)
    env.reset(seed=0)
    size = env.action_space.shape[0]
    bad = (action * size)[:size] if size > 1 else action[:1]
    with pytest.raises(SchemaError) as error:
        env.step(bad)
    assert "column/key 'action'" in str(error.value) and "\n" not in str(error.value)
