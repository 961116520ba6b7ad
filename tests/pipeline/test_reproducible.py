"""Reproducible, shareable builds: two builds of one configuration write the same bytes except timings.json,
and every artifact is world-readable whatever the umask (issue 15, part 5)."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pandas as pd
import pytest

from pipeline.builder.driver import build_district_local
from pipeline.builder.manifest import RECORDS, SIDECAR, TIMINGS, split_metrics_timings
from pipeline.config import read_build_config

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "fixtures" / "synthetic_district"


def short_config_file(folder: Path, *, source: str = "none", ilv: Path | None = None) -> Path:
    """The synthetic fixture district for three days of June 2018, its input paths made absolute, in
    ``folder`` (with ``source = "csv"``: one closed-loop epoch on the ILV tables in ``ilv``)."""
    text = FIXTURE.joinpath("district.toml").read_text().replace("end = 2018-06-30", "end = 2018-06-03")
    for key in ("eulp", "weather", "tariff", "fuel_mix"):
        line = next(x for x in text.splitlines() if x.startswith(f"{key} = "))
        relative = line.split('"')[1]
        text = text.replace(line, f'{key} = "{(FIXTURE / relative).resolve()}"')
    text = text.replace('ilv = "ilv"', f'ilv = "{ilv or FIXTURE / "ilv"}"')
    text = text.replace('source = "csv"', f'source = "{source}"').replace("epochs = 40", "epochs = 1")
    path = folder / "district.toml"
    path.write_text(text)
    return path


def small_ilv_tables(folder: Path) -> Path:
    """The fixture's ILV tables cut to 1-21 June (every reference run, 504 h each): fast to train on."""
    folder.mkdir(parents=True, exist_ok=True)
    for path in sorted((FIXTURE / "ilv").glob("*.parquet")):
        table = pd.read_parquet(path)
        stamp = pd.to_datetime(table["timestamp"])
        keep = (stamp >= "2018-06-01") & (stamp < "2018-06-22")
        table[keep].reset_index(drop=True).to_parquet(folder / path.name, index=False)
    return folder


def read_tree(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder``: relative POSIX path -> bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def with_umask(mask: int, fn, *args):
    old = os.umask(mask)
    try:
        return fn(*args)
    finally:
        os.umask(old)


@pytest.fixture(scope="module")
def two_builds(tmp_path_factory):
    """The same configuration built twice, into two output roots: first under umask 077, then 022."""
    tmp = tmp_path_factory.mktemp("reproducible")
    config = read_build_config(short_config_file(tmp))
    first = with_umask(0o077, build_district_local, config, tmp / "first")
    second = with_umask(0o022, build_district_local, config, tmp / "second")
    return first, second


def test_two_builds_are_byte_identical_except_the_run_records(two_builds):
    first, second = (read_tree(f) for f in two_builds)
    assert TIMINGS in first and TIMINGS in second
    assert sorted(first) == sorted(second)
    differ = [name for name in first if first[name] != second[name]]
    assert differ in ([], [SIDECAR, TIMINGS])  # the run's record and the sidecar that hashes it
    manifest = json.loads(first["manifest.json"])
    assert "timings_s" not in manifest and TIMINGS not in manifest["outputs"]
    assert set(manifest["outputs"]) == set(first) - set(RECORDS)
    # no absolute path of this machine in the reproducible files (paths are relative to the config's folder)
    for name, data in first.items():
        if name != TIMINGS and not name.endswith(".png"):
            assert str(two_builds[0].parent.parent).encode() not in data, name
    assert manifest["config"]["source"] == "district.toml" and "cache_dir" not in manifest["config"]
    assert json.loads(first[TIMINGS])["stages_s"]["validate"] > 0


def test_pngs_carry_no_software_or_date_tag(two_builds):
    for png in two_builds[0].rglob("*.png"):
        head = png.read_bytes()
        assert head.startswith(b"\x89PNG") and b"tEXtSoftware" not in head and b"tIME" not in head, png.name


def test_every_artifact_world_readable_under_umask_077(two_builds):
    first = two_builds[0]
    modes = {p.relative_to(first).as_posix(): stat.S_IMODE(p.stat().st_mode) for p in [first, *first.rglob("*")]}
    folders = {n for n in modes if (first / n).is_dir()}
    assert {"report"} <= folders and any(n.endswith(".csv") for n in modes) and "report/district_net.png" in modes
    assert {n: m for n, m in modes.items() if n in folders and m != 0o755} == {}
    assert {n: m for n, m in modes.items() if n not in folders and m != 0o644} == {}


def test_metrics_seconds_move_out_by_hand():
    metrics = {"building": "B", "training": {"train_seconds": 12.5, "train_cpu_seconds": 11.0, "best_epoch": 1,
                                             "history": [{"epoch": 0, "seconds": 3.0, "val": 0.5},
                                                         {"epoch": 1, "seconds": 6.5, "val": 0.4}]}}
    clean, seconds = split_metrics_timings(metrics)
    assert clean == {"building": "B", "training": {"best_epoch": 1, "history": [{"epoch": 0, "val": 0.5},
                                                                                 {"epoch": 1, "val": 0.4}]}}
    assert seconds == {"train_seconds": 12.5, "train_cpu_seconds": 11.0, "epoch_seconds": [3.0, 6.5]}
    assert metrics["training"]["train_seconds"] == 12.5   # the argument is untouched


@pytest.mark.slow  # two trainings (one epoch each) and two closed-loop validations: about a minute
def test_surrogate_builds_are_byte_identical_with_fresh_caches(tmp_path):
    """Trained twice from scratch (two empty caches): .pth, metrics, plots and report agree byte for byte."""
    path = short_config_file(tmp_path, source="csv", ilv=small_ilv_tables(tmp_path / "ilv"))
    config = read_build_config(path)
    folders = [build_district_local(config.model_copy(update={"cache_dir": tmp_path / f"cache{i}"}),
                                          tmp_path / f"out{i}") for i in (1, 2)]
    first, second = (read_tree(f) for f in folders)
    assert {"Building_1.pth", "surrogates/Building_1.metrics.json", "surrogates/Building_1.png"} <= set(first)
    assert sorted(n for n in first if first[n] != second.get(n)) == [SIDECAR, TIMINGS]
    metrics = json.loads(first["surrogates/Building_1.metrics.json"])
    assert "train_seconds" not in metrics["training"]
    timings = json.loads(first[TIMINGS])
    assert timings["surrogates"]["Building_1"]["hit"] is False
    assert timings["surrogates"]["Building_1"]["train_seconds"] > 0
    manifest = json.loads(first["manifest.json"])
    assert len(manifest["surrogate_cache"]["Building_1"]["key"]) == 64
    assert set(manifest["inputs"]) >= {"weather", "tariff", "fuel_mix", "ilv/900001", "ilv/900002"}


def _busy(seconds: float) -> None:
    """Spin the CPU for ``seconds`` (a process beside the build)."""
    import time

    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pass


@pytest.mark.slow  # two trainings (one epoch each) with `auto` precision, the second beside two busy processes
def test_auto_precision_gives_one_district_on_a_busy_cpu(tmp_path, monkeypatch):
    """``precision = "auto"`` is decided once per machine and recorded (DISTRICTGEN_CACHE_DIR/precision.json):
    a second build from an empty surrogate cache, trained while two processes keep both cores busy (where a
    fresh speed probe could choose otherwise), uses the recorded decision and gives the same district."""
    import multiprocessing

    from pipeline.builder.manifest import district_digest

    monkeypatch.setenv("DISTRICTGEN_CACHE_DIR", str(tmp_path / "machine"))
    path = short_config_file(tmp_path, source="csv", ilv=small_ilv_tables(tmp_path / "ilv"))
    config = read_build_config(path)
    config = config.model_copy(update={"surrogate": config.surrogate.model_copy(update={"precision": "auto"})})
    quiet = build_district_local(config.model_copy(update={"cache_dir": tmp_path / "cache1"}), tmp_path / "out1")
    context = multiprocessing.get_context("spawn")
    burners = [context.Process(target=_busy, args=(600.0,), daemon=True) for _ in range(2)]
    for burner in burners:
        burner.start()
    try:
        busy = build_district_local(config.model_copy(update={"cache_dir": tmp_path / "cache2"}), tmp_path / "out2")
    finally:
        for burner in burners:
            burner.terminate()
    records = [json.loads((folder / TIMINGS).read_text())["precision"] for folder in (quiet, busy)]
    assert records[0]["precision"] == records[1]["precision"]
    assert json.loads((busy / TIMINGS).read_text())["surrogates"]["Building_1"]["hit"] is False  # trained again
    assert district_digest(busy) == district_digest(quiet)
