"""The paper's 17 benchmarks: definitions, schema edits and runs on a district the tests generate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, load_schema
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
    path, _ = district
    config = load_schema(path)
    b = {x.id: x for x in BENCHMARKS}
    edited = benchmark_schema(config, b["rlc-b1-c-bess_pv"], (312, 719))
    env = CityLearnEnv(edited)
    assert env.building_names == ("Building_1",)
    assert env.action_names == ["Building_1.electrical_storage"]
    assert env.observation_names == ["hour", "day_type", "Building_1.net_electricity_consumption",
                                     "electricity_pricing", "Building_1.solar_generation",
                                     "Building_1.electrical_storage_soc"]
    # 719 - 312 + 1 = 408 time steps; 6 observations, 3 of them shared (hour, day_type, pricing)
    assert env.reset()[0].shape == (6,) and env.episode_length == 408
    assert edited.shared_observations == ("hour", "day_type", "electricity_pricing")
    assert edited.central_agent and edited.episode_time_steps == ((312, 719),)
    assert edited.buildings[0].dhw_storage.capacity == 0.0 and edited.buildings[0].electrical_storage.capacity > 0
    bare = CityLearnEnv(benchmark_schema(config, b["x-b1_b2-x-x"], (312, 719)))
    assert bare.district.pv_nominal_power.tolist() == [0.0, 0.0] and bare.action_names == []
    # the loaded district itself is unchanged (typed edits return copies)
    assert len(config.buildings) == 2 and config.buildings[0].pv_nominal_power > 0


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


def test_overcooling_statistics_by_hand(tmp_path):
    """Over-/under-cooling statistics of a run: mean and std of the set-point deviation on each side."""
    from pipeline.paper import mean_or_zero, std_or_zero

    delta = np.array([-1.0, -3.0, 0.5, 0.0, 1.5])
    over, under = -delta[delta < 0], delta[delta > 0]
    assert (mean_or_zero(over), std_or_zero(over)) == (2.0, 1.0)
    assert (mean_or_zero(under), std_or_zero(under)) == (1.0, 0.5)
    assert mean_or_zero(np.array([])) == 0.0


def test_multiplier_sweep_on_lstm_district(tmp_path):
    """rlc-b1-d_o-hp on the shared LSTM district (1 SAC episode per m): a row per multiplier, changes vs m = 1."""
    from pipeline.paper import multiplier_sweep
    from tests.conftest import DATASET, need_shared

    need_shared(DATASET)
    schema = json.loads((DATASET / "schema.json").read_text())
    schema.update(root_directory=str(DATASET), simulation_end_time_step=719)
    path = tmp_path / "schema.json"
    path.write_text(json.dumps(schema))
    rows = multiplier_sweep(path, tmp_path, (1.0, 12.0), sac_episodes=1, log=lambda *_: None)
    assert [r["multiplier"] for r in rows] == [1.0, 12.0]
    for r in rows:
        assert r["discomfort"] > 0 and r["consumption"] > 0 and r["overcooling_mean"] >= 0
    table = (tmp_path / "multiplier_sweep.md").read_text().splitlines()
    assert len(table) == 4 and "+0.0 %" in table[2]
