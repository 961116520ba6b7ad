"""The paper's rule-based controllers, hour by hour: as described (paper_application.md) and as published
(the SimBuild code, citylearn_behaviour.md section 9). CityLearn hour h is the hour ending at h:00."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.controllers import (
    PUBLISHED_RULES,
    RULE_SETS,
    RULES,
    cost_rbc,
    emission_rbc,
    peak_rbc,
    published_cost_rbc,
    published_emission_rbc,
    published_peak_rbc,
    rule_actions,
)

HOURS = range(1, 25)


def table(rule, day_type: int) -> list[float]:
    return [rule(h, day_type) for h in HOURS]


# Expected values per hour ending 1..24, written from the texts (c = charge, d = discharge per hour):
C9, D6, D24 = 1 / 9, -0.5 / 3, -0.5 / 12


def test_cost_rule_as_described_hour_by_hour():
    # off-peak 10 PM - 7 AM = hours ending 23, 24, 1..7 (9 h, +1/9 each: full capacity);
    # on-peak 3 - 6 PM = hours ending 16, 17, 18 (-0.5 / 3); the 12 other hours share the other half
    weekday = [C9] * 7 + [D24] * 8 + [D6] * 3 + [D24] * 4 + [C9] * 2
    assert table(cost_rbc, 1) == pytest.approx(weekday) and table(cost_rbc, 5) == pytest.approx(weekday)
    assert sum(weekday) == pytest.approx(0.0)              # charged fully, then emptied
    for weekend in (6, 7, 8):                              # Sat, Sun, holiday: flat cheap rate
        assert table(cost_rbc, weekend) == pytest.approx([1 / 24] * 24)


def test_cost_rule_as_published_hour_by_hour():
    # hour >= 22 or < 7: hours 22, 23, 24, 1..6 (one hour early); 15 <= hour < 18: 15, 16, 17
    weekday = [C9] * 6 + [D24] * 8 + [D6] * 3 + [D24] * 4 + [C9] * 3
    for day_type in (2, 3, 4, 5, 6):                       # Tue..Sat treated as weekdays
        assert table(published_cost_rbc, day_type) == pytest.approx(weekday)
    for day_type in (1, 7, 8):                             # Mon, Sun, holiday: +1/48 every hour
        assert table(published_cost_rbc, day_type) == pytest.approx([1 / 48] * 24)


def test_emission_rule_both_ways_hour_by_hour():
    # described: charge before 8 AM (hours ending 1..8, +1/8), discharge 12 PM - 11 PM (13..23, -1/11)
    described = [1 / 8] * 8 + [0.0] * 4 + [-1 / 11] * 11 + [0.0]
    # published: hour <= 7 -> +1/7 (7 h), 12 <= hour <= 22 -> -1/11 (11 h), else 0
    published = [1 / 7] * 7 + [0.0] * 4 + [-1 / 11] * 11 + [0.0] * 2
    for day_type in (1, 6):
        assert table(emission_rbc, day_type) == pytest.approx(described)
        assert table(published_emission_rbc, day_type) == pytest.approx(published)
    assert sum(described) == pytest.approx(0.0) and sum(published) == pytest.approx(0.0)


def test_peak_rule_both_ways_hour_by_hour():
    # described: charge before 6 AM (hours ending 1..6, +1/6), discharge 6 AM - 11 PM (7..23, -1/17)
    described = [1 / 6] * 6 + [-1 / 17] * 17 + [0.0]
    # published: hour < 6 -> +1/5 (5 h); hour 6 or 11..22 -> -1/14 (13 h... 1 + 12 = 13, 14 in the divisor)
    published = [1 / 5] * 5 + [-1 / 14] + [0.0] * 4 + [-1 / 14] * 12 + [0.0] * 2
    assert table(peak_rbc, 3) == pytest.approx(described)
    assert table(published_peak_rbc, 3) == pytest.approx(published)
    assert sum(published) == pytest.approx(1.0 - 13 / 14)  # the published rule leaves 1/14 in the battery


def test_rule_sets_read_the_controlled_step_or_the_observed_one(tmp_path):
    """Described rules read the hour of t + 1 (the step the action controls), published ones that of t."""
    from citylearn_env import CityLearnEnv
    from citylearn_env.example import write_example_district

    env = CityLearnEnv(write_example_district(tmp_path, n_buildings=1, hours=48, seed=3))
    env.reset(seed=0)
    assert RULE_SETS["described"] == (RULES, 1) and RULE_SETS["published"] == (PUBLISHED_RULES, 0)
    hour, day_type = env.data("hour")[0], env.data("day_type")[0]
    storages = [i for i, n in enumerate(env.action_names) if n.endswith("_storage")]
    for _ in range(30):
        t = env.t
        described = rule_actions(env, cost_rbc, 1)
        published = rule_actions(env, published_cost_rbc, 0)
        assert described[storages] == pytest.approx(cost_rbc(int(hour[t + 1]), int(day_type[t + 1])))
        assert published[storages] == pytest.approx(published_cost_rbc(int(hour[t]), int(day_type[t])))
        env.step(np.zeros(env.action_space.shape))
