"""pipeline/paper/results.py: the m-sweep table carries the seeds' spread of its SAC rows."""

from __future__ import annotations

from pipeline.paper.results import METRICS, summarise, sweep_table


def run(multiplier: float, discomfort: float, consumption: float) -> dict:
    values = dict.fromkeys(METRICS, 0.5)
    return {**values, "multiplier": multiplier, "discomfort": discomfort, "consumption": consumption,
            "below_above": "overcooling/undercooling"}


def cells(table: str) -> list[list[str]]:
    return [[c.strip() for c in line.strip("|").split("|")] for line in table.strip().split("\n")[2:]]


def test_sweep_rows_of_several_seeds_give_mean_and_sample_std():
    rows = [summarise([run(1, 40.0, 700.0), run(1, 50.0, 710.0), run(1, 60.0, 720.0)]),
            summarise([run(3, 90.0, 690.0), run(3, 110.0, 700.0), run(3, 100.0, 680.0)])]
    first, second = cells(sweep_table(rows))
    # mean and sample standard deviation (n - 1) of the three seeds, worked by hand
    assert first[:2] == ["1", "50.0 ± 10.0"] and first[4] == "710.00 ± 10.00"
    assert second[:2] == ["3", "100.0 ± 10.0"] and second[4] == "690.00 ± 10.00"
    # changes against m = 1 use the means: +100 % discomfort, 690 / 710 - 1 = -2.8 % consumption
    assert second[5:] == ["+100.0 %", "-2.8 %"]


def test_sweep_rows_of_one_seed_have_no_spread():
    (only,) = cells(sweep_table([summarise([run(1, 46.4, 752.5)])]))
    assert only[1] == "46.4" and only[4] == "752.50"
