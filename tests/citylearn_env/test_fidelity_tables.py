"""No-control energy and KPIs against stored upstream reference runs (issue 11, item 3: the fidelity tables).

The references are upstream's own code run outside this repository in scratch venvs, on the unchanged datasets
under ../shared/data/citylearn/upstream/ -- independent runs, not our output:

* ``benchmarks/upstream_2_1_2/no_control.json`` (``benchmarks/fidelity.py --store``): CityLearn 2.1.2 on the
  v2.1.2 datasets, ``CityLearnEnv(schema, central_agent=True)``, every action 0 for the whole episode: the
  district energy ``sum(env.net_electricity_consumption)`` [kWh] and every row of ``env.evaluate()``. Ours, in
  the 2.1 preset, must agree to 1e-4 relative on the energy and on every KPI row.
* ``benchmarks/upstream_2_5_0/no_control.json`` (``benchmarks/ev_upstream.py --only no-control``): CityLearn
  2.5.0 on the v2.4.2 datasets, every action inactive. Ours, in the 2.5 preset with every action inactive:
  district energy within 0.5 % -- and within 1e-6 once 2.5.0's bookkeeping of the first and last steps is
  applied to our series -- and every KPI both compute within 1e-4 except three upstream 2.5.0 effects, each
  checked against its own cause (see the ``_expected_2_5`` docstring and benchmarks/README.md).

The default run checks the small datasets (2023 phase 1, 2022 phase 1); the slow test checks every dataset.
Everything skips with a stated reason without ../shared.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, load_schema
from tests.conftest import ROOT, SHARED, need_shared

UPSTREAM = SHARED / "data" / "citylearn" / "upstream"
REF_212 = ROOT / "benchmarks" / "upstream_2_1_2" / "no_control.json"
REF_250 = ROOT / "benchmarks" / "upstream_2_5_0" / "no_control.json"
SMALL = ("citylearn_challenge_2023_phase_1", "citylearn_challenge_2022_phase_1")
#: CityLearn 2.5.0 KPI name -> our (CityLearn 2.1) name of the same quantity
RENAMED = {"all_time_peak_average": "annual_peak_average",
           "discomfort_cold_proportion": "discomfort_too_cold_proportion",
           "discomfort_hot_proportion": "discomfort_too_hot_proportion"}


def _references(path: Path) -> dict:
    return json.loads(path.read_text()) if path.is_file() else {}


def _cases(path: Path) -> list:
    """The datasets of a stored reference as test cases: the small ones in the default run, the rest slow."""
    return [pytest.param(n, marks=() if n in SMALL else pytest.mark.slow, id=n) for n in sorted(_references(path))]


def _value(v) -> float:
    """A stored KPI value as a float (null -> NaN; "nan"/"inf" strings -> their float)."""
    return math.nan if v is None else float(v)


def _close(ours: float, theirs: float, rel: float) -> bool:
    """Equal within ``rel`` of ``theirs``; NaN equals NaN, and magnitudes below 1e-9 count as 0 (upstream's
    float32 sizing leaves ~1e-11 kWh unserved where float64 serves it all)."""
    if math.isnan(ours) or math.isnan(theirs):
        return math.isnan(ours) and math.isnan(theirs)
    if math.isinf(ours) or math.isinf(theirs):
        return ours == theirs
    return abs(ours - theirs) <= max(rel * abs(theirs), 1e-9)


def _episode(env: CityLearnEnv, action: np.ndarray) -> int:
    """Step ``env`` with ``action`` until the episode ends; the number of step calls."""
    env.reset(seed=0)
    steps, done = 0, env.episode_length <= 1
    while not done:
        _, _, terminated, truncated, _ = env.step(action)
        steps, done = steps + 1, terminated or truncated
    return steps


def _kpis(env: CityLearnEnv) -> dict[tuple[str, str], float]:
    return {(r.cost_function, r.name): float(r.value) for r in env.evaluate().itertuples()}


# ------------------------------------------------------------------ v2.1.2 data against CityLearn 2.1.2
def check_2_1_2(name: str) -> None:
    reference = _references(REF_212)[name]
    schema = UPSTREAM / "v2.1.2" / name / "schema.json"
    need_shared(schema)
    env = CityLearnEnv(schema, settings="citylearn-2.1")
    assert _episode(env, np.zeros(env.action_space.shape)) == reference["steps"]
    energy = float(np.sum(env.series()["net_electricity_consumption"]))
    assert energy == pytest.approx(reference["district_energy_kwh"], rel=1e-4)
    ours = _kpis(env)
    off = [(k, n, ours.get((k, n)), v) for k, n, v in reference["kpis"]
           if (k, n) not in ours or not _close(ours[(k, n)], _value(v), 1e-4)]
    assert not off, f"{len(off)} of {len(reference['kpis'])} KPI rows off by more than 1e-4: {off[:5]}"


@pytest.mark.parametrize("name", _cases(REF_212))
def test_dataset_matches_citylearn_2_1_2(name):
    check_2_1_2(name)


# ------------------------------------------------------------------ v2.4.2 data against CityLearn 2.5.0
def _one_minus_load_factor(x: np.ndarray, window: int) -> float:
    """Mean over consecutive ``window``-step blocks of 1 - mean/max (the last block may be shorter)."""
    blocks = [x[i:i + window] for i in range(0, len(x), window)]
    return float(np.mean([1.0 - b.mean() / b.max() for b in blocks]))


def _expected_2_5(env: CityLearnEnv, kpi: str, building: str, ours: float) -> tuple[float, float]:
    """(value CityLearn 2.5.0 reports for ``kpi`` at ``building`` given our episode, absolute tolerance).

    Three upstream 2.5.0 effects, each recomputed from our own series:

    * daily/monthly 1 - load factor: 2.5.0 divides the value of ``env.net_electricity_consumption`` (a list
      ``update_variables`` appends once per step call: T - 1 entries) by that of the baseline series (building
      arrays sliced ``[0:time_step + 1]``: T entries, the last never simulated, 0), so the ratio is
      f(x[:T-1]) / f(x[:T-1] + [0]) instead of 1;
    * discomfort proportions (building rows and their district mean): 2.5.0 predicts a step's indoor temperature
      inside that step's ``apply_actions``, so the last time step, which no step call reaches, keeps the
      dataset's temperature: at most one occupied step per building counts differently (tolerance 1 /
      occupied steps);
    * carbon_emissions_total / cost_total where the schema has no carbon intensity / pricing file: 2.5.0 takes a
      zero baseline and its safe division returns 1.0; ours reports NaN (no signal, no ratio).
    """
    if kpi in ("daily_one_minus_load_factor_average", "monthly_one_minus_load_factor_average"):
        x = np.sum(env.series()["net_electricity_consumption"], axis=0)[:-1]
        window = 24 if kpi.startswith("daily") else 730
        return _one_minus_load_factor(x, window) / _one_minus_load_factor(np.append(x, 0.0), window), 1e-4
    if kpi.startswith("discomfort") and kpi.endswith("proportion"):
        occupied = (env.data("occupant_count") > 0).sum(axis=1)
        return ours, 1.0 / max(int(occupied.min()), 1) + 1e-12
    if kpi in ("carbon_emissions_total", "cost_total") and math.isnan(ours):
        signal = "carbon_intensity" if kpi.startswith("carbon") else "electricity_pricing"
        assert not env.data(signal).any(), f"{kpi} is NaN although {signal} is not all zero"
        return 1.0, 1e-9
    return ours, 0.0


def check_2_5_0(name: str) -> None:
    reference = _references(REF_250)[name]
    schema = UPSTREAM / "v2.4.2" / name / "schema.json"
    need_shared(schema)
    env = CityLearnEnv(load_schema(schema).with_actions([]), settings="citylearn-2.5")
    assert _episode(env, np.zeros(0)) == reference["step_calls"]
    theirs = reference["district_net_electricity_consumption_sum"]
    series = env.series()
    net = np.asarray(series["net_electricity_consumption"])
    assert net.sum() == pytest.approx(theirs, rel=5e-3)
    # and exactly, with 2.5.0's bookkeeping: only the T - 1 step calls (the last time step is never simulated)
    # and the first step's end-use consumption booked three times (Building.update_variables' time_step == 0
    # branch adds it at reset and again after the first apply_actions, which adds it too)
    first = sum(np.asarray(series[f"{k}_electricity_consumption"])[:, 0].sum()
                for k in ("cooling", "heating", "dhw", "non_shiftable_load"))
    assert net[:, :-1].sum() + 2 * first == pytest.approx(theirs, rel=1e-6)
    ours = _kpis(env)
    compared, off = 0, []
    for row in reference["kpis"]:
        key = (RENAMED.get(row["cost_function"], row["cost_function"]), row["name"])
        if key not in ours:
            continue  # a KPI only 2.5.0 computes (the split cold/hot discomfort deltas)
        expected, tolerance = _expected_2_5(env, key[0], key[1], ours[key])
        value = _value(row["value"])
        compared += 1
        if not (_close(expected, value, 1e-4) or abs(expected - value) <= tolerance):
            off.append((row["cost_function"], row["name"], ours[key], value))
    assert compared > len(reference["building_names"])
    assert not off, f"{len(off)} of {compared} KPI rows off: {off[:5]}"


@pytest.mark.parametrize("name", _cases(REF_250))
def test_dataset_matches_citylearn_2_5_0(name):
    check_2_5_0(name)


def test_load_factor_helper_by_hand():
    # blocks [1, 3] and [2, 2]: 1 - 2/3 and 1 - 2/2 -> mean 1/6
    assert _one_minus_load_factor(np.array([1.0, 3.0, 2.0, 2.0]), 2) == pytest.approx(1 / 6)
    # a short last block counts as a whole block: [2, 4, 4] -> 1 - (10/3)/4 = 1/6, [1] -> 0; mean 1/12
    assert _one_minus_load_factor(np.array([2.0, 4.0, 4.0, 1.0]), 3) == pytest.approx(1 / 12)
