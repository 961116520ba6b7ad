"""A district validated in chunks of buildings gives what one environment over all its buildings gives.

The buildings of a CityLearn district share no state (each has its own storage, devices and data), so each
chunk's per-building values must equal the whole district's, and the district KPIs and objectives computed
on the chunks' summed series must equal those of the district sums (to rounding: sums in another order).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from pipeline.builder.validate import oracle_objectives, validate_district
from pipeline.runners import ProcessRunner

SHARED = Path(__file__).resolve().parents[4] / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2"
PHASE_1 = SHARED / "citylearn_challenge_2022_phase_1" / "schema.json"  # 5 buildings, batteries + PV

pytestmark = pytest.mark.skipif(not PHASE_1.is_file(), reason=f"needs ../shared's CityLearn data ({PHASE_1})")


@pytest.fixture(scope="module")
def whole_and_chunked(tmp_path_factory):
    """Phase 1's first week (a copy of its files), validated whole and in chunks of 2 buildings (2 + 2 + 1)
    on two worker processes."""
    folder = tmp_path_factory.mktemp("phase_1")
    for path in PHASE_1.parent.iterdir():
        if path.is_file():
            shutil.copy(path, folder / path.name)
    schema = json.loads(PHASE_1.read_text())
    schema.update(simulation_start_time_step=0, simulation_end_time_step=167)
    (folder / "schema.json").write_text(json.dumps(schema))
    return (validate_district(folder / "schema.json"),
            validate_district(folder / "schema.json", ProcessRunner(2), chunk_buildings=2))


def test_per_building_values_equal_in_chunks(whole_and_chunked):
    whole, chunked = whole_and_chunked
    for policy, run in whole.runs.items():
        other = chunked.runs[policy]
        for key, values in run.per_building.items():
            np.testing.assert_array_equal(other.per_building[key], values, err_msg=f"{policy} {key}")
        rows = run.kpis[run.kpis["level"] == "building"].reset_index(drop=True)
        rows_chunked = other.kpis[other.kpis["level"] == "building"].reset_index(drop=True)
        assert rows[["cost_function", "name"]].equals(rows_chunked[["cost_function", "name"]])
        np.testing.assert_array_equal(rows_chunked["value"].to_numpy(), rows["value"].to_numpy())


def test_district_values_from_summed_chunks(whole_and_chunked):
    whole, chunked = whole_and_chunked
    for policy, run in whole.runs.items():
        other = chunked.runs[policy]
        district = run.kpis[run.kpis["level"] == "district"].set_index("cost_function")["value"]
        district_chunked = other.kpis[other.kpis["level"] == "district"].set_index("cost_function")["value"]
        assert list(district.index) == list(district_chunked.index)
        np.testing.assert_allclose(district_chunked.to_numpy(), district.to_numpy(), rtol=1e-9, equal_nan=True)
        for key, value in run.objectives.items():
            assert other.objectives[key] == pytest.approx(value, rel=1e-9, nan_ok=True), (policy, key)
        np.testing.assert_allclose(other.district_net, run.district_net, rtol=1e-9, atol=1e-9)
        assert other.series_buildings == run.series_buildings         # 5 buildings: every one has figures
        for key, values in run.series.items():
            np.testing.assert_array_equal(other.series[key], values, err_msg=key)


def test_the_oracle_splits_per_building_and_skips_the_joint_peak(whole_and_chunked):
    """Cost and emissions are one problem per building: summed over chunks they are the whole district's; the
    district peak couples the buildings, so a chunked validation names it as not run."""
    whole, chunked = whole_and_chunked
    assert set(whole.oracle.bounds) == {"cost", "emissions", "average_daily_peak"} and not whole.oracle.skipped
    assert set(chunked.oracle.bounds) == {"cost", "emissions"}
    assert "optimal DISTRICT --objective average_daily_peak" in chunked.oracle.skipped["average_daily_peak"]
    assert chunked.oracle.storages == whole.oracle.storages == 5
    for key in ("cost", "emissions"):
        a, b = whole.oracle.bounds[key], chunked.oracle.bounds[key]
        assert b.no_control == pytest.approx(a.no_control, rel=1e-9)
        assert b.lower_bound == pytest.approx(a.lower_bound, rel=1e-6)
        # the best plan is a local optimum (docs/controllers.md): the same to 0.1 %, both above the bound
        assert b.plan == pytest.approx(a.plan, rel=1e-3)
        assert b.lower_bound <= b.plan <= b.no_control + 1e-9 and a.lower_bound <= a.plan


def test_the_oracle_budget():
    small = oracle_objectives(6, 720)
    assert small.run == ("cost", "emissions", "average_daily_peak") and not small.skipped
    year = oracle_objectives(1000, 8760, one_chunk=False)
    assert year.run == () and set(year.skipped) == {"cost", "emissions", "average_daily_peak"}
    month = oracle_objectives(100, 720, one_chunk=False)
    assert month.run == ("cost", "emissions") and "one joint LP" in month.skipped["average_daily_peak"]
