"""A schema's files stay inside its folder whatever the entry point (issue 50, item 1's compat part): a schema file,
a data-set name or ``DataSet().get_schema`` whose ``root_directory`` (or a file name) leaves the folder is refused,
with or without read keywords, and the outside file's content is never echoed; bad names, reward strings and
wrongly typed keywords are one line each."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.data import ENV_VAR, DataSet
from citylearn_env.compat.version import VERSION_VAR
from citylearn_env.errors import SchemaError
from citylearn_env.example import write_example_district

SECRET = "SECRET-FIRST-LINE-4711"
READ_KEYWORDS = [{}, {"simulation_end_time_step": 10}, {"simulation_start_time_step": 1}, {"buildings": [0]},
                 {"simulation_end_time_step": 10, "buildings": ["Building_1"]}]


def escaping(tmp_path: Path, *, root: str | None, file_prefix: str = "") -> Path:
    """A data set in ``tmp_path/cache/v2.1.2/escape`` whose schema points outside its folder: ``root_directory``
    ``root`` or building files named ``file_prefix + name``; the outside folder holds copies of the real files
    whose first line is :data:`SECRET`."""
    district = write_example_district(tmp_path / "source", n_buildings=2, hours=48, seed=0)
    raw = json.loads(district.read_text())
    outside = tmp_path / "cache" / "v2.1.2"
    outside.mkdir(parents=True)
    for f in district.parent.iterdir():
        if f.suffix == ".csv":
            (outside / f.name).write_text(SECRET + "\n" + f.read_text())
    folder = outside / "escape"
    folder.mkdir()
    raw["root_directory"] = root
    if file_prefix:
        for spec in raw["buildings"].values():
            spec["energy_simulation"] = file_prefix + spec["energy_simulation"]
    (folder / "schema.json").write_text(json.dumps(raw))
    return folder / "schema.json"


def refused(call) -> str:
    with pytest.raises(SchemaError) as error:
        call()
    message = str(error.value)
    assert "\n" not in message and SECRET not in message
    return message


@pytest.mark.parametrize("keywords", READ_KEYWORDS)
@pytest.mark.parametrize("escape", [{"root": ".."}, {"root": None, "file_prefix": "../"}, {"root": "/"}])
def test_an_escaping_schema_is_refused_whatever_the_entry_point(tmp_path, monkeypatch, keywords, escape) -> None:
    schema = escaping(tmp_path, **escape)
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    monkeypatch.setenv(VERSION_VAR, "2.1")
    assert "outside" in refused(lambda: CityLearnEnv(str(schema), **keywords))
    assert "outside" in refused(lambda: CityLearnEnv("escape", **keywords))
    if escape["root"] is not None:
        assert "outside" in refused(lambda: DataSet().get_schema("escape"))
        assert "outside" in refused(lambda: DataSet.get_schema("escape"))


@pytest.mark.parametrize(("schema", "keywords", "match"), [
    ("citylearn\x00challenge", {}, "NUL|data-set name|schema"),
    ("a" * 5000, {}, "data-set name|over 4096"),
    ("x" * 300, {}, "data-set name"),
    (3.5, {}, "a schema is a data-set name"),
    (None, {}, "a schema is a data-set name"),
])
def test_bad_schema_arguments_are_one_line(tmp_path, monkeypatch, schema, keywords, match) -> None:
    monkeypatch.setenv(ENV_VAR, str(tmp_path))
    message = refused(lambda: CityLearnEnv(schema, **keywords))
    assert len(message) < 1500
    assert __import__("re").search(match, message)


@pytest.mark.parametrize("keywords", [
    {"simulation_end_time_step": "10"}, {"simulation_end_time_step": -1}, {"simulation_start_time_step": 1.5},
    {"central_agent": "yes"}, {"episode_time_steps": "24"}, {"seconds_per_time_step": 0},
    {"seconds_per_time_step": "3600"}, {"random_seed": True}, {"buildings": "Building_1"},
    {"active_observations": "hour"}, {"reward_function_kwargs": [1]}, {"root_directory": 5},
    {"root_directory": "a\x00b"}, {"reward_function": "some.string"}, {"reward_function": 5},
    {"seconds_per_time_step": 1e9}, {"random_seed": 2**80}, {"simulation_end_time_step": 10**9},
    {"inactive_actions": ["nonexistent"]}, {"shared_observations": ["nope"]}, {"episode_time_steps": 0},
    {"reward_function": "citylearn.reward_function.ComfortReward", "reward_function_kwargs": {"band": "x"}},
])
def test_wrongly_typed_keywords_are_one_line(tmp_path, monkeypatch, keywords) -> None:
    schema = write_example_district(tmp_path / "d", n_buildings=2, hours=48, seed=0)
    message = refused(lambda: CityLearnEnv(str(schema), **keywords))
    assert next(iter(keywords)) in message or "reward" in message
