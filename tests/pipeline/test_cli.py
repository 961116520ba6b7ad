"""The districtgen command: bad input ends with one line naming file and key, exit status 2, no traceback."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from citylearn_env.example import write_example_district
from pipeline.cli import build_parser, main
from pipeline.errors import InputError
from surrogates import cli as surrogate_commands

ROOT = Path(__file__).resolve().parents[2]


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


#: modules of the extras (and the LP solver) that ``run`` must not load: it is the environment alone
HEAVY = ("torch", "prefect", "pydantic", "pvlib", "sklearn", "matplotlib", "highspy", "fmpy")


def test_run_loads_no_extra(tmp_path):
    """``districtgen run`` builds every wing's parser and runs the example without importing an extra."""
    probe = ("import sys\nfrom pipeline.cli import main\nstatus = main(['run', '--policy', 'zero'])\n"
             f"print(status, sorted(m for m in {HEAVY!r} if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "0 []"


@pytest.mark.parametrize(("argv", "module"), [
    (["run"], "pipeline.commands"),
    (["build"], "pipeline.builder.commands"),
    (["verify", "d"], "pipeline.builder.commands"),
    (["paper", "s.json", "-o", "p"], "pipeline.paper.commands"),
    (["optimal", "s.json"], "pipeline.optimal.commands"),
    (["select", "m.csv", "-o", "c.csv"], "pipeline.select"),
    (["weather", "w.epw", "--start", "2018-06-01", "--end", "2018-06-02", "-o", "w.csv"], "pipeline.ingest.commands"),
    (["surrogate", "train", "t.csv", "-o", "m"], "surrogates.cli"),
    (["surrogate", "evaluate", "m.pth", "t.csv"], "surrogates.cli"),
    (["surrogate", "install", "d", "Building_1", "m.pth"], "pipeline.builder.commands"),
])
def test_each_command_is_handled_by_its_wing(argv, module):
    args = build_parser().parse_args(argv)
    assert args.func.__module__ == module


def test_the_surrogate_commands_take_the_district_handlers_from_the_caller(capsys):
    """Registered alone (no pipeline handed in), ``surrogate install`` and ``evaluate --judge`` say they need
    the pipeline; ``districtgen`` hands them the builder's."""
    parser = argparse.ArgumentParser(prog="districtgen")
    surrogate_commands.register(parser.add_subparsers(dest="command", required=True))
    for argv, option in ((["surrogate", "install", "d", "Building_1", "m.pth"], "install"),
                         (["surrogate", "evaluate", "m.pth", "--judge", "district.toml"], "--judge")):
        args = parser.parse_args(argv)
        with pytest.raises(InputError, match="needs the district pipeline") as error:
            args.func(args)
        assert error.value.column == option
    judged = build_parser().parse_args(["surrogate", "evaluate", "m.pth", "--judge", "district.toml"])
    assert judged.judge_handler.__module__ == "pipeline.builder.commands"
