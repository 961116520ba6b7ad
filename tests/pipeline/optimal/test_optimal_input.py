"""``districtgen optimal`` on problems that are not meaningful (issue 50 item 4): each one clear line and a non-zero
exit, or, where the case is legitimate (a plan worse than no control), one stated warning and no control reported
as the best plan. The district is the 2-building, 72-hour example of test_optimal_cli.py, edited per case."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pandas as pd
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from pipeline.cli import main
from pipeline.controllers import run_episode
from pipeline.optimal.optimum import district, optimal

pytest.importorskip("highspy")


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    return write_example_district(tmp_path_factory.mktemp("example"), n_buildings=2, hours=72, seed=1).parent


def variant(example, tmp_path, *, battery=None, prices=None):
    """A copy of the example with Building_1's battery attributes updated by ``battery`` and every price column
    mapped by ``prices``; returns its schema path."""
    folder = tmp_path / "district"
    shutil.copytree(example, folder)
    schema = folder / "schema.json"
    if battery:
        document = json.loads(schema.read_text())
        document["buildings"]["Building_1"]["electrical_storage"]["attributes"].update(battery)
        schema.write_text(json.dumps(document))
    if prices is not None:
        frame = pd.read_csv(folder / "pricing.csv")
        frame.apply(prices).to_csv(folder / "pricing.csv", index=False)
    return schema


def one_line_error(argv, capsys, status=2) -> str:
    assert main(["optimal", *argv]) == status
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("districtgen: error: ") and "Traceback" not in captured.err, err
    return err[0]


def test_normalising_by_a_negative_no_control_value_is_refused(example, tmp_path, capsys):
    # prices negated: every kWh imported earns, so no control's cost is < 0; dividing the weight by it would turn
    # the minimisation into a maximisation (issue 50: a "minimum" of 157,857 $ against -246 $)
    schema = variant(example, tmp_path, prices=lambda column: -column)
    line = one_line_error([str(schema), "--normalise"], capsys)
    assert "'--normalise'" in line and "must be > 0" in line and "cost is -" in line


def test_negative_prices_are_refused(example, tmp_path, capsys):
    # -100 $/kWh is inside the environment's range, but max(net, 0) x a negative price is not convex: the LP would
    # leave those steps out and report a plan and a bound that are not the env's
    schema = variant(example, tmp_path, prices=lambda column: column * 0 - 100.0)
    line = one_line_error([str(schema)], capsys)
    assert "Building_1, column/key 'electricity_pricing', row episode step 1" in line
    assert "price -100 $/kWh" in line


@pytest.mark.parametrize("weight", ["1e15", "1e-12"])
def test_weights_outside_the_stated_range_are_refused(example, capsys, weight):
    line = one_line_error([str(example / "schema.json"), "--objective", f"cost={weight}"], capsys)
    assert "'objective'" in line and "at most 1e+06" in line and "at least 1e-06" in line


@pytest.mark.parametrize("battery, says", [
    ({"efficiency": 1e-300}, "round-trip efficiency of 1e-300"),
    ({"power_efficiency_curve": [[0.0, 0.0], [1.0, 0.9]]}, "round-trip efficiency of 0"),
    ({"loss_coefficient": 1.0}, "standing loss of 1 per step"),
])
def test_device_parameters_the_lp_cannot_divide_by_are_refused(example, tmp_path, capsys, battery, says):
    # each value is inside citylearn_env.ranges (the env runs it); the LP divides by sqrt(efficiency) and by the
    # retention 1 - loss (issue 50: efficiency 1e-300 ended in a 27-line SolveError traceback)
    line = one_line_error([str(variant(example, tmp_path, battery=battery))], capsys)
    assert line.startswith("districtgen: error: Building_1, column/key 'electrical_storage': ") and says in line


def test_a_solver_failure_is_one_line(example, tmp_path, capsys):
    # a depth of discharge of 1e-12 (inside the env's 0..1) makes LP coefficients of about 1e-12, which HiGHS
    # does not load: the status in one line, exit 1
    schema = variant(example, tmp_path, battery={"depth_of_discharge": 1e-12})
    line = one_line_error([str(schema)], capsys, status=1)
    assert "the oracle's linear program was not solved: HiGHS" in line


def test_a_plan_worse_than_no_control_reports_no_control(example, tmp_path, capsys):
    # a 1,000,000 kWh battery starting at its depth-of-discharge floor: the LP's penalty on sinking below the floor
    # (standing loss) buys energy to hold it there, a plan far worse than leaving every storage idle
    schema = variant(example, tmp_path, battery={"capacity": 1e6})
    out = tmp_path / "schedule.csv"
    assert main(["optimal", str(schema), "-o", str(out)]) == 0
    text = capsys.readouterr().out.splitlines()
    env = CityLearnEnv(district(schema))
    run_episode(env, lambda _: np.zeros(len(env.action_pairs)), 0)  # no control, independently
    idle = env.objectives()["cost"]
    warning = [line for line in text if "warning" in line]
    assert len(warning) == 1 and "is worse than no control" in warning[0]
    best = next(line for line in text if "best plan" in line and "bound" in line)
    assert float(best.split("best plan ")[1].split()[0]) == pytest.approx(idle, rel=1e-5)
    assert float(best.split("certified lower bound ")[1].split()[0]) <= idle
    schedule = pd.read_csv(out)
    assert (schedule.filter(like=".action").to_numpy() == 0).all()
    assert schedule["Building_1.electrical_storage.soc"].iloc[0] == pytest.approx(0.2)  # initial_soc = 1 - 0.8
    assert schedule["Building_1.electrical_storage.soc"].is_monotonic_decreasing  # standing loss only


def test_tiny_prices_give_the_same_plan_scaled(example, tmp_path):
    # the optimum does not change when every price is multiplied by 1e-9, so the best plan's cost is 1e-9 x the
    # original's; before the LP's coefficients were scaled, HiGHS's absolute tolerance (1e-7) took any plan as
    # optimal and the "certified lower bound" lay above the plan
    base = optimal(example / "schema.json", "cost", quiet=True)
    tiny = optimal(variant(example, tmp_path, prices=lambda column: column * 1e-9), "cost", quiet=True)
    assert tiny.value == pytest.approx(base.value * 1e-9, rel=1e-4)
    assert tiny.bound == pytest.approx(base.bound * 1e-9, rel=1e-4) and tiny.bound <= tiny.value
