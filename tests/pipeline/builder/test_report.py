"""The build report: every figure as a PNG of its size, the tables of summary.md, byte-identical reruns."""

from __future__ import annotations

import json
import re
import shutil
import struct
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.builder.driver import build_district_local
from pipeline.builder.install import revalidate
from pipeline.builder.report import (
    SelectionSummary,
    district_report,
    objectives_table,
    rule_misfits,
    selection_section,
    write_report,
)
from pipeline.builder.report_figures import day_hour_matrix, parse_calendar, peak_week, price_bands, runs
from pipeline.builder.validate import validate_district
from pipeline.config import read_build_config

ROOT = Path(__file__).resolve().parents[3]
FIXTURE = ROOT / "tests" / "fixtures" / "synthetic_district" / "district.toml"
BUILDINGS = ("Building_1", "Building_2")
#: file -> (width, height) in pixels: the figure sizes the report promises (11 in wide at 100 dpi)
FIGURES = {"district_net.png": (1100, 800), "district_heatmap.png": (1100, 800),
           **{f"load_{b}.png": (1100, 700) for b in BUILDINGS},
           **{f"temperature_{b}.png": (1100, 600) for b in BUILDINGS}}


def _fixture_config(tmp: Path, end: date, **surrogate):
    """The synthetic fixture district (two EULP houses, Tampa weather) from 1 June to ``end``."""
    config = read_build_config(FIXTURE)
    return config.model_copy(update={
        "period": config.period.model_copy(update={"end": end}),
        "surrogate": config.surrogate.model_copy(update={"source": "none", **surrogate}),
        "cache_dir": tmp / "cache"})


@pytest.fixture(scope="module")
def small_build(tmp_path_factory) -> Path:
    """Nine June days of the fixture district, no surrogates (a build of a few seconds)."""
    tmp = tmp_path_factory.mktemp("report")
    return build_district_local(_fixture_config(tmp, date(2018, 6, 9)), tmp / "out")


def _png_size(path: Path) -> tuple[int, int]:
    """Width and height from the PNG signature and IHDR chunk (PNG spec: 8-byte signature, then IHDR)."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR", path.name
    return struct.unpack(">II", head[16:24])


def _chunks(path: Path) -> list[bytes]:
    """The chunk types of a PNG file, in order."""
    data, out, at = path.read_bytes(), [], 8
    while at < len(data):
        (length,) = struct.unpack(">I", data[at:at + 4])
        out.append(data[at + 4:at + 8])
        at += 12 + length
    return out


def _table(summary: str, heading: str) -> list[list[str]]:
    """The body rows of the markdown table under ``## heading`` (cells stripped)."""
    section = summary.split(f"## {heading}", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("|")]
    return [[cell.strip() for cell in row.strip("|").split("|")] for row in rows[2:]]


def test_every_figure_is_a_png_of_its_size_linked_from_the_summary(small_build):
    report = small_build / "report"
    summary = (report / "summary.md").read_text()
    linked = re.findall(r"!\[[^\]]+\]\(([^)]+)\)", summary)
    assert sorted(linked) == sorted(FIGURES)
    for name, size in FIGURES.items():
        assert _png_size(report / name) == size, name
        chunks = _chunks(report / name)
        assert chunks[-1] == b"IEND" and b"tIME" not in chunks, name   # complete, no modification date
        assert b"Software" not in (report / name).read_bytes(), name
    from PIL import Image

    with Image.open(report / "load_Building_1.png") as image:
        pixels = np.asarray(image.convert("RGB")).astype(np.int64)
    assert np.unique(pixels @ np.array([65536, 256, 1])).size > 50   # drawn, not blank


def test_summary_tables_name_every_building_with_its_devices(small_build):
    summary = (small_build / "report" / "summary.md").read_text()
    schema = json.loads((small_build / "schema.json").read_text())
    devices = _table(summary, "Devices")
    assert [row[0] for row in devices] == list(BUILDINGS)
    for row in devices:
        spec = schema["buildings"][row[0]]
        assert float(row[1]) == pytest.approx(spec["cooling_device"]["attributes"]["nominal_power"], abs=0.005)
        assert row[5] == "4.0 / 3.32"                                 # BYD LVS 4.0: 4 kWh, 3.32 kW
    assert [row[0] for row in _table(summary, "Objectives per building")] == list(BUILDINGS)
    assert "## Surrogates" not in summary                             # built without surrogates
    assert "timing" not in summary.lower() and not re.search(r"\b\d+(\.\d+)? ?s\b", summary)


def test_summary_kpis_are_the_csv_values(small_build):
    report = small_build / "report"
    summary = (report / "summary.md").read_text()
    rows = {row[0]: row for row in _table(summary, "KPIs")}
    for column, policy in ((2, "no_control"), (3, "cost_rbc")):
        csv = pd.read_csv(report / f"kpis_{policy}.csv")
        district = csv[csv["level"] == "district"].set_index("cost_function")["value"]
        assert set(district.index) == set(rows)
        for kpi, value in district.items():
            cell = rows[kpi][column]
            if np.isnan(value):
                assert cell == "n/a", kpi
            else:
                assert float(cell) == pytest.approx(value, abs=5e-5), kpi
    assert float(rows["cost_total"][2]) == 1.0                        # no control is its own baseline


def test_no_control_objectives_by_hand_from_the_emitted_files(small_build):
    """No control: net = non-shiftable + cooling / Carnot COP + DHW / heater efficiency - PV, each device
    delivering at most P * COP; consumption = sum of max(net, 0), cost = sum of max(net, 0) * price."""
    schema = json.loads((small_build / "schema.json").read_text())
    weather = pd.read_csv(small_build / "weather.csv")
    price = pd.read_csv(small_build / "pricing.csv")["electricity_pricing"].to_numpy()
    consumption = cost = 0.0
    for name in BUILDINGS:
        spec, data = schema["buildings"][name], pd.read_csv(small_build / f"{name}.csv")
        hp, heater = spec["cooling_device"]["attributes"], spec["dhw_device"]["attributes"]
        target = hp["target_cooling_temperature"]
        cop = hp["efficiency"] * (target + 273.15) / (weather["outdoor_dry_bulb_temperature"].to_numpy() - target)
        cop = np.where((cop < 0) | (cop > 20), 20.0, cop)
        cooling = np.minimum(data["cooling_demand"], hp["nominal_power"] * cop) / cop
        dhw = np.minimum(data["dhw_demand"], heater["nominal_power"] * heater["efficiency"]) / heater["efficiency"]
        assert data["heating_demand"].sum() == 0.0                    # June in Tampa
        pv = spec["pv"]["attributes"]["nominal_power"] * data["solar_generation"].to_numpy() / 1000.0
        grid = np.maximum(data["non_shiftable_load"].to_numpy() + cooling + dhw - pv, 0.0)
        consumption += grid.sum()
        cost += (grid * price).sum()
    summary = (small_build / "report" / "summary.md").read_text()
    objectives = {row[0]: row for row in _table(summary, "Objectives over the period")}
    assert objectives["consumption"][1] == "kWh" and objectives["cost"][1] == "$"
    assert float(objectives["consumption"][2]) == pytest.approx(consumption, abs=0.05)
    assert float(objectives["cost"][2]) == pytest.approx(cost, abs=0.005)


def test_a_second_report_has_the_same_bytes(small_build, tmp_path):
    """The report rewritten from what the district holds (what ``surrogate install`` does) is the build's,
    byte for byte, its Buildings section included (written once, not appended)."""
    schema = json.loads((small_build / "schema.json").read_text())
    validation = validate_district(small_build / "schema.json")
    write_report(tmp_path, district_report(small_build, small_build.name, schema, validation, None))
    first = small_build / "report"
    written = sorted(p.name for p in tmp_path.iterdir())
    assert sorted(p.name for p in first.iterdir()) == written
    assert set(FIGURES) | {"summary.md", "kpis_no_control.csv", "kpis_cost_rbc.csv"} <= set(written)
    for name in written:
        assert (tmp_path / name).read_bytes() == (first / name).read_bytes(), name
    summary = (first / "summary.md").read_text()
    assert summary.count("## Buildings") == 1 and summary.index("## Figures") < summary.index("## Buildings")
    assert "## Selection" not in summary                              # the fixture lists its buildings


def test_the_selection_section_from_its_record():
    """A selection's k and validity rows, through the manifest's JSON and back, as pipeline.select prints
    them (NaN where an index is undefined)."""
    record = SelectionSummary(3, ({"k": 2, "sse": 9.5, "calinski_harabasz": 4.0, "silhouette": float("nan"),
                                   "davies_bouldin": 1.25},
                                  {"k": 3, "sse": 4.729, "calinski_harabasz": 4.84321, "silhouette": 0.2189,
                                   "davies_bouldin": 1.0211}))
    again = SelectionSummary.from_json(json.loads(json.dumps(record.to_json())))
    lines = selection_section(again)
    assert lines[:3] == ["", "## Selection (k = 3, one building per k-means cluster)", ""]
    assert lines[3] == lines[5] == "```" and len(lines) == 6
    table = [row.split() for row in lines[4].split("\n")]
    assert table == [["k", "SSE", "Calinski-H", "silhouette", "Davies-B"],
                     ["2", "9.5000", "4.0000", "nan", "1.2500"], ["3*", "4.7290", "4.8432", "0.2189", "1.0211"]]
    assert selection_section(SelectionSummary(6))[-1] == "Validity indices: not recorded by the build."


def test_calendar_days_heat_map_and_peak_week_by_hand():
    # a period starting at 22:00 (hours ending 23, 24): a two-hour first day, then 2 whole days and 1 hour
    hour = np.array([23, 24, *range(1, 25), *range(1, 25), 1])
    steps = hour.size                                                  # 51
    calendar = parse_calendar(hour, np.full(steps, 6), np.array([1] * 2 + [2] * 24 + [3] * 24 + [4]))
    assert calendar.days == 4 and calendar.first.tolist() == [0, 2, 26, 50]
    assert calendar.day_type.tolist() == [1, 2, 3, 4]
    matrix = day_hour_matrix(np.arange(steps, dtype=float), calendar)
    assert matrix.shape == (24, 4) and matrix[22, 0] == 0 and matrix[23, 0] == 1 and matrix[0, 1] == 2
    assert np.isnan(matrix[0, 0]) and matrix[0, 3] == 50 and np.isnan(matrix[1, 3])
    net = np.zeros(steps)
    net[30] = 5.0                                                      # peak on day 2 (steps 26..49)
    assert peak_week(net, calendar, days=2) == slice(2, 50)           # days 1-2: the peak day second
    assert peak_week(net, calendar, days=7) == slice(0, steps)        # longer than the period: all of it


def test_tariff_levels_and_runs():
    levels, labels = price_bands(np.array([0.03, 0.03, 0.06, 0.06, 0.03]))
    assert levels.tolist() == [0, 0, 1, 1, 0] and labels == ["0.03 $/kWh", "0.06 $/kWh"]
    assert runs(levels) == [(0, 2, 0), (2, 4, 1), (4, 5, 0)]
    levels, labels = price_bands(np.linspace(0.01, 0.10, 10))       # real-time: five quantile bands
    assert len(labels) == 5 and levels.tolist() == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4]


@pytest.mark.slow  # ~1-2 min: trains two tiny surrogates on a year of ILV data
def test_surrogate_table_has_each_building_fit(tmp_path):
    folder = build_district_local(_fixture_config(tmp_path, date(2018, 6, 3), source="csv", epochs=1,
                                                        max_seconds=3.0), tmp_path / "out")
    rows = _table((folder / "report" / "summary.md").read_text(), "Surrogates")
    assert [row[0] for row in rows] == list(BUILDINGS)
    for row in rows:
        fit = json.loads((folder / "surrogates" / f"{row[0]}.metrics.json").read_text())["test"]
        median, worst = (float(v) for v in row[1].split(" / "))
        assert median == pytest.approx(fit["monthly_rmse_c"]["median"], abs=0.005)
        assert worst == pytest.approx(fit["monthly_rmse_c"]["max"], abs=0.005)
        assert int(row[4]) == fit["hours"]
        assert row[6].endswith("(months 6)")  # a June district's models train on June


def test_a_rule_that_raises_its_own_objective_is_named_once():
    objectives = {"no_control": {"cost": 100.0, "emissions": 50.0, "discomfort": 0.0, "consumption": 900.0,
                                 "average_daily_peak": 10.0},
                  "cost_rbc": {"cost": 102.0, "emissions": 49.0, "discomfort": 0.0, "consumption": 950.0,
                               "average_daily_peak": 9.0}}
    lines = objectives_table(objectives)
    notes = [line for line in lines if line.startswith("Note:")]
    # 102 against 100 $: +2.0 %; the emissions it lowers and the consumption it raises are not its objective
    assert len(notes) == 1 and "cost RBC raises cost by +2.0 %" in notes[0]
    objectives["cost_rbc"]["cost"] = 99.0
    assert rule_misfits(objectives) == []


def test_install_rewrites_the_report_as_the_build_wrote_it(small_build, tmp_path):
    """``surrogate install``'s rewrite (install.revalidate): every report file anew from what the district holds,
    the selection from the manifest's record (the default district's, rendered as its baseline build printed
    it), or, for a district built before the manifest held it, the k of selection.csv; nothing of the old
    summary is kept."""
    district = tmp_path / small_build.name
    shutil.copytree(small_build, district)
    (district / "report" / "summary.md").write_text("# stale\n\n## Buildings\n\nold rows\n")
    schema = json.loads((district / "schema.json").read_text())
    record = {"k": 6, "validity": [{"k": 6, "sse": 4.729027996008899, "calinski_harabasz": 4.843162756110561,
                                    "silhouette": 0.218913619305749, "davies_bouldin": 1.0210800613239492}]}
    revalidate(district, small_build.name, schema, {"selection": record})
    built = (small_build / "report" / "summary.md").read_text()
    selection = ("\n## Selection (k = 6, one building per k-means cluster)\n\n```\n"
                 "   k        SSE  Calinski-H  silhouette  Davies-B\n"
                 "  6*     4.7290      4.8432      0.2189    1.0211\n```\n")
    assert (district / "report" / "summary.md").read_text() == built + selection
    for path in (small_build / "report").iterdir():
        if path.name != "summary.md":
            assert (district / "report" / path.name).read_bytes() == path.read_bytes(), path.name

    pd.DataFrame({"bldg_id": [7, 9], "cluster": [0, 1], "k": [2, 2],
                  "building": list(BUILDINGS)}).to_csv(district / "selection.csv", index=False)
    revalidate(district, small_build.name, schema, {})
    assert (district / "report" / "summary.md").read_text() == built + (
        "\n## Selection (k = 2, one building per k-means cluster)\n\nValidity indices: not recorded by the build.\n")
