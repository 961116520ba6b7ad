"""The paper runner's reference controllers: the oracle and MPC beside the RBC and SAC rows, the regret table,
the SOC figure and resumable reference tasks, on a three-test-day synthetic district (seconds)."""

from __future__ import annotations

import json
import math

import pytest

from citylearn_env.errors import InputError
from citylearn_env.example import write_example_district
from pipeline.paper.benchmarks import BENCHMARKS, RunOptions
from pipeline.paper.reference import unsupported
from pipeline.paper.results import captured, regret_table
from pipeline.paper.tasks import plan_tasks, run_paper

BY_ID = {b.id: b for b in BENCHMARKS}
#: a storage configuration per objective and device set with its RBC, two with their SAC (1 episode)
IDS = ["x-b1_b2-x-x", "x-b1_b2-x-pv", "rbc-b1-c-dhw", "rbc-b1-e-bess_pv", "rbc-b1-c-dhw_bess_pv",
       "rlc-b1-c-dhw_bess_pv", "rbc-b1_b2-p-bess_pv", "rlc-b1_b2-p-bess_pv"]
#: one SAC episode on one thread (no thread measurement)
OPTIONS = RunOptions(sac_episodes=1, sac_threads=1)
SAC_CONFIGS = {"b1-c-dhw_bess_pv", "b1_b2-p-bess_pv"}
#: 13 training days + 3 test days
HOURS = 16 * 24


@pytest.fixture(scope="module")
def paper(tmp_path_factory):
    """The paper on IDS with every controller (SAC: 1 episode) and its output folder."""
    out = tmp_path_factory.mktemp("paper_oracle")
    schema = write_example_district(tmp_path_factory.mktemp("district"), n_buildings=2, hours=HOURS, seed=5)
    result = run_paper(schema, out, only=IDS, sweep=(), options=OPTIONS, log=lambda *_: None)
    return schema, out, result


def test_oracle_is_never_worse_than_rbc_or_sac(paper):
    _, _, result = paper
    rows = [r for r in result["regret"] if "value" in r]
    configs = {r["configuration"] for r in rows}
    assert configs == {"b1-c-dhw", "b1-e-bess_pv", "b1-c-dhw_bess_pv", "b1_b2-p-bess_pv"}
    for config in configs:
        mine = {r["controller"]: r for r in rows if r["configuration"] == config}
        best = mine["oracle"]["value"]
        assert set(mine) >= {"rbc", "mpc", "oracle"} and ("sac" in mine) == (config in SAC_CONFIGS), config
        for controller in {"rbc", "sac"} & set(mine):
            assert best <= mine[controller]["value"] * (1 + 1e-6) + 1e-9, (config, controller)
        # the oracle saves against no control and captures its own saving
        assert best <= mine["oracle"]["no_control"] + 1e-9
        if math.isfinite(mine["oracle"]["captured"]):
            assert mine["oracle"]["captured"] == pytest.approx(1.0)


def test_benchmark_rows_carry_oracle_and_mpc(paper):
    _, out, result = paper
    rows = {r["id"]: r for r in result["results"]}
    cost = rows["rbc-b1-c-dhw_bess_pv"]
    assert cost["objective"] == "cost" and cost["oracle"] <= cost["cost"] and math.isfinite(cost["mpc"])
    assert cost["captured"] == pytest.approx((cost["no_control"] - cost["cost"]) / (cost["no_control"] - cost["oracle"]))
    peak = rows["rbc-b1_b2-p-bess_pv"]
    assert peak["objective"] == "average_daily_peak" and peak["oracle"] <= peak["average_daily_peak"] + 1e-9
    assert "objective" not in rows["x-b1_b2-x-x"]
    # MPC of the daily peak: a run, or skipped with mpc's reason in the table
    table = (out / "regret.md").read_text()
    assert "| b1_b2-p-bess_pv | average_daily_peak kW |" in table and "| b1-c-dhw | cost $ |" in table
    assert (out / "regret.csv").is_file() and (out / "soc_trajectories.png").stat().st_size > 10_000
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert {"oracle", "mpc", "no_control", "captured"} <= set(header)


def test_reference_tasks_resume(paper):
    schema, out, result = paper
    task = out / "tasks" / "oracle-b1-c-dhw-s0.json"
    stored = json.loads(task.read_text())
    assert stored["result"]["controller"] == "oracle" and stored["result"]["steps"] == 3 * 24 - 1
    stored["result"]["cost"] = -1.0
    task.write_text(json.dumps(stored))
    again = run_paper(schema, out, only=IDS, sweep=(), options=OPTIONS,
                      controllers=("oracle",), log=lambda *_: None)
    oracle = {r["configuration"]: r for r in again["regret"] if r["controller"] == "oracle"}
    assert oracle["b1-c-dhw"]["value"] == -1.0                      # reused as written, not rerun
    assert {r["controller"] for r in again["regret"]} == {"oracle"}


def test_plan_and_guards():
    every = plan_tasks(None, (1.0, 3.0, 6.0, 12.0))
    keys = {t.key for t in every}
    # the seven storage configurations of the paper get an oracle and an MPC task; the heat pump does not
    references = sorted(k for k in keys if k.startswith(("oracle-", "mpc-")))
    assert len(references) == 14 and "oracle-b1-c-dhw-s0" in references and "mpc-b1_b2-p-bess_pv-s0" in references
    assert not any("d_o" in k for k in references)
    assert len(every) == 17 + 3 + 14
    only_rbc = plan_tasks(None, (1.0,), controllers=("rbc",))
    assert {BY_ID[t.id].control for t in only_rbc} == {"none", "rbc"} and not any(t.controller for t in only_rbc)
    assert "LSTM" in unsupported(BY_ID["rlc-b1-d_o-hp"]) and unsupported(BY_ID["x-b1_b2-x-pv"])
    assert unsupported(BY_ID["rlc-b1-e-dhw"]) is None
    with pytest.raises(InputError, match="unknown controller"):
        plan_tasks(None, (), controllers=("lqr",))


def test_captured_share_by_hand():
    assert captured(10.0, 8.0, 6.0) == pytest.approx(0.5)
    assert captured(10.0, 11.0, 6.0) == pytest.approx(-0.25)
    assert math.isnan(captured(10.0, 9.0, 10.0)) and math.isnan(captured(float("nan"), 9.0, 8.0))


def _regret(config: str, controller: str, value: float, no_control: float, oracle: float) -> dict:
    return {"configuration": config, "objective": "cost", "unit": "$", "controller": controller, "value": value,
            "value_sd": 0.0, "seeds": 1, "no_control": no_control, "oracle": oracle,
            "captured": captured(no_control, value, oracle), "note": ""}


def test_an_rbc_worse_than_no_control_gets_one_line():
    rows = [_regret("b1-c-dhw", "rbc", 20.5, 20.0, 18.0), _regret("b1-c-dhw", "oracle", 18.0, 20.0, 18.0),
            _regret("b1-c-bess_pv", "rbc", 19.0, 20.0, 18.0), _regret("b1-c-bess_pv", "oracle", 18.0, 20.0, 18.0)]
    text = regret_table(rows)
    notes = [line for line in text.splitlines() if "worse than no control" in line]
    # 20.5 against 20.0: 2.5 % above; the RBC that saves (19.0 < 20.0) gets no line
    assert len(notes) == 1 and notes[0].startswith("b1-c-dhw:") and "(+2.5 %)" in notes[0]
    assert "| b1-c-dhw | cost $ | 20.000 | 20.500 (-25.0 %) |" in text
