"""Orchestration a busy machine cannot break, the surrogate cache key, and build progress."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import threading
import time
from datetime import date
from pathlib import Path

import pytest

from pipeline import progress
from pipeline.builder.cache import cache_key
from pipeline.builder.driver import run_build
from pipeline.builder.houses import simulation_cache_parts
from pipeline.builder.surrogates import csv_ilv_path, surrogate_cache_parts
from pipeline.config import read_build_config
from tests.pipeline.builder.test_build import _short_config

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def short_toml(tmp_path):
    path = _short_config(tmp_path)
    yield path
    path.unlink(missing_ok=True)


def _cli(args: list[str], tmp_path: Path, **env: str) -> subprocess.Popen:
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_HOME": str(tmp_path / "prefect"), **env}
    environment.pop("PREFECT_API_URL", None)
    return subprocess.Popen([sys.executable, "-m", "pipeline.cli", *args], cwd=ROOT, env=environment,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (Linux /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                out.append(int(entry.name))
    return out


def _cmdline(pid: int) -> str:
    try:
        return (Path("/proc") / str(pid) / "cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _assert_ok_or_one_line(status: int, stdout: str, stderr: str, folder: Path) -> None:
    """The build either succeeded (exit 0, the district is there) or ended in one line, exit 2."""
    assert "Traceback" not in stderr and "Traceback" not in stdout
    if status == 0:
        assert (folder / "schema.json").is_file()
    else:
        lines = [line for line in stderr.splitlines() if line.strip()]
        assert status == 2 and len(lines) == 1 and lines[0].startswith("districtgen: error:"), (status, stderr)


def test_a_tiny_prefect_startup_timeout_is_one_line_and_exit_2(short_toml, tmp_path):
    """The temporary API server cannot answer within 0.01 s: one line naming the way out, exit 2, no server
    process left behind."""
    proc = _cli(["build", str(short_toml), "-o", str(tmp_path / "out"), "--quiet"], tmp_path,
                DISTRICTGEN_PREFECT_STARTUP_TIMEOUT="0.01")
    stdout, stderr = proc.communicate(timeout=600)
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert proc.returncode == 2 and len(lines) == 1, stderr
    assert "did not answer within 0 s" in lines[0] and "--no-prefect" in lines[0]
    assert stdout == "" and not (tmp_path / "out" / "default").exists()
    assert not [p for p in _children(proc.pid)]   # reaped: nothing of the build is left


@pytest.mark.slow  # the server is held stopped for 25 s, then the build runs
def test_a_prefect_server_stopped_for_longer_than_prefects_timeout_does_not_fail_the_build(short_toml, tmp_path):
    """SIGSTOP the build's temporary Prefect server as soon as it exists, for 25 s (Prefect's own startup
    wait gives up after 20 s): the build waits it out and succeeds, or ends in one clear line."""
    proc = _cli(["build", str(short_toml), "-o", str(tmp_path / "out"), "--quiet"], tmp_path)
    stopped: list[int] = []

    def stop_server() -> None:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None and not stopped:
            for child in _children(proc.pid):
                if "uvicorn" in _cmdline(child):
                    os.kill(child, signal.SIGSTOP)
                    stopped.append(child)
                    time.sleep(25.0)
                    os.kill(child, signal.SIGCONT)
                    return
            time.sleep(0.05)

    holder = threading.Thread(target=stop_server)
    holder.start()
    stdout, stderr = proc.communicate(timeout=900)
    holder.join()
    assert stopped, "the server process was never seen"
    _assert_ok_or_one_line(proc.returncode, stdout, stderr, tmp_path / "out" / "default")
    assert proc.returncode == 0, stderr


def test_a_failing_task_in_the_prefect_flow_is_one_line_exit_2(tmp_path):
    """A building id that is not in the data fails inside a Prefect task: one line naming it, exit 2."""
    path = _short_config(tmp_path)
    try:
        path.write_text(path.read_text().replace("buildings = [900001, 900002]", "buildings = [900001, 4242]"))
        assert "4242" in path.read_text()
        proc = _cli(["build", str(path), "-o", str(tmp_path / "out")], tmp_path)
        stdout, stderr = proc.communicate(timeout=900)
    finally:
        path.unlink(missing_ok=True)
    lines = [line for line in stderr.splitlines() if line.strip() and not line.startswith("districtgen: [")]
    assert proc.returncode == 2 and len(lines) == 1 and "4242" in lines[0], stderr
    assert "Traceback" not in stderr and not (tmp_path / "out" / "default").exists()


def test_surrogate_and_simulation_keys_cover_only_what_they_use(short_toml):
    """The period's days within its season, the battery, the PV, the sizing and the name do not change a
    surrogate's or a house simulation's cache key; the epochs, the seed, the ILV data and the season the
    model trains on (the period's months and one either side) change the surrogate's; the simulation
    covers the whole months of the period and the season, so the season changes it too."""
    config = read_build_config(short_toml)
    config = config.model_copy(update={"surrogate": config.surrogate.model_copy(update={"source": "csv"})})
    ilv = csv_ilv_path(config, 900001)

    def surrogate_key(c, table=None):
        return cache_key(surrogate_cache_parts(c, 900001, "Building_1", table)[0])

    def edit(c, **sections):
        return c.model_copy(update={k: getattr(c, k).model_copy(update=v) if isinstance(v, dict) else v
                                    for k, v in sections.items()})

    base = surrogate_key(config)
    assert config.period.start.month == config.period.end.month == 6
    unrelated = [edit(config, period={"start": date(2018, 6, 10), "end": date(2018, 6, 20)}),
                 edit(config, sizing={"battery": "Tesla Powerwall 2", "pv_zne_fraction": 0.5}),
                 edit(config, pv={"tilt": 10.0}), edit(config, name="another", seed=7)]
    assert [surrogate_key(c) for c in unrelated] == [base] * len(unrelated)
    assert surrogate_key(edit(config, surrogate={"epochs": config.surrogate.epochs + 1})) != base
    assert surrogate_key(edit(config, surrogate={"seed": config.surrogate.seed + 1})) != base
    seasons = [edit(config, period={"start": date(2018, 7, 1), "end": date(2018, 7, 3)}),   # July
               edit(config, period={"start": date(2018, 1, 1), "end": date(2018, 12, 31)}),  # every month
               edit(config, surrogate={"season_margin": 2})]                                # April-August
    assert len({base, *(surrogate_key(c) for c in seasons)}) == 4
    from surrogates.ilv import read_ilv

    table = read_ilv(ilv)
    assert surrogate_key(config, table) == base                   # the same table, given instead of read
    changed = table.copy()
    changed.loc[changed.index[5], "indoor_dry_bulb_temperature"] += 0.01
    assert surrogate_key(config, changed) != base

    row = {"bldg_id": 1, "in.sqft": 1900}
    sim = cache_key(simulation_cache_parts(config, row))
    for other in unrelated:
        assert cache_key(simulation_cache_parts(other, row)) == sim
    assert len({sim, *(cache_key(simulation_cache_parts(c, row)) for c in seasons)}) == 4  # other months
    next_year = edit(config, period={"start": date(2019, 6, 1), "end": date(2019, 6, 3)})
    assert cache_key(simulation_cache_parts(next_year, row)) != sim    # another calendar year
    assert cache_key(simulation_cache_parts(edit(config, simulation={"partial_runs": 2}), row)) != sim
    assert cache_key(simulation_cache_parts(edit(config, timezone="America/Denver"), row)) != sim  # the clock


def test_log_reporter_writes_a_few_plain_lines():
    stream = io.StringIO()
    reporter = progress.make_reporter("auto", stream)     # a StringIO is not a terminal: plain lines
    assert isinstance(reporter, progress.LogReporter)
    with progress.active(reporter):
        progress.stage("surrogate", 2)
        callback = progress.epochs("Building_1")
        for epoch in range(1, 61):
            callback(epoch, 60)
        progress.advance("surrogate", "Building_1")
        progress.end("surrogate")
    lines = stream.getvalue().splitlines()
    # epochs 1, 15, 30, 45, 60 of 60 (each quarter), plus start, one building done, end
    assert [line.split("] ", 1)[1] for line in lines] == [
        "surrogates: train: started (2 buildings)", "Building_1: train 1/60", "Building_1: train 15/60",
        "Building_1: train 30/60", "Building_1: train 45/60", "Building_1: train 60/60",
        "surrogates: train: Building_1 done (1/2)", "surrogates: train: finished"]
    assert type(progress.current()) is progress.Reporter            # inactive again after the block
    assert type(progress.make_reporter("quiet", stream)) is progress.Reporter


def test_rich_reporter_draws_stage_and_building_bars():
    from rich.console import Console

    stream = io.StringIO()
    reporter = progress.RichReporter(Console(file=stream, force_terminal=True, width=100))
    with progress.active(reporter):
        progress.stage("house", 1)
        progress.report("Building_1", "train", 30, 60)
        progress.advance("house", "Building_1")
    text = stream.getvalue()
    assert "houses: simulate + train" in text and "Building_1" in text and "1/1" in text


def test_in_process_runner_reports_each_building_and_quiet_build_prints_nothing(short_toml, tmp_path, capsys):
    from pipeline.cli import main

    assert main(["build", str(short_toml), "-o", str(tmp_path / "out"), "--no-prefect", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    stream = io.StringIO()
    with progress.active(progress.LogReporter(stream)):
        run_build(read_build_config(short_toml), tmp_path / "logged")
    text = stream.getvalue()
    for line in ("buildings: ingest: Building_1 done (1/2)", "buildings: ingest: Building_2 done (2/2)",
                 "validate: no control + RBC: finished", "site signals (weather, PV, prices, carbon): finished"):
        assert line in text, text
