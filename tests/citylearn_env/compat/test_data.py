"""Data-set names resolve offline through the cache folder (``$DISTRICTGEN_CITYLEARN_DATA``); an unknown or
absent name is one SchemaError line saying where it looked and how to get the data set; ``get_dataset`` copies a
folder into the cache (nothing is downloaded)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from citylearn_env import CityLearnEnv as NativeEnv
from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.data import ENV_VAR, DataSet, dataset_schema_path, get_dataset, is_dataset_name
from citylearn_env.errors import SchemaError
from citylearn_env.example import write_example_district
from tests.citylearn_env.compat.conftest import PHASE_1, UPSTREAM


def test_names_resolve_in_the_cache_per_preset(cache) -> None:
    assert dataset_schema_path(PHASE_1) == UPSTREAM / "v2.1.2" / PHASE_1 / "schema.json"
    assert PHASE_1 in DataSet().get_names() and "citylearn_challenge_2022_phase_all_plus_evs" not in DataSet().get_names()
    schema = DataSet().get_schema(PHASE_1)
    assert Path(schema["root_directory"]) == (UPSTREAM / "v2.1.2" / PHASE_1).resolve()
    env = CityLearnEnv(schema, simulation_end_time_step=23)  # upstream's DataSet().get_schema(name) route
    assert env.time_steps == 24
    # the 2.5 preset reads the v2.4.2 data sets, where the EV set is
    ev = CityLearnEnv("citylearn_challenge_2022_phase_all_plus_evs", citylearn_version="2.5",
                      simulation_end_time_step=23)
    assert ev.mirror.api == "gymnasium" and ev.settings.kpi_names_2_5
    assert "electric_vehicle_storage_charger_1_1" in ev.action_names[0]
    assert ev.get_metadata()["reward_function"] == "Electric_Vehicles_Reward_Function"


def test_unknown_or_absent_name_is_one_clear_line(cache, monkeypatch, tmp_path) -> None:
    with pytest.raises(SchemaError) as error:
        CityLearnEnv("citylearn_challenge_1999")
    message = str(error.value)
    assert "\n" not in message and "citylearn_challenge_1999" in message
    assert str(UPSTREAM / "v2.1.2" / "citylearn_challenge_1999") in message and "Nothing is downloaded" in message
    assert ENV_VAR in message and PHASE_1 in message  # lists what the cache has
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "empty"))
    with pytest.raises(SchemaError, match=r"no schema\.json in .*empty/v2\.1\.2/citylearn_challenge_2022_phase_1"):
        CityLearnEnv(PHASE_1)


def test_paths_are_not_names(tmp_path) -> None:
    assert not is_dataset_name("data/schema.json") and not is_dataset_name("../x") and is_dataset_name(PHASE_1)
    with pytest.raises(SchemaError, match="schema file not found"):
        CityLearnEnv(str(tmp_path / "schema.json"))


def test_get_dataset_copies_a_folder_into_the_cache(monkeypatch, tmp_path) -> None:
    source = write_example_district(tmp_path / "source", n_buildings=2, hours=48, seed=0).parent
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    schema = get_dataset("example_district", source)
    assert schema == tmp_path / "cache" / "v2.1.2" / "example_district" / "schema.json" and schema.is_file()
    env = CityLearnEnv("example_district")
    native = NativeEnv(source / "schema.json", settings="citylearn-2.1")
    observations = env.reset()  # the example district is written in the v2.1 layout: CityLearn 2.1's API
    native_observations, _ = native.reset()
    expected = native_observations if env.central_agent else native.flat_observations().astype(np.float32)
    np.testing.assert_array_equal(np.concatenate(observations), expected)
    with pytest.raises(SchemaError, match="not a CityLearn data-set folder"):
        get_dataset("other", tmp_path)
    with pytest.raises(SchemaError, match="not a CityLearn data-set name"):
        get_dataset("../escape", source)
