"""Bad input gets one clear SchemaError naming the file, the column or key, and the row."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, SchemaError, load_schema
from citylearn_env.example import write_example_district


@pytest.fixture()
def district(tmp_path) -> Path:
    return write_example_district(tmp_path, n_buildings=2, hours=48, seed=1)


def _edit_csv(path: Path, edit) -> None:
    lines = path.read_text().splitlines()
    rows = [line.split(",") for line in lines]
    edit(rows)
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")


def _col(path: Path, name: str) -> int:
    return path.read_text().splitlines()[0].split(",").index(name)


def test_missing_column(district):
    b1 = district.parent / "Building_1.csv"
    j = _col(b1, "dhw_demand")
    _edit_csv(b1, lambda rows: [r.pop(j) for r in rows])
    with pytest.raises(SchemaError, match=r"Building_1.csv.*'dhw_demand'.*missing column"):
        load_schema(district)


def test_extra_column(district):
    b1 = district.parent / "Building_1.csv"
    _edit_csv(b1, lambda rows: [r.append("x" if i == 0 else "1") for i, r in enumerate(rows)])
    with pytest.raises(SchemaError, match=r"Building_1.csv.*column/key 'x'.*unexpected column"):
        load_schema(district)


def test_extra_column_positional_layout(tmp_path):
    schema = write_example_district(tmp_path, n_buildings=1, hours=48, file_layout="v2.1")
    weather = tmp_path / "weather.csv"
    _edit_csv(weather, lambda rows: [r.append("Extra" if i == 0 else "1") for i, r in enumerate(rows)])
    with pytest.raises(SchemaError, match=r"weather.csv.*'Extra'.*unexpected column 17 of 17.*v2.1 weather layout has 16 columns"):
        load_schema(schema)


def test_too_few_rows(district):
    weather = district.parent / "weather.csv"
    _edit_csv(weather, lambda rows: rows.__delitem__(slice(30, None)))
    with pytest.raises(SchemaError, match=r"weather.csv.*row 29.*29 data rows.*needs 48"):
        load_schema(district)


@pytest.mark.parametrize("file, column, line, cell, message", [
    ("Building_2.csv", "non_shiftable_load", 6, "nan", r"Building_2.csv.*'non_shiftable_load'.*row 5 \(file line 7\).*NaN"),
    ("Building_2.csv", "hour", 3, "", r"Building_2.csv.*'hour'.*row 2 .*not a number"),
    ("Building_1.csv", "cooling_demand", 11, "-0.5", r"Building_1.csv.*'cooling_demand'.*row 10 .*negative value -0.5"),
])
def test_bad_cell(district, file, column, line, cell, message):
    """A NaN, an empty cell and a negative load: one error naming file, column and row."""
    path = district.parent / file
    j = _col(path, column)
    _edit_csv(path, lambda rows: rows[line].__setitem__(j, cell))
    with pytest.raises(SchemaError, match=message):
        load_schema(district)


def test_cooling_and_heating_both_positive(district):
    b1 = district.parent / "Building_1.csv"
    jc, jh = _col(b1, "cooling_demand"), _col(b1, "heating_demand")

    def edit(rows):
        rows[4][jc], rows[4][jh] = "1.0", "2.0"

    _edit_csv(b1, edit)
    with pytest.raises(SchemaError, match=r"Building_1.csv.*cooling_demand / heating_demand.*row 3 .*both > 0"):
        load_schema(district)


def test_unknown_device_type_lists_known(district):
    raw = json.loads(district.read_text())
    raw["buildings"]["Building_2"]["electrical_storage"]["type"] = "mypackage.evil.Battery"
    with pytest.raises(SchemaError, match=r"buildings.Building_2.electrical_storage.type.*unknown device type "
                                          r"'mypackage.evil.Battery'.*citylearn.energy_model.Battery"):
        load_schema({**raw, "root_directory": str(district.parent)})


def test_schema_dict_is_not_mutated(district):
    raw = json.loads(district.read_text())
    raw["root_directory"] = str(district.parent)
    before = json.dumps(raw, sort_keys=True)
    CityLearnEnv(raw).reset()
    assert json.dumps(raw, sort_keys=True) == before


def test_unknown_reward_type(district):
    raw = json.loads(district.read_text())
    raw["root_directory"] = str(district.parent)
    raw["reward_function"] = {"type": "os.system", "attributes": {}}
    with pytest.raises(SchemaError, match=r"os.system"):
        CityLearnEnv(raw)


def test_action_of_wrong_size(district):
    env = CityLearnEnv(district)
    env.reset()
    with pytest.raises(SchemaError, match=r"action has 3 values, the action space has 4 \(Building_1.dhw_storage"):
        env.step(np.zeros(3))


def test_nan_action(district):
    env = CityLearnEnv(district)
    env.reset()
    with pytest.raises(SchemaError, match=r"'Building_2.dhw_storage'.*not finite"):
        env.step(np.array([0.0, 0.0, np.nan, 0.0]))


def test_a_file_name_with_a_newline_stays_on_one_line():
    """A data file named with a control character (found by the schema fuzzer) is located on the message's one
    line, the character written as its escape."""
    from citylearn_env.errors import SchemaError

    error = SchemaError("data file not found", file="/tmp/district/0\n", column="buildings.B.energy_simulation",
                        row="2\t")
    text = str(error)
    assert "\n" not in text and "\t" not in text
    assert text.startswith("/tmp/district/0\\n, column/key 'buildings.B.energy_simulation', row 2\\t: ")
