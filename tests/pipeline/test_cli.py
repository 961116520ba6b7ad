"""The districtgen command: bad input ends with one line naming file and key, exit status 2, no traceback."""

from __future__ import annotations

import json

import pytest

from citylearn_env.example import write_example_district
from pipeline.cli import main


def test_run_prints_the_kpi_table(tmp_path, capsys):
    schema = write_example_district(tmp_path, n_buildings=2, hours=48)
    assert main(["run", "--schema", str(schema), "--policy", "zero"]) == 0
    out = capsys.readouterr().out
    assert "electricity_consumption_total" in out and "average_daily_peak" in out


def test_bad_schema_is_one_line_exit_2(tmp_path, capsys):
    schema = write_example_district(tmp_path, n_buildings=1, hours=48)
    raw = json.loads(schema.read_text())
    raw["buildings"]["Building_1"]["pv"]["type"] = "citylearn.energy_model.Windmill"
    schema.write_text(json.dumps(raw))
    assert main(["run", "--schema", str(schema)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "buildings.Building_1.pv.type" in err[0] and "Windmill" in err[0] and "Traceback" not in err[0]


def test_bad_build_config_is_one_line_exit_2(tmp_path, capsys):
    config = tmp_path / "district.toml"
    config.write_text('name = "x"\n[period]\nstart = 2018-06-01\nend = 2018-06-02\n')
    assert main(["build", str(config)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "district.toml" in err[0] and "'inputs'" in err[0]


def test_verify_reports_a_missing_manifest(tmp_path, capsys):
    assert main(["verify", str(tmp_path)]) == 2
    assert "no manifest.json" in capsys.readouterr().err


def test_paper_precision_and_threads_options(tmp_path, capsys):
    """``--precision`` and ``--sac-threads`` reach the run: a bad thread count is one line (exit 2), and an
    RBC-only run records no precision for its rows."""
    schema = write_example_district(tmp_path / "d", n_buildings=2, hours=360, seed=2)
    assert main(["paper", str(schema), "-o", str(tmp_path / "p"), "--sac-threads", "0"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--sac-threads" in err
    with pytest.raises(SystemExit):
        main(["paper", str(schema), "-o", str(tmp_path / "p"), "--precision", "fp8"])
    capsys.readouterr()
    assert main(["paper", str(schema), "-o", str(tmp_path / "p"), "--only", "rbc-b1-c-bess_pv",
                 "--precision", "float32", "--workers", "1"]) == 0
    stored = json.loads((tmp_path / "p" / "tasks" / "rbc-b1-c-bess_pv-m3-s0.json").read_text())
    assert stored["fingerprint"]["precision"] == "float32" and stored["result"]["precision"] == "-"
    assert "cores" not in stored["fingerprint"]  # where a task ran does not make it another result
