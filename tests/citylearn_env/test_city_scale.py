"""The environment at city scale (issue 48, item 3): shared storage, lazily paged records, the static rows, the
fast CSV path, and the memory estimate and refusal of ``districtgen run``.

Upstream data: citylearn_challenge_2022_phase_all (CityLearn 2.1.2), read in place or copied into tmp_path.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, dataset, load_schema
from citylearn_env.district import District
from citylearn_env.errors import SchemaError
from citylearn_env.footprint import available_memory, estimate_run_memory, memory_refusal
from citylearn_env.state import BatteryRecord, lazy_zeros

ROOT = Path(__file__).resolve().parents[2]
PHASE_ALL = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2" / "citylearn_challenge_2022_phase_all"
needs_data = pytest.mark.skipif(not PHASE_ALL.is_dir(), reason="upstream data sets not present")
FILE_KEYS = ("energy_simulation", "weather", "pricing", "carbon_intensity")


def _city(folder: Path, n: int, *, copies: bool = False, end: int | None = None) -> Path:
    """phase_all's buildings repeated to ``n`` in ``folder``: all naming upstream's files, or (``copies``) each
    its own byte-identical copy of its building file; ``end``: the simulation_end_time_step."""
    raw = json.loads((PHASE_ALL / "schema.json").read_text())
    names = list(raw["buildings"])
    for spec in raw["buildings"].values():
        for key in FILE_KEYS:
            if not (folder / spec[key]).exists():
                shutil.copyfile(PHASE_ALL / spec[key], folder / spec[key])
    buildings = {}
    for i in range(n):
        spec = json.loads(json.dumps(raw["buildings"][names[i % len(names)]]))
        name = f"{names[i % len(names)]}_c{i // len(names)}"
        if copies:
            shutil.copyfile(folder / spec["energy_simulation"], folder / f"{name}.csv")
            spec["energy_simulation"] = f"{name}.csv"
        buildings[name] = spec
    raw["buildings"] = buildings
    if end is not None:
        raw["simulation_end_time_step"] = end
    (folder / "schema.json").write_text(json.dumps(raw))
    return folder / "schema.json"


# ------------------------------------------------------------------------------ shared storage
@needs_data
@pytest.mark.parametrize("copies", [False, True])
def test_buildings_sharing_a_file_or_its_copy_share_one_array(tmp_path, copies):
    """Two buildings naming one building file (or byte-identical copies of it) hold the same arrays; the
    district stores them as one broadcast row (stride 0), and a column that differs as a (B, N) copy."""
    config = load_schema(_city(tmp_path, 18, copies=copies), settings="citylearn-2.1")
    first, again, other = config.buildings[0], config.buildings[17], config.buildings[1]   # Building_1 twice
    assert first.name == "Building_1_c0" and again.name == "Building_1_c1"
    for name in ("non_shiftable_load", "solar_generation", "month", "outdoor_dry_bulb_temperature"):
        assert again.series[name] is first.series[name]
    assert other.series["non_shiftable_load"] is not first.series["non_shiftable_load"]
    assert other.series["hour"] is first.series["hour"]                       # equal calendars: interned
    district = District(config)
    for name in ("hour", "outdoor_dry_bulb_temperature", "electricity_pricing", "cooling_demand"):
        column = district.signals[name]
        assert column.shape == (18, 8760) and column.strides[0] == 0 and not column.flags.writeable
    load = district.signals["non_shiftable_load"]
    assert load.strides[0] != 0 and not load.flags.writeable
    np.testing.assert_array_equal(load[1], other.series["non_shiftable_load"])
    np.testing.assert_array_equal(load[17], load[0])
    cop = district.end_use_params[0].cop                                         # no device anywhere: one row
    assert cop.shape == (18, 8760) and cop.strides[0] == 0


@needs_data
def test_a_shared_column_reads_as_upstreams_file(tmp_path):
    """The broadcast weather column of every building is the upstream weather file's column, float32-rounded."""
    config = load_schema(_city(tmp_path, 3), settings="citylearn-2.1")
    text = np.genfromtxt(PHASE_ALL / "weather.csv", delimiter=",", skip_header=1)[:, 0]
    column = District(config).signals["outdoor_dry_bulb_temperature"]
    for b in range(3):
        np.testing.assert_array_equal(column[b], text.astype(np.float32).astype(np.float64))


# ------------------------------------------------------------------------------ records
def _rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc/self/status (Linux)")
def test_writing_one_column_of_a_large_record_takes_pages_not_the_record():
    """4 x (1,000, 8,760) float64 = 280 MB of zeros: writing column 0 of each (one value per building, as a
    step does) makes about 4 x 1,000 pages resident (16 MB), not the whole block (huge pages would: 280 MB)."""
    block = lazy_zeros(4, 1000, 8760)
    before = _rss_kib()
    block[:, :, 0] = 1.0
    grown_mb = (_rss_kib() - before) / 1024
    assert grown_mb < 60, grown_mb
    assert block.sum() == 4000.0 and block[:, :, 1:].max() == 0.0
    record = BatteryRecord.zeros(1000, 8760)
    record.soc[:, 5] = 0.5
    assert record.soc.shape == (1000, 8760) and record.soc.flags.writeable and record.capacity.sum() == 0.0


# ------------------------------------------------------------------------------ static rows
@needs_data
def test_static_rows_are_the_episode_series_at_each_step(tmp_path):
    """Row t of the static observations holds, at every (name, building) position, that building's series at
    t (the definition of the former (T, pairs) matrix), for shared and per-building series alike."""
    env = CityLearnEnv(_city(tmp_path, 20), compat=True)
    env.reset(seed=0)
    layout, d = env.layout, env.district
    rows = layout.episode_matrix()
    assert len(rows) == 8760
    for t in (0, 1, 127, 128, 4000, 8759):
        row = rows[t]
        for name, (pos, bidx) in layout.groups.items():
            expected = 0.0 if name in obs_dynamic() else d.static_series(name)[bidx, t]
            np.testing.assert_array_equal(row[pos], expected)
    with pytest.raises(IndexError):
        rows[8760]


def obs_dynamic() -> tuple[str, ...]:
    from citylearn_env.state import DYNAMIC

    return DYNAMIC


# ------------------------------------------------------------------------------ reading
@needs_data
def test_numeric_and_text_reading_agree_on_upstream_files():
    """The fast path (pandas typing numeric columns) and the all-strings path give bit-identical arrays."""
    for name, kind in (("Building_1.csv", "building"), ("Building_5.csv", "building"), ("weather.csv", "weather"),
                       ("pricing.csv", "pricing"), ("carbon_intensity.csv", "carbon")):
        path = PHASE_ALL / name
        fast = dataset.read_table(path, kind)
        text = dataset.parse_table(dataset.read_frame(path), kind, path, None)
        assert fast.keys() == text.keys()
        for column in fast:
            assert fast[column].tobytes() == text[column].tobytes(), (name, column)


@pytest.mark.parametrize(("cell", "message"), [("", "not a number: ''"), ("True", "not a number: 'True'"),
                                               ("abc", "not a number: 'abc'"), ("nan", "missing value (NaN)")])
def test_a_bad_cell_names_file_column_and_row_on_the_fast_path(tmp_path, cell, message):
    names = list(dataset.PRICING_COLUMNS)
    rows = [["0.2"] * 4 for _ in range(5)]
    rows[3][2] = cell
    path = tmp_path / "pricing.csv"
    path.write_text(",".join(names) + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(SchemaError) as caught:
        dataset.read_table(path, "pricing")
    text = str(caught.value)
    assert message in text and "pricing.csv" in text and names[2] in text and "3 (file line 5)" in text


def test_a_boolean_column_is_refused_with_its_first_cell(tmp_path):
    """pandas would read True/False as booleans; the reader falls back to text and names the first one."""
    path = tmp_path / "carbon.csv"
    path.write_text("carbon_intensity\nTrue\nFalse\n")
    with pytest.raises(SchemaError, match=r"not a number: 'True'.*row 0 \(file line 2\)|row 0 \(file line 2\).*"
                                          r"not a number: 'True'"):
        dataset.read_table(path, "carbon")


# ------------------------------------------------------------------------------ memory estimate and refusal
#: runs ``districtgen run`` in this (child) process, then prints its own peak resident memory [bytes]
_RUN_AND_MEASURE = ("import sys\nfrom citylearn_env.footprint import peak_resident_memory\nfrom pipeline.cli import main\n"
                    "code = main(sys.argv[1:])\nprint('peak', peak_resident_memory())\nsys.exit(code)")


def _peak_rss_mb_of_run(schema: Path) -> float:
    """Peak resident memory [MB] of ``districtgen run --schema SCHEMA --policy random`` in a fresh process, read
    by the process itself (``VmHWM``: a forked child's ``ru_maxrss`` would start at this test process's)."""
    out = subprocess.run([sys.executable, "-c", _RUN_AND_MEASURE, "run", "--schema", str(schema), "--policy",
                          "random"], capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)},
                         timeout=600)
    assert out.returncode == 0, out.stderr
    return int(out.stdout.strip().splitlines()[-1].split()[1]) / 2**20


@needs_data
@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="peak memory from /proc/self/status (Linux)")
def test_the_run_memory_estimate_is_within_a_factor_of_two_of_the_measured(tmp_path):
    """``districtgen run`` on 17 and on 200 buildings x 2,000 steps, each in its own process: the estimate is
    within a factor of 2 of the peak resident memory, and so is its growth from 17 to 200 buildings (the
    per-building part, not only the interpreter's)."""
    small, large = tmp_path / "small", tmp_path / "large"
    small.mkdir()
    large.mkdir()
    schemas = (_city(small, 17, end=1999), _city(large, 200, end=1999))
    measured = [_peak_rss_mb_of_run(s) for s in schemas]
    estimated = [estimate_run_memory(s) / 2**20 for s in schemas]
    for m, e in zip(measured, estimated, strict=True):
        assert m / 2 <= e <= 2 * m, (measured, estimated)
    growth_measured, growth_estimated = measured[1] - measured[0], estimated[1] - estimated[0]
    assert growth_measured / 2 <= growth_estimated <= 2 * growth_measured, (measured, estimated)


def _ten_thousand(tmp_path: Path) -> Path:
    raw = json.loads((PHASE_ALL / "schema.json").read_text()) if PHASE_ALL.is_dir() else {
        "simulation_start_time_step": 0, "simulation_end_time_step": 8759, "buildings": {"Building_1": {}}}
    spec = next(iter(raw["buildings"].values()))
    raw["buildings"] = {f"Building_{i}": spec for i in range(10_000)}
    path = tmp_path / "schema.json"
    path.write_text(json.dumps(raw))
    return path


def test_ten_thousand_buildings_are_refused_in_one_line_naming_estimate_available_and_remedy(tmp_path):
    schema = _ten_thousand(tmp_path)
    needed = estimate_run_memory(schema)
    assert 30 * 2**30 < needed < 40 * 2**30          # 10,000 x 8,760 x 400 bytes + base: about 33 GiB
    line = memory_refusal(schema, available=16 * 2**30)
    assert line is not None and "\n" not in line
    assert f"need about {needed / 2**30:.1f} GiB" in line and "16.0 GiB are available" in line
    assert "10000 buildings x 8760 time steps" in line and "run fewer buildings" in line
    assert memory_refusal(schema, available=needed + 1) is None


@pytest.mark.skipif((available_memory() or 0) > 32 * 2**30, reason="this machine has room for 10,000 buildings")
def test_districtgen_run_refuses_ten_thousand_buildings_before_loading(tmp_path):
    """The command exits 2 with one line (no data file is read: the refusal comes first)."""
    schema = _ten_thousand(tmp_path)
    out = subprocess.run([sys.executable, "-m", "pipeline.cli", "run", "--schema", str(schema)], capture_output=True,
                         text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    lines = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(lines) == 1, out.stderr
    assert "10000 buildings x 8760 time steps need about" in lines[0] and "GiB are available" in lines[0]
    assert "schema.json" in lines[0] and "run fewer buildings" in lines[0]
