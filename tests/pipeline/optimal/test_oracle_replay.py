"""The oracle's schedule replayed as actions in the environment (default preset, corrected): the env's own
objective must equal the LP's within 0.5 % (measured gaps are far smaller), following the plan's states of
charge or its energies open loop; and the oracle is never beaten by no control or the paper's rule-based
controllers on the same district.

Upstream datasets are CityLearn's own (../shared/data/citylearn/upstream/v2.1.2/); those tests skip with the
reason when ../shared is absent. The default district is the project's built one (artifacts/default), skipped
when it has not been built. One month per upstream dataset keeps the tests quick.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.example import write_example_district
from citylearn_env.settings import CORRECTED, PRESETS
from pipeline.controllers import run_policy
from pipeline.errors import InputError
from pipeline.optimal.optimum import district, optimal
from pipeline.optimal.oracle import oracle
from pipeline.optimal.plant import UNSUPPORTED_SETTINGS
from pipeline.optimal.replay import replay
from tests.conftest import ROOT, SHARED, need_shared

UPSTREAM = SHARED / "data" / "citylearn" / "upstream" / "v2.1.2"
DEFAULT = ROOT / "artifacts" / "default" / "schema.json"
GAP = 0.005  # the tolerance: 0.5 %


def need_default() -> None:
    if not DEFAULT.exists():
        pytest.skip(f"no built default district at {DEFAULT} (make run builds it)")


CASES = [
    # tanks (cooling + DHW, heat pump COP varying with the weather) and batteries; prices are all 0 in this
    # dataset, so the objective is emissions
    pytest.param("citylearn_challenge_2020_climate_zone_1", "emissions", 0, 719, id="2020_cz1-tanks-emissions"),
    # batteries only (5 buildings, PV, time-of-use prices)
    pytest.param("citylearn_challenge_2022_phase_1", "cost", 0, 719, id="2022_phase_1-battery-cost"),
    # stochastic power outages, depth-of-discharge floor, standing battery loss, an undersized DHW heater, LSTM
    # buildings (device actions inactive: the heat pump serves the ideal load)
    pytest.param("citylearn_challenge_2023_phase_2_online_evaluation_1", "cost", None, None,
                 id="2023_phase_2-outages-cost"),
]


@pytest.mark.parametrize(("name", "objective", "start", "end"), CASES)
def test_replay_matches_the_lp_on_upstream_data(name, objective, start, end):
    schema = UPSTREAM / name / "schema.json"
    need_shared(schema)
    env = CityLearnEnv(district(schema, start=start, end=end))
    assert env.settings == CORRECTED
    env.reset(seed=0)
    plan = oracle(env, objective)
    assert plan.value < plan.baseline[objective]  # the storage is worth something
    tracked, open_loop = replay(env, plan.schedule, track="soc"), replay(env, plan.schedule, track="energy")
    assert abs(tracked.gap[objective]) < GAP and abs(open_loop.gap[objective]) < GAP
    assert tracked.soc_gap < 1e-3  # the env's states of charge follow the plan


def test_replay_matches_the_lp_in_the_citylearn_2_1_preset():
    # CityLearn 2.1.2 exactly (its battery curve extrapolation among its quirks): the plan follows it as well
    schema = UPSTREAM / "citylearn_challenge_2022_phase_1" / "schema.json"
    need_shared(schema)
    result = optimal(schema, "cost", 0, 719, settings="citylearn-2.1", quiet=True)
    assert result.preset == "citylearn-2.1"
    assert abs(result.replay.gap["cost"]) < GAP


def test_presets_with_other_step_timing_are_refused(tmp_path):
    on = {name for name, preset in PRESETS.items() if any(getattr(preset, f, False) for f in UNSUPPORTED_SETTINGS)}
    if not on:
        pytest.skip("no preset turns on a setting the oracle does not follow")
    schema = write_example_district(tmp_path / "example", n_buildings=1, hours=48)
    for name in on:
        with pytest.raises(InputError, match="step timing"):
            optimal(schema, "cost", settings=name, quiet=True)


@pytest.mark.parametrize("objective", ["cost", "average_daily_peak"])
def test_replay_matches_the_lp_on_the_default_district(objective):
    need_default()
    end = None if objective == "cost" else 167  # the joint peak LP of 6 buildings: one week is enough here
    result = optimal(DEFAULT, objective, 0, end, quiet=True)
    assert abs(result.replay.gap[objective]) < GAP
    assert result.replay.soc_gap < 0.01


def test_weighted_sum_replays_on_the_example_district(tmp_path):
    # the project's synthetic district (DHW tank + battery per building): needs nothing outside the repository
    schema = write_example_district(tmp_path / "example", n_buildings=2, hours=96)
    out = tmp_path / "schedule.csv"
    result = optimal(schema, {"cost": 1.0, "average_daily_peak": 1.0}, out=out, normalise=True, quiet=True)
    for k in ("cost", "average_daily_peak"):
        assert abs(result.replay.gap[k]) < GAP
    frame = pd.read_csv(out)
    assert list(frame.columns[:3]) == ["time_step", "Building_1.dhw_storage.action", "Building_1.dhw_storage.soc"]
    assert len(frame) == 96 and frame["time_step"].tolist() == list(range(96))
    assert {"Building_2.electrical_storage.action", "Building_2.electrical_storage.soc"} <= set(frame.columns)
    assert frame.filter(like=".soc").to_numpy().min() >= -1e-9
    assert frame.filter(like=".soc").to_numpy().max() <= 1.0 + 1e-9
    assert "gap" in result.summary() and str(out) in result.summary()


def oracle_and_policies(schema, start, end) -> tuple[float, dict[str, float]]:
    """The oracle's cost as the env replays it, and each policy's cost on the same district and episode."""
    result = optimal(schema, "cost", start, end, quiet=True)
    config = district(schema, start=start, end=end)
    policies = {p: run_policy(config, p).objectives()["cost"]
                for p in ("no_control", "cost_rbc", "emission_rbc", "peak_rbc")}
    return result.replay.objectives["cost"], policies


def test_oracle_beats_no_control_and_rules_on_upstream_data():
    schema = UPSTREAM / "citylearn_challenge_2022_phase_1" / "schema.json"
    need_shared(schema)
    best, policies = oracle_and_policies(schema, 0, 719)
    assert all(best <= cost for cost in policies.values()), (best, policies)


def test_oracle_beats_no_control_and_rules_on_the_default_district():
    need_default()
    best, policies = oracle_and_policies(DEFAULT, None, None)
    assert all(best <= cost for cost in policies.values()), (best, policies)
    assert np.isfinite(best)


def test_episode_outside_the_data_is_refused(tmp_path):
    schema = write_example_district(tmp_path / "example", n_buildings=1, hours=48)
    with pytest.raises(ValueError, match="inside the simulation range 0..47"):
        district(schema, start=10, end=48)


def test_parallel_workers_give_the_same_optimum(tmp_path):
    # buildings solved in two spawned processes: the same optimum as one after the other (the plans may differ
    # where the LP has ties: other warm starts)
    schema = write_example_district(tmp_path / "example", n_buildings=3, hours=48)
    one = optimal(schema, "cost", quiet=True, check=False)
    two = optimal(schema, "cost", quiet=True, check=False, workers=2)
    assert two.bound == pytest.approx(one.bound, rel=1e-6)
    assert len(two.oracle.schedule.storages) == len(one.oracle.schedule.storages) == 6
