"""The paper's 17 benchmarks: definitions, building roles, schema edits, the task runner and full runs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.errors import InputError
from citylearn_env.example import write_example_district
from pipeline.paper.benchmarks import BENCHMARKS, RunOptions, benchmark_schema, resolve_roles
from pipeline.paper.tasks import plan_tasks, run_paper

BY_ID = {x.id: x for x in BENCHMARKS}


def bare(names) -> list[str]:
    """Observation/action names without their ``<building>.`` prefix."""
    return [n.split(".")[-1] for n in names]


@pytest.fixture(scope="module")
def district(tmp_path_factory):
    path = write_example_district(tmp_path_factory.mktemp("paper"), n_buildings=3, hours=720, seed=11)
    schema = json.loads(path.read_text())
    schema["root_directory"] = str(path.parent)
    return path, schema


@pytest.fixture(scope="module")
def lstm_district(tmp_path_factory):
    """The shared 2023 phase-3 district (LSTM buildings) cut to 30 days: a copy (2.9 MB) with its schema."""
    import shutil

    from tests.conftest import DATASET, need_shared

    need_shared(DATASET)
    folder = tmp_path_factory.mktemp("lstm") / "district"
    shutil.copytree(DATASET, folder)
    schema = json.loads((folder / "schema.json").read_text())
    schema.update(simulation_end_time_step=719)
    (folder / "schema.json").write_text(json.dumps(schema))
    return folder / "schema.json"


def test_the_17_configurations():
    assert len(BENCHMARKS) == 17 and len(BY_ID) == 17
    assert (BY_ID["rbc-b1-c-dhw"].buildings, BY_ID["rbc-b1-c-dhw"].dhw, BY_ID["rbc-b1-c-dhw"].bess_pv) == (1, True,
                                                                                                         False)
    assert BY_ID["x-b1_b2-x-pv"].pv and not BY_ID["x-b1_b2-x-pv"].bess_pv and BY_ID["x-b1_b2-x-pv"].buildings == 2
    assert BY_ID["rlc-b1-d_o-hp"].hp and BY_ID["rlc-b1-d_o-hp"].objective == "discomfort_consumption"
    assert sum(x.control == "sac" for x in BENCHMARKS) == 8 and sum(x.control == "rbc" for x in BENCHMARKS) == 7


def test_schema_edits_follow_the_configuration(district):
    path, _ = district
    config = load_schema(path)
    edited = benchmark_schema(config, BY_ID["rlc-b1-c-bess_pv"], (312, 719))
    env = CityLearnEnv(edited)
    assert env.building_names == ("Building_1",)
    assert bare(env.action_names) == ["electrical_storage"]
    assert bare(env.observation_names) == ["hour", "day_type", "net_electricity_consumption",
                                           "electricity_pricing", "solar_generation", "electrical_storage_soc"]
    # 719 - 312 + 1 = 408 time steps; 6 observations, 3 of them shared (hour, day_type, pricing)
    assert env.reset()[0].shape == (6,) and env.episode_length == 408
    assert edited.shared_observations == ("hour", "day_type", "electricity_pricing")
    assert edited.central_agent and edited.episode_time_steps == ((312, 719),)
    assert edited.buildings[0].dhw_storage.capacity == 0.0 and edited.buildings[0].electrical_storage.capacity > 0
    nothing = CityLearnEnv(benchmark_schema(config, BY_ID["x-b1_b2-x-x"], (312, 719)))
    assert nothing.district.pv_nominal_power.tolist() == [0.0, 0.0] and nothing.action_names == []
    # the loaded district itself is unchanged (typed edits return copies)
    assert len(config.buildings) == 3 and config.buildings[0].pv_nominal_power > 0


def test_building_roles_map_onto_schema_names(district):
    config = load_schema(district[0])
    assert resolve_roles(config) == ("Building_1", "Building_2")                # default: the first two
    assert resolve_roles(config, ["Building_3", "Building_1"]) == ("Building_3", "Building_1")
    two = benchmark_schema(config, BY_ID["rbc-b1_b2-p-bess_pv"], (0, 23), roles=("Building_3", "Building_1"))
    one = benchmark_schema(config, BY_ID["rbc-b1-c-dhw"], (0, 23), roles=("Building_3", "Building_1"))
    assert two.building_names == ("Building_3", "Building_1") and one.building_names == ("Building_3",)
    with pytest.raises(InputError, match="unknown building.*Building_9"):
        resolve_roles(config, ["Building_9"])
    with pytest.raises(InputError, match="one or two distinct"):
        resolve_roles(config, ["Building_1", "Building_1"])
    with pytest.raises(InputError, match="needs two buildings"):
        benchmark_schema(config, BY_ID["x-b1_b2-x-x"], (0, 23), roles=("Building_2",))


def test_missing_device_is_one_clear_error(district):
    config = load_schema(district[0]).with_device("Building_2", "electrical_storage", capacity=0.0)
    with pytest.raises(InputError, match=r"rbc-b1_b2-p-bess_pv needs battery .* in B2 = Building_2"):
        benchmark_schema(config, BY_ID["rbc-b1_b2-p-bess_pv"], (0, 23))
    # B1 alone does not need Building_2's battery; a heat-pump row needs an LSTM model the example lacks
    benchmark_schema(config, BY_ID["rbc-b1-c-bess_pv"], (0, 23))
    with pytest.raises(InputError, match="LSTM temperature model"):
        benchmark_schema(config, BY_ID["rlc-b1-d_o-hp"], (0, 23))


def test_results_name_the_buildings_and_runs_resume(district, tmp_path):
    path, _ = district
    ids = ["x-b1_b2-x-x", "x-b1_b2-x-pv", "rbc-b1-c-bess_pv", "rbc-b1_b2-p-bess_pv", "rlc-b1-e-dhw"]
    options = RunOptions(sac_episodes=1, roles=("Building_2", "Building_3"))
    results = {r["id"]: r for r in run_paper(path, tmp_path, only=ids, sweep=(), options=options,
                                            log=lambda *_: None)["results"]}
    assert results["rbc-b1-c-bess_pv"]["buildings"] == "Building_2"
    assert results["x-b1_b2-x-x"]["buildings"] == "Building_2+Building_3"
    table = (tmp_path / "results.md").read_text()
    assert "B1 = Building_2, B2 = Building_3" in table and "| rbc-b1-c-bess_pv | Building_2 |" in table
    for r in results.values():
        assert r["steps"] == 407 and all(np.isfinite(r[k]) for k in ("cost", "emissions", "consumption"))
    # PV can only lower grid imports; the rule-based battery actually moves energy
    assert results["x-b1_b2-x-pv"]["consumption"] < results["x-b1_b2-x-x"]["consumption"]
    assert results["rbc-b1-c-bess_pv"]["mean_abs_action"] > 0.02
    assert results["rlc-b1-e-dhw"]["mean_abs_action"] > 0
    assert {p.name for p in tmp_path.glob("*.png")} == {"cost_emissions.png", "actions_soc.png", "daily_peak.png",
                                                       "soc_trajectories.png"}      # the oracle and MPC run by default
    # resume: a finished task file is reused as is (a marked value comes back), other options rerun it
    task = tmp_path / "tasks" / "rbc-b1-c-bess_pv-m3-s0.json"
    stored = json.loads(task.read_text())
    stored["result"]["cost"] = -1.0
    task.write_text(json.dumps(stored))
    again = {r["id"]: r for r in run_paper(path, tmp_path, only=ids, sweep=(), options=options,
                                            log=lambda *_: None)["results"]}
    assert again["rbc-b1-c-bess_pv"]["cost"] == -1.0
    published = RunOptions(sac_episodes=1, roles=("Building_2", "Building_3"), rules="published")
    rerun = run_paper(path, tmp_path, only=["rbc-b1-c-bess_pv"], sweep=(), options=published,
                      log=lambda *_: None)["results"]
    assert rerun[0]["cost"] == pytest.approx(results["rbc-b1-c-bess_pv"]["cost"], rel=0.05)
    assert rerun[0]["cost"] != results["rbc-b1-c-bess_pv"]["cost"]


def test_seeds_give_mean_and_std(district, tmp_path):
    out = run_paper(district[0], tmp_path, only=["rlc-b1-c-bess_pv", "rbc-b1-c-bess_pv"], sweep=(), seeds=2,
                    options=RunOptions(sac_episodes=1), log=lambda *_: None, controllers=("rbc", "sac"))
    runs = [(r["id"], r["seed"]) for r in out["runs"]]
    assert sorted(runs) == [("rbc-b1-c-bess_pv", 0), ("rlc-b1-c-bess_pv", 0), ("rlc-b1-c-bess_pv", 1)]
    row = {r["id"]: r for r in out["results"]}["rlc-b1-c-bess_pv"]
    costs = [r["cost"] for r in out["runs"] if r["id"] == "rlc-b1-c-bess_pv"]
    assert row["seeds"] == 2 and row["cost"] == pytest.approx(sum(costs) / 2)
    assert row["cost_sd"] == pytest.approx(abs(costs[0] - costs[1]) / 2 ** 0.5)   # sample std of two values
    assert " ± " in (tmp_path / "results.md").read_text()


def test_task_plan():
    tasks = plan_tasks(None, (1.0, 3.0, 6.0, 12.0), seeds=3, controllers=("rbc", "sac"))
    # 9 deterministic rows once; 8 SAC rows x 3 seeds; the sweep adds m = 1, 6, 12 (m = 3 is the d_o row)
    assert len(tasks) == 9 + 8 * 3 + 3 * 3
    assert len({t.key for t in tasks}) == len(tasks)
    assert all(BY_ID[t.id].control == "sac" for t in tasks[:33])              # the long tasks first
    with pytest.raises(InputError, match="unknown benchmark id"):
        plan_tasks(["rbc-b3-z-x"], ())


def test_overcooling_statistics_by_hand():
    """Over-/under-cooling statistics of a run: mean and std of the set-point deviation on each side."""
    from pipeline.paper.benchmarks import mean_or_zero, std_or_zero

    delta = np.array([-1.0, -3.0, 0.5, 0.0, 1.5])
    over, under = -delta[delta < 0], delta[delta > 0]
    assert (mean_or_zero(over), std_or_zero(over)) == (2.0, 1.0)
    assert (mean_or_zero(under), std_or_zero(under)) == (1.0, 0.5)
    assert mean_or_zero(np.array([])) == 0.0


@pytest.mark.slow
def test_two_episode_run_of_the_whole_paper(lstm_district, tmp_path):
    """All 17 configurations and the m-sweep, SAC for 2 episodes, on the LSTM district, B1/B2 = the
    SimBuild buildings (Building_2, Building_3): shapes and physics of every run."""
    options = RunOptions(sac_episodes=2, roles=("Building_2", "Building_3"))
    out = run_paper(lstm_district, tmp_path, sweep=(1.0, 3.0, 6.0, 12.0), options=options, workers=2,
                    log=lambda *_: None)
    results = {r["id"]: r for r in out["results"]}
    assert list(results) == [b.id for b in BENCHMARKS] and len(out["sweep"]) == 4
    for r in out["runs"]:
        assert r["steps"] == 720 - 13 * 24 - 1                      # the 17-day test period's step calls
        trace = r["trace"]
        assert len(trace["daily_peak"]) == 17 and len(trace["actions"]) == 7 * 24
        for soc in ("dhw_storage_soc", "electrical_storage_soc"):
            assert min(trace[soc]) >= 0.0 and max(trace[soc]) <= 1.0
    # PV only lowers B1's grid imports, hence its cost
    assert results["x-b1_b2-x-pv"]["cost"] < results["x-b1_b2-x-x"]["cost"]
    assert results["rlc-b1-d_o-hp"]["discomfort"] > 0
    assert (tmp_path / "multiplier_sweep.md").read_text().count("\n") == 6


def test_lean_sac_squashed_gaussian_matches_torch_distributions():
    """LeanSAC's action log-probability = that of torch's tanh-transformed Normal (SB3's distribution, up
    to its 1e-6 in the log-det), and its layers start inside nn.Linear's U(-1/sqrt(fan_in), 1/sqrt(fan_in))."""
    import torch
    from torch.distributions import Normal, TransformedDistribution
    from torch.distributions.transforms import TanhTransform

    from pipeline.paper.sac.lean import LeanSAC

    agent = LeanSAC(5, 2, seed=3)
    obs = torch.rand(64, 5)
    state = agent.generator.get_state()
    with torch.no_grad():
        action, log_prob = agent._sample(obs)
        agent.generator.set_state(state)
        mu, log_std = agent._actor_params(obs)
        u = mu + log_std.exp() * torch.randn(mu.shape, generator=agent.generator)
        reference = TransformedDistribution(Normal(mu, log_std.exp()), [TanhTransform()]).log_prob(torch.tanh(u))
    assert torch.allclose(action, torch.tanh(u))
    assert torch.allclose(log_prob, reference.sum(1), atol=1e-3)
    assert agent.actor[0].abs().max() <= 1 / 5 ** 0.5 and agent.critic[2].abs().max() <= 1 / 256 ** 0.5
    assert agent.act(np.zeros(5)).shape == (2,) and 0.0 <= agent.act(np.zeros(5)).min() <= 1.0


@pytest.mark.slow
def test_tasks_on_a_local_dask_cluster_equal_in_process(district, tmp_path):
    """The same tasks on a 2-process Dask LocalCluster give the in-process results (rule rows are
    deterministic), written as task files the in-process run then resumes from."""
    pytest.importorskip("dask.distributed")
    from pipeline.runners import DaskRunner

    path, _ = district
    ids = ["x-b1_b2-x-pv", "rbc-b1-c-bess_pv", "rbc-b1-e-bess_pv"]
    options = RunOptions(sac_episodes=1)
    here = {r["id"]: r for r in run_paper(path, tmp_path / "here", only=ids, sweep=(), options=options,
                                          log=lambda *_: None)["results"]}
    dask = {r["id"]: r for r in run_paper(path, tmp_path / "dask", only=ids, sweep=(), options=options,
                                          runner=DaskRunner(workers=2), log=lambda *_: None)["results"]}
    assert sorted(p.name for p in (tmp_path / "dask" / "tasks").glob("*.json")) == sorted(
        p.name for p in (tmp_path / "here" / "tasks").glob("*.json"))
    for key in ids:
        for metric in ("cost", "emissions", "consumption"):
            assert dask[key][metric] == here[key][metric]


def test_cores_per_task_follow_the_runner():
    """In process a task may use every core; a local pool shares them out over the tasks running at once;
    a remote scheduler's machines are not this one (1)."""
    import os

    from pipeline.paper.tasks import cores_per_task
    from pipeline.runners import DaskRunner, InProcessRunner, ProcessRunner

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert cores_per_task(InProcessRunner(), 5) == cpus
    assert cores_per_task(ProcessRunner(2), 10) == max(1, cpus // 2)
    assert cores_per_task(ProcessRunner(2), 1) == cpus          # one task left: it gets them all
    assert cores_per_task(DaskRunner(None, 4), 10) == max(1, cpus // 4)
    assert cores_per_task(DaskRunner("tcp://127.0.0.1:1", 4), 10) == 1


def test_sac_threads_are_measured_only_with_cores_to_spare():
    from pipeline.paper.sac.train import THREAD_GAIN, sac_threads

    assert sac_threads(1) == (1, "one core per task")
    threads, reason = sac_threads(2)  # what this machine measures now: either answer is legitimate,
    gain = float(reason.split("measured ")[1].split("x")[0].split()[-1])  # but it must follow the measurement
    assert threads in (1, 2) and (gain >= THREAD_GAIN) == (threads == 2)
