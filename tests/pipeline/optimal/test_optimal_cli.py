"""``districtgen optimal``: the best plan and its certified bound printed, the schedule written, bad options one line; ``--mpc`` through the
real CLI on an upstream dataset (skipped when ../shared is absent)."""

from __future__ import annotations

import pandas as pd
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from pipeline.cli import main
from pipeline.controllers import run_episode
from pipeline.optimal.optimum import district
from tests.conftest import SHARED, need_shared

pytest.importorskip("highspy")


@pytest.fixture(scope="module")
def schema(tmp_path_factory):
    return write_example_district(tmp_path_factory.mktemp("example"), n_buildings=2, hours=72, seed=1)


def test_optimal_prints_the_bound_and_writes_the_schedule(schema, tmp_path, capsys):
    out = tmp_path / "schedule.csv"
    assert main(["optimal", str(schema), "--objective", "cost", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("oracle: best plan found for cost over data rows 0..71") and "replay" in text
    assert "certified lower bound" in text and "gap" in text and "minimum" not in text  # batteries: not exact
    schedule = pd.read_csv(out)
    assert len(schedule) == 72 and schedule["time_step"].tolist() == list(range(72))
    actions = [c for c in schedule if c.endswith(".action")]
    assert len(actions) == 4 and all(schedule[c].between(-1, 1).all() for c in actions)  # 2 tanks, 2 batteries


def test_weighted_objectives_and_bad_options_are_one_line(schema, capsys):
    assert main(["optimal", str(schema), "--objective", "cost=1", "emissions=0.5", "--no-check", "--certify", "0"]) == 0
    assert "1 cost + 0.5 emissions" in capsys.readouterr().out
    for argv, says in ((["--objective", "comfort"], "unknown objective 'comfort'"),
                       (["--objective", "cost=-1"], "must be a finite number >= 0"),
                       (["--start", "50", "--end", "10"], "must lie inside the simulation range"),
                       (["--certify", "-1"], "--certify SECONDS needs a finite number >= 0"),
                       (["--certify", "nan"], "--certify SECONDS needs a finite number >= 0")):
        assert main(["optimal", str(schema), *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err


def test_mpc_through_the_cli_on_upstream_data(tmp_path, capsys):
    # CityLearn's own 2022 phase 1 (5 buildings, battery + PV): two days after 13 training days; MPC with day-ahead
    # forecasts printed beside the oracle's bound and no control, its actions written and replayed exactly
    schema = SHARED / "data" / "citylearn" / "upstream" / "v2.1.2" / "citylearn_challenge_2022_phase_1" / "schema.json"
    need_shared(schema)
    out = tmp_path / "mpc.csv"
    argv = ["optimal", str(schema), "--start", "312", "--end", "359", "--mpc", "--horizon", "12", "--forecast",
            "day_ahead", "--train", "0", "311", "-o", str(out), "--certify", "0"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    line = next(x for x in text.splitlines() if x.strip().startswith("cost") and "oracle" in x)
    mpc_cost, bound, none = (float(v) for v in (line.split()[1], line.split("oracle ")[1].split(",")[0],
                                                 line.split("no control ")[1].rstrip(")")))
    assert "mpc: horizon 12 steps, day_ahead forecasts" in text and f"MPC actions: {out}" in text
    assert bound * (1 - 1e-4) <= mpc_cost and bound < none
    schedule = pd.read_csv(out)
    assert len(schedule) == 48 and schedule["time_step"].tolist() == list(range(312, 360))
    env = CityLearnEnv(district(schema, start=312, end=359))
    env.reset(seed=0)
    positions = [env.building_names[b] + "." + slot + ".action" for slot, b in env.action_pairs]
    steps = iter(schedule[positions].to_numpy()[1:])
    run_episode(env, lambda _: next(steps), 0)
    assert env.objectives()["cost"] == pytest.approx(mpc_cost, rel=1e-5)


def test_mpc_options_need_mpc(schema, capsys):
    assert main(["optimal", str(schema), "--forecast", "persistence"]) == 2
    assert "apply to --mpc only" in capsys.readouterr().err
