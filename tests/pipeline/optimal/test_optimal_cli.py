"""``districtgen optimal``: the bound printed, the schedule written, bad options one line."""

from __future__ import annotations

import pandas as pd
import pytest

from citylearn_env.example import write_example_district
from pipeline.cli import main

pytest.importorskip("highspy")


@pytest.fixture(scope="module")
def schema(tmp_path_factory):
    return write_example_district(tmp_path_factory.mktemp("example"), n_buildings=2, hours=72, seed=1)


def test_optimal_prints_the_bound_and_writes_the_schedule(schema, tmp_path, capsys):
    out = tmp_path / "schedule.csv"
    assert main(["optimal", str(schema), "--objective", "cost", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("oracle: minimum cost over data rows 0..71") and "replay" in text and "gap" in text
    schedule = pd.read_csv(out)
    assert len(schedule) == 72 and schedule["time_step"].tolist() == list(range(72))
    actions = [c for c in schedule if c.endswith(".action")]
    assert len(actions) == 4 and all(schedule[c].between(-1, 1).all() for c in actions)  # 2 tanks, 2 batteries


def test_weighted_objectives_and_bad_options_are_one_line(schema, capsys):
    assert main(["optimal", str(schema), "--objective", "cost=1", "emissions=0.5", "--no-check"]) == 0
    assert "1 cost + 0.5 emissions" in capsys.readouterr().out
    for argv, says in ((["--objective", "comfort"], "unknown objective 'comfort'"),
                       (["--objective", "cost=-1"], "must be a finite number >= 0"),
                       (["--start", "50", "--end", "10"], "must lie inside the simulation range")):
        assert main(["optimal", str(schema), *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err
