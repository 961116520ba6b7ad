"""The paper's 17 benchmarks: definitions, schema edits and runs on a district the tests generate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from pipeline.paper import BENCHMARKS, benchmark_schema, run_all


@pytest.fixture(scope="module")
def district(tmp_path_factory):
    path = write_example_district(tmp_path_factory.mktemp("paper"), n_buildings=2, hours=720, seed=11)
    schema = json.loads(path.read_text())
    schema["root_directory"] = str(path.parent)
    return path, schema


def test_the_17_configurations():
    assert len(BENCHMARKS) == 17 and len({b.id for b in BENCHMARKS}) == 17
    b = {x.id: x for x in BENCHMARKS}
    assert (b["rbc-b1-c-dhw"].buildings, b["rbc-b1-c-dhw"].dhw, b["rbc-b1-c-dhw"].bess_pv) == (1, True, False)
    assert b["x-b1_b2-x-pv"].pv and not b["x-b1_b2-x-pv"].bess_pv and b["x-b1_b2-x-pv"].buildings == 2
    assert b["rlc-b1-d_o-hp"].hp and b["rlc-b1-d_o-hp"].objective == "discomfort_consumption"
    assert sum(x.control == "sac" for x in BENCHMARKS) == 8 and sum(x.control == "rbc" for x in BENCHMARKS) == 7


def test_schema_edits_follow_the_configuration(district):
    _, schema = district
    b = {x.id: x for x in BENCHMARKS}
    env = CityLearnEnv(benchmark_schema(schema, b["rlc-b1-c-bess_pv"], (312, 719)))
    assert env.building_names == ("Building_1",)
    assert env.action_names == ["electrical_storage"]
    assert env.observation_names == ["hour", "day_type", "net_electricity_consumption", "electricity_pricing",
                                     "solar_generation", "electrical_storage_soc"]
    assert env.reset()[0].shape == (6,) and env.district.length == 408
    bare = CityLearnEnv(benchmark_schema(schema, b["x-b1_b2-x-x"], (312, 719)))
    assert bare.district.pv_nominal_power.tolist() == [0.0, 0.0] and bare.action_names == []


def test_runs_report_test_period_objectives(district, tmp_path):
    path, _ = district
    ids = ["x-b1_b2-x-x", "x-b1_b2-x-pv", "rbc-b1-c-bess_pv", "rbc-b1_b2-p-bess_pv", "rlc-b1-e-dhw"]
    results = {r["id"]: r for r in run_all(path, tmp_path, only=ids, sac_episodes=1, log=lambda *_: None)}
    assert (tmp_path / "results.csv").is_file() and "rbc-b1-c-bess_pv" in (tmp_path / "results.md").read_text()
    for r in results.values():
        assert r["steps"] == 407 and all(np.isfinite(r[k]) for k in ("cost", "emissions", "consumption"))
    # PV can only lower grid imports; the rule-based battery actually moves energy
    assert results["x-b1_b2-x-pv"]["consumption"] < results["x-b1_b2-x-x"]["consumption"]
    assert results["rbc-b1-c-bess_pv"]["mean_abs_action"] > 0.02
    assert results["rlc-b1-e-dhw"]["mean_abs_action"] > 0


def test_unknown_benchmark_id(district, tmp_path):
    with pytest.raises(ValueError, match="unknown benchmark id"):
        run_all(district[0], tmp_path, only=["rbc-b3-z-x"])
