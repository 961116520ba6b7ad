"""The build report's oracle bounds (computed in pipeline/builder/validate.py, shown by pipeline/builder/report.py): cost, emissions and average daily peak of the
perfect-foresight storage schedule next to the policies, and one line instead of a crash where the oracle
does not apply. (Here beside the paper's oracle tests; the report's own tests build a district.)"""

from __future__ import annotations

import pytest

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.example import write_example_district
from pipeline.builder.report import oracle_table
from pipeline.builder.validate import ORACLE_BOUNDS, oracle_bounds
from pipeline.controllers import run_policy, without_device_actions


@pytest.fixture(scope="module")
def district(tmp_path_factory):
    """A synthetic two-building district over four days (DHW tanks and batteries)."""
    return load_schema(write_example_district(tmp_path_factory.mktemp("report_oracle"), n_buildings=2, hours=96,
                                              seed=3))


def test_bounds_sit_below_no_control_and_the_rule(district):
    policies = {p: run_policy(district, p) for p in ("no_control", "cost_rbc")}
    objectives = {p: {k: v for k, v in env.objectives().items() if k != "per_building"} for p, env in policies.items()}
    found = oracle_bounds(district, env=policies["no_control"])
    assert found.storages == 4 and set(found.bounds) == set(ORACLE_BOUNDS) and found.reason is None
    for key, bound in found.bounds.items():
        # the LP's no control is the env's, and the oracle is no worse than either policy
        assert bound.no_control == pytest.approx(objectives["no_control"][key], rel=1e-6)
        assert bound.plan <= min(objectives[p][key] for p in objectives) + 1e-9
        # the certified lower bound sits at or below the best plan (a relaxation of the same problem)
        assert bound.lower_bound <= bound.plan + 1e-9 * max(1.0, abs(bound.plan))
    lines = oracle_table(found, objectives)
    rows = [line for line in lines if line.startswith("| cost |") or line.startswith("| average daily peak |")]
    assert len(rows) == 2 and rows[0].count("|") == 9 and " %" in rows[0]
    assert oracle_bounds(district) == found                           # a new env gives the same bounds


def test_an_unsupported_configuration_is_one_line(district):
    env = CityLearnEnv(without_device_actions(district), settings="citylearn-2.5")
    found = oracle_bounds(district, env=env)
    assert not found.bounds and "\n" not in found.reason and "settings" in found.reason
    lines = oracle_table(found, {})
    assert lines[2].startswith("No oracle: ") and len(lines) == 4
