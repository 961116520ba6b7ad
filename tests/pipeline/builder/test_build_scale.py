"""Builds at scale: real ResStock houses on a 2-process local Dask cluster give the in-process district."""

from __future__ import annotations

import importlib.util
import shutil
from datetime import date
from pathlib import Path

import pytest

from pipeline.builder.driver import build_district_local
from pipeline.builder.manifest import district_digest
from pipeline.config import read_build_config

ROOT = Path(__file__).resolve().parents[3]


def _benchmark():
    """benchmarks/build_scale.py (the N-house configuration the benchmark builds), loaded as a module."""
    spec = importlib.util.spec_from_file_location("build_scale", ROOT / "benchmarks" / "build_scale.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow  # 2 EnergyPlus passes of June and 2 short trainings, twice the training
def test_two_houses_on_a_two_process_dask_cluster_match_the_in_process_build(tmp_path):
    from surrogates.energyplus.engine import find_energyplus

    try:
        find_energyplus()
    except Exception as error:  # noqa: BLE001 - any reason the engine is missing
        pytest.skip(f"EnergyPlus is not installed ({error}): the houses cannot be simulated")
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    from pipeline.flows import build_district_on_dask

    scale = _benchmark()
    data = scale.scale_config(2, date(2018, 6, 1), date(2018, 6, 3))
    data["surrogate"]["epochs"] = 2       # the surrogates are real but short: this checks plumbing and equality
    toml = tmp_path / "scale2.toml"
    toml.write_text(scale.dump_toml(data))
    config = read_build_config(toml)
    assert config.inputs.buildings == [4, 8]   # the first two occupied hot-humid single-family dwellings

    dask_config = config.model_copy(update={"cache_dir": tmp_path / "cache_dask"})
    with temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}):
        on_dask = build_district_on_dask(dask_config, str(tmp_path / "dask"), workers=2)
    # the in-process build trains again (its own surrogate cache) on the same simulations (EnergyPlus is
    # deterministic; the benchmark compares cold simulations too)
    shutil.copytree(tmp_path / "cache_dask" / "simulations", tmp_path / "cache_local" / "simulations")
    local_config = config.model_copy(update={"cache_dir": tmp_path / "cache_local"})
    local = build_district_local(local_config, tmp_path / "local")

    for name in ("schema.json", "Building_1.csv", "Building_2.csv", "Building_1.pth", "Building_2.pth",
                 "buildings.json", "report/summary.md"):
        assert (on_dask / name).read_bytes() == (local / name).read_bytes(), name
    # manifest.json records the cache folder: equal once both builds name the same one
    assert sorted(p.relative_to(on_dask) for p in on_dask.rglob("*")) == sorted(
        p.relative_to(local) for p in local.rglob("*"))
    rebuilt = build_district_local(dask_config, tmp_path / "again")   # every result from the cache
    assert district_digest(rebuilt) == district_digest(on_dask)
