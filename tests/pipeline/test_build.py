"""The district build: configuration, sizing, rule-based controllers, atomic emission, manifest, flow."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from citylearn_env import CityLearnEnv
from pipeline import build
from pipeline.config import parse_build_config, read_build_config
from pipeline.controllers import cost_rbc, emission_rbc, peak_rbc
from pipeline.errors import InputError
from pipeline.sizing import SizingRules, dhw_tank, heat_pump_power, pv_power

ROOT = Path(__file__).resolve().parents[2]
RAW_CONFIG = ROOT / "raw" / "district.toml"


def _short_config(tmp_path: Path, **surrogate) -> Path:
    """raw/district.toml for three days, written next to raw/ so relative paths still resolve."""
    text = RAW_CONFIG.read_text().replace("end = 2018-06-30", "end = 2018-06-03")
    text = text.replace('source = "csv"', f'source = "{surrogate.get("source", "none")}"')
    cap = f"\nmax_seconds = {surrogate['max_seconds']}" if "max_seconds" in surrogate else ""
    text = text.replace("epochs = 40", f"epochs = {surrogate.get('epochs', 40)}{cap}")
    path = ROOT / "raw" / f".test_{tmp_path.name}.toml"
    path.write_text(text)
    return path


@pytest.fixture()
def short_config(tmp_path):
    path = _short_config(tmp_path)
    yield read_build_config(path)
    path.unlink(missing_ok=True)


def test_config_errors_name_file_and_key(tmp_path):
    with pytest.raises(InputError, match=r"cfg.toml.*'sizing.battery'.*unknown battery 'Acme'"):
        parse_build_config({"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
                            "inputs": {"eulp": "e", "buildings": [1], "weather": "w", "tariff": "t",
                                       "fuel_mix": "f"}, "sizing": {"battery": "Acme"}}, file="cfg.toml")
    with pytest.raises(InputError, match=r"'period'.*end must not be before start"):
        parse_build_config({"name": "x", "period": {"start": "2018-06-02", "end": "2018-06-01"},
                            "inputs": {"eulp": "e", "buildings": [1], "weather": "w", "tariff": "t",
                                       "fuel_mix": "f"}})
    bad = tmp_path / "bad.toml"
    bad.write_text(RAW_CONFIG.read_text().replace("[pv]", "[pv]\ncolour = 'blue'"))
    with pytest.raises(InputError, match=r"bad.toml.*'pv.colour'.*Extra inputs are not permitted"):
        read_build_config(bad)


def test_heat_pump_sized_at_peak_electric_input():
    # COP = 0.25 * (8 + 273.15) / (T - 8): at 33 C -> 2.81150, at 23 C -> 4.68583
    cooling, outdoor = np.array([3.0, 5.0]), np.array([23.0, 33.0])
    expected = max(3.0 / (0.25 * 281.15 / 15.0), 5.0 / (0.25 * 281.15 / 25.0))
    assert heat_pump_power(cooling, outdoor, SizingRules()) == pytest.approx(expected)


def test_dhw_tank_is_half_the_peak_and_pv_meets_zne_fraction():
    tank = dhw_tank(np.array([0.2, 1.6, 0.4]), 1.8, SizingRules())
    assert tank == {"capacity": 0.8, "loss_coefficient": 0.004, "max_input_power": 1.8, "max_output_power": 1.8}
    # 100 kWh consumption, 21.5 % from PV; yield 1000 W/kW for 200 h = 200 kWh/kW -> 0.1075 kW -> 0.11
    assert pv_power(100.0, np.full(200, 1000.0), SizingRules()) == pytest.approx(0.11)


def test_rule_based_controllers_follow_the_paper():
    weekday = [cost_rbc(h, 2) for h in range(1, 25)]
    assert sum(v for v in weekday if v > 0) == pytest.approx(1.0)         # charge to capacity off-peak
    assert sum(weekday[15:18]) == pytest.approx(-0.5)                     # half on-peak (hours ending 16-18)
    assert sum(weekday) == pytest.approx(0.0)
    assert all(cost_rbc(h, 7) > 0 for h in range(1, 25))                  # weekend: constant charge
    assert sum(emission_rbc(h, 3) for h in range(1, 9)) == pytest.approx(1.0)
    assert sum(peak_rbc(h, 3) for h in range(7, 24)) == pytest.approx(-1.0)


def test_local_build_is_complete_verifiable_and_loads(short_config, tmp_path):
    folder = build.build_district_local(short_config, tmp_path)
    for name in ("schema.json", "Building_1.csv", "Building_2.csv", "weather.csv", "pricing.csv",
                 "carbon_intensity.csv", "manifest.json", "report/summary.md", "report/kpis_cost_rbc.csv",
                 "report/district_net.png"):
        assert (folder / name).is_file(), name
    assert [p.name for p in tmp_path.iterdir()] == ["default"]   # no temporary folder left behind
    # one site, one PV yield: every building's solar_generation column is the same series
    solar = [np.loadtxt(folder / f"Building_{i}.csv", delimiter=",", skiprows=1)[:, 11] for i in (1, 2)]
    assert np.array_equal(solar[0], solar[1]) and solar[0].max() > 0
    assert build.verify_district(folder) == []
    summary = (folder / "report" / "summary.md").read_text()
    schema = json.loads((folder / "schema.json").read_text())
    battery = schema["buildings"]["Building_1"]["electrical_storage"]["attributes"]
    assert battery["capacity"] == 4.0 and "| Building_1 |" in summary and "4.0 / 3.32" in summary
    env = CityLearnEnv(folder / "schema.json")
    obs, _ = env.reset(seed=0)
    assert env.district.length == 72 and np.isfinite(obs).all()
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["outputs"]["schema.json"]["sha256"] and manifest["seeds"]["build"] == 0
    with open(folder / "pricing.csv", "a") as handle:
        handle.write("0.1,0.1,0.1,0.1\n")
    assert build.verify_district(folder) == ["pricing.csv: sha256 differs from the manifest"]


def test_failed_build_leaves_nothing(short_config, tmp_path):
    bad = short_config.model_copy(update={"inputs": short_config.inputs.model_copy(update={"buildings": [4242]})})
    with pytest.raises(InputError, match="4242"):
        build.build_district_local(bad, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_prefect_flow_builds_the_same_district(short_config, tmp_path):
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    from pipeline.flows import build_district

    with temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}):
        folder = build_district(short_config, str(tmp_path / "flow"))
    local = build.build_district_local(short_config, tmp_path / "local")
    for name in ("schema.json", "Building_1.csv", "weather.csv", "carbon_intensity.csv"):
        assert (folder / name).read_bytes() == (local / name).read_bytes(), name
    shutil.rmtree(tmp_path / "flow")


@pytest.mark.slow  # ~1-2 min: closed-loop validation and evaluation over a year of ILV data
def test_build_with_surrogates_emits_lstm_buildings(tmp_path):
    """csv ILV tables -> training (tiny budget) -> .pth next to the schema -> the env runs the LSTM."""
    path = _short_config(tmp_path, source="csv", epochs=1, max_seconds=3.0)
    try:
        config = read_build_config(path).model_copy(update={"cache_dir": tmp_path / "cache"})
        folder = build.build_district_local(config, tmp_path / "out")
    finally:
        path.unlink(missing_ok=True)
    schema = json.loads((folder / "schema.json").read_text())
    block = schema["buildings"]["Building_1"]["dynamics"]
    assert block["type"] == "citylearn.dynamics.LSTMDynamics" and block["attributes"]["filename"] == "Building_1.pth"
    assert block["attributes"]["input_observation_names"][-1] == "indoor_dry_bulb_temperature"
    metrics = json.loads((folder / "surrogates" / "Building_1.metrics.json").read_text())
    assert metrics["test"]["monthly_rmse_c"]["median"] > 0
    env = CityLearnEnv(folder / "schema.json")
    env.reset(seed=0)
    for _ in range(20):
        env.step(np.full(env.action_space.shape, 0.5))
    temps = env.series()["indoor_dry_bulb_temperature"]
    data = env.series()["indoor_dry_bulb_temperature_without_partial_load"]
    assert not np.allclose(temps[:, 13:21], data[:, 13:21])   # the surrogate, not the data, from t = 13
    assert np.all((temps > 5) & (temps < 45))
    assert build.verify_district(folder) == []


@pytest.mark.slow  # a local Dask cluster starts in ~10-30 s here
def test_dask_task_runner_builds_the_same_district(short_config, tmp_path):
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    from pipeline.flows import build_district_on_dask

    with temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}):
        folder = build_district_on_dask(short_config, str(tmp_path / "dask"), workers=2)
    local = build.build_district_local(short_config, tmp_path / "local")
    for name in ("schema.json", "Building_2.csv", "pricing.csv"):
        assert (folder / name).read_bytes() == (local / name).read_bytes(), name


def test_pipeline_imports_no_private_name_of_another_package():
    """pipeline/ uses the public APIs of citylearn_env and surrogates (no ``from x import _y``)."""
    import ast

    offenders = []
    for path in sorted((ROOT / "pipeline").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and not node.module.startswith("pipeline"):
                offenders += [f"{path.name}: {node.module}.{a.name}" for a in node.names if a.name.startswith("_")]
    assert offenders == []
