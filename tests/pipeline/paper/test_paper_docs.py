"""``districtgen paper --docs PAGE``: the documentation's page of the paper's tables holds the runner's numbers
(issue 47, item 8: result tables are generated, never pasted)."""

from __future__ import annotations

import re

import pytest

from citylearn_env.example import write_example_district
from pipeline.cli import main
from pipeline.paper.results import docs_page

IDS = ["x-b1_b2-x-x", "x-b1_b2-x-pv", "rbc-b1-c-bess_pv", "rlc-b1-c-bess_pv"]


def table_rows(page: str, header: str) -> dict[str, list[str]]:
    """The cells of the markdown table whose header line starts with ``header``, keyed by the first cell."""
    lines = page.split("\n")
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows[cells[0]] = cells[1:]
    return rows


def number(cell: str) -> float:
    """The leading number of a table cell (``18.759 (33.0 %)`` -> 18.759)."""
    return float(re.match(r"-?[\d.]+", cell).group(0))


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    """A tiny paper run through the CLI (four benchmarks, one SAC episode, the oracle) with ``--docs``."""
    folder = tmp_path_factory.mktemp("paper_docs")
    schema = write_example_district(folder / "district", n_buildings=3, hours=720, seed=11)
    out, page = folder / "out", folder / "docs" / "paper_results.md"
    page.parent.mkdir()
    status = main(["paper", str(schema), "-o", str(out), "--only", *IDS, "--sac-episodes", "1", "--workers", "1",
                   "--controllers", "rbc", "sac", "oracle", "--docs", str(page)])
    assert status == 0
    return out, page, schema


def test_page_holds_the_runners_numbers(paper_run):
    import pandas as pd

    out, page, _ = paper_run
    text = page.read_text()
    results = pd.read_csv(out / "results.csv").set_index("id")
    rows = table_rows(text, "| benchmark |")
    assert sorted(rows) == sorted(IDS)
    for bench in IDS:
        cost, emissions, discomfort, consumption, peak = (number(c) for c in rows[bench][1:6])
        run = results.loc[bench]
        assert cost == pytest.approx(run["cost"], abs=5e-4)
        assert emissions == pytest.approx(run["emissions"], abs=5e-3)
        assert discomfort == pytest.approx(run["discomfort"], abs=0.05)
        assert consumption == pytest.approx(run["consumption"], abs=5e-3)
        assert peak == pytest.approx(run["average_daily_peak"], abs=5e-4)
    # the change against no control with PV, recomputed from the runner's numbers
    base = results.loc["x-b1_b2-x-pv", "cost"]
    change = 100 * (results.loc["rbc-b1-c-bess_pv", "cost"] - base) / base
    assert rows["rbc-b1-c-bess_pv"][6].split(" / ")[1] == f"{change:+.1f} %"
    # the regret table: the oracle's value is the reference run's, and the RBC's captured share follows from it
    regret = pd.read_csv(out / "regret.csv")
    oracle = regret[(regret.configuration == "b1-c-bess_pv") & (regret.controller == "oracle")].iloc[0]
    rbc = regret[(regret.configuration == "b1-c-bess_pv") & (regret.controller == "rbc")].iloc[0]
    line = table_rows(text, "| configuration |")["b1-c-bess_pv"]
    assert number(line[-1]) == pytest.approx(oracle["value"], abs=5e-4)
    share = 100 * (rbc["no_control"] - rbc["value"]) / (rbc["no_control"] - oracle["value"])
    assert f"({share:.1f} %)" in line[2]


def test_page_names_the_command_date_and_cpu(paper_run):
    import pandas as pd

    out, page, _ = paper_run
    text = page.read_text()
    assert text.startswith("# The paper's benchmarks")
    assert "--sac-episodes 1" in text and "--controllers rbc sac oracle" in text and f"--docs {page}" in text
    assert re.search(r"page written \d{4}-\d\d-\d\d \d\d:\d\d UTC on .+load average \d", text)
    # where the runs themselves finished: every run of this folder, on this machine's CPU
    from surrogates.precision import capability

    runs = len(pd.read_csv(out / "runs.csv"))
    assert f"{runs} on {capability().describe()} (load average " in text
    assert re.search(r"The runs finished \d{4}-\d\d-\d\d \d\d:\d\d to \d{4}-\d\d-\d\d \d\d:\d\d UTC", text)
    assert "SAC training: " in text
    # the page is the run folder's tables, never retyped: regenerating from the folder gives the same tables
    again = docs_page(out, command="c", machine="m", finished="f")
    assert again.split("## ", 1)[1] == text.split("## ", 1)[1]
    assert "## The m-sweep" not in text                    # no sweep ran: no table


def test_rerun_on_a_finished_folder_rewrites_the_page_without_running(paper_run, capsys):
    out, page, schema = paper_run
    before = {p.name: p.stat().st_mtime_ns for p in (out / "tasks").iterdir()}
    page.unlink()
    status = main(["paper", str(schema), "-o", str(out), "--only", *IDS,
                   "--sac-episodes", "1", "--workers", "1", "--controllers", "rbc", "sac", "oracle",
                   "--docs", str(page)])
    assert status == 0 and page.is_file()
    assert "0 to run" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in (out / "tasks").iterdir()} == before


def test_rewritten_page_names_the_runs_machines_not_only_its_own(paper_run, tmp_path):
    """A folder whose task files came from elsewhere (another CPU, or before the record was kept): the page says
    so from the runs' own records, whatever machine rewrites it."""
    import shutil

    import pandas as pd

    from pipeline.paper.results import write_docs_page

    out, _, _ = paper_run
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    runs = pd.read_csv(copy / "runs.csv")
    runs.loc[0, "machine"] = "Some Other CPU (avx2)"
    runs.loc[0, "load_average"] = 3.25
    runs.loc[1, ["machine", "load_average", "finished_utc"]] = None
    runs.to_csv(copy / "runs.csv", index=False)
    text = write_docs_page(copy, tmp_path / "page.md", command="c").read_text()
    assert "1 on Some Other CPU (avx2) (load average 3.2-3.2)" in text
    assert f"{len(runs) - 2} on " in text
    assert "1 earlier run's task file does not record its machine." in text
