"""The committed default inputs under raw/: real files, recorded sha256, documented, and the default district's
configuration (no engine runs)."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import pandas as pd
import pytest

from pipeline.config import read_build_config
from tools.make_raw import REAL_INPUTS, copy_real_inputs, main

ROOT = Path(__file__).resolve().parents[2]
RAW = ROOT / "raw"
SHARED = ROOT.parent / "shared" / "data"


def test_raw_holds_exactly_the_real_inputs_with_their_sha256():
    data = {str(p.relative_to(RAW)) for p in RAW.rglob("*") if p.is_file()} - {"README.md", "district.toml"}
    data = {p for p in data if not Path(p).name.startswith(".")}
    assert data == set(REAL_INPUTS) | {"tariffs/austin_energy_tou_2018.toml"}
    readme = (RAW / "README.md").read_text()
    for path, (_, digest) in REAL_INPUTS.items():
        assert hashlib.sha256((RAW / path).read_bytes()).hexdigest() == digest, path
        assert f"`{path}`" in readme and digest in readme
    assert "Tampa" not in " ".join(data) and "synthetic" not in " ".join(data).lower()


def test_the_shared_data_readme_lists_the_same_files_as_embeddable():
    if not SHARED.is_dir():
        pytest.skip("../shared/data is absent (a fresh clone): nothing to compare with")
    table = (SHARED / "README.md").read_text()
    for relative, digest in REAL_INPUTS.values():
        line = next(line for line in table.splitlines() if f"`{Path(relative).name}" in line
                    or f"`{relative}`" in line)
        assert "embeddable" in line
        assert re.search(r"sha256 [0-9a-f]{8}", line) is None or digest[:8] in line


def test_make_raw_copies_unchanged_and_refuses_another_file(tmp_path):
    if not SHARED.is_dir():
        pytest.skip("../shared/data is absent (a fresh clone): nothing to copy from")
    copied = copy_real_inputs(SHARED, tmp_path / "raw", log=lambda message: None)
    for path in REAL_INPUTS:
        assert (tmp_path / "raw" / path).read_bytes() == (RAW / path).read_bytes()
    assert copied == {path: digest for path, (_, digest) in REAL_INPUTS.items()}
    fake = tmp_path / "fake"
    for relative, _ in REAL_INPUTS.values():
        (fake / relative).parent.mkdir(parents=True, exist_ok=True)
        (fake / relative).write_bytes(b"not the published file")
    assert main(["--shared", str(fake), "--raw-dir", str(tmp_path / "other")]) == 2
    assert not (tmp_path / "other").exists() or not any((tmp_path / "other").rglob("*.epw"))


def test_default_district_selects_real_single_family_houses():
    config = read_build_config(RAW / "district.toml")
    assert config.inputs.characteristics.is_file() and config.inputs.eulp is None
    assert config.surrogate.source == "energyplus" and config.selection.clusters in range(6, 9)
    stock = pd.read_parquet(config.inputs.characteristics)
    keep = pd.Series(True, index=stock.index)
    for key, value in config.selection.filters.items():
        keep &= stock[f"build_existing_model.{key}"] == value
    assert keep.sum() >= config.selection.clusters                           # enough houses to pick from
    assert (stock.loc[keep, "build_existing_model.geometry_building_type_recs"] == "Single-Family Detached").all()
    assert (config.period.start.isoformat(), config.period.end.isoformat()) == ("2018-06-01", "2018-06-30")
