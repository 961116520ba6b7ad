"""What CityLearn 2.4+ data sets (upstream's neighbourhood builder, the Quebec occupant sets) use, each derived
here in tmp_path (issue 28, part 1): hvac_mode 3 (auto), CityLearn 2.2+'s PV and battery autosize attributes,
null LSTM sizes, and the occupant set-point overrides of ``LogisticRegressionOccupantInteractionBuilding``.

Everything but the last two tests needs nothing outside the repository: districts come from
:func:`citylearn_env.example.write_example_district`, a tiny LSTM is saved with torch, occupant models are real
scikit-learn LogisticRegressions pickled here. The tests on a copy of upstream's v2.4.2 2023 data set skip with a
stated reason when ../shared is absent.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from citylearn_env import CityLearnEnv, SchemaError, load_schema
from citylearn_env import pv_battery_autosize as pvb
from citylearn_env.ev import upstream_device_seed, upstream_uniform
from citylearn_env.example import write_example_district
from citylearn_env.occupant import (
    OccupantConfig,
    OccupantModel,
    interaction_probability,
    occupant_draw,
    read_logistic_regression,
    set_point_change,
)
from tests.conftest import SHARED, need_shared

HOURS = 48
LOOKBACK = 2
V24_LSTM = SHARED / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2023_phase_3_1"


def _one_line(error: pytest.ExceptionInfo) -> str:
    text = str(error.value)
    assert "\n" not in text and "Traceback" not in text
    return text


def _edit(path: Path, edit) -> dict:
    raw = json.loads(path.read_text())
    edit(raw)
    path.write_text(json.dumps(raw))
    return raw


def _set_columns(csv: Path, **columns) -> None:
    frame = pd.read_csv(csv)
    for name, value in columns.items():
        frame[name] = value
    frame.to_csv(csv, index=False)


def _tiny_lstm(path: Path, n_inputs: int, hidden: int = 3) -> None:
    """A 1-layer LSTM state dict (torch.save) with small fixed weights: predictions stay near the inputs' range."""
    torch = pytest.importorskip("torch")
    rs = np.random.RandomState(0)

    def t(*shape):
        return torch.tensor(rs.uniform(-0.1, 0.1, shape), dtype=torch.float32)

    torch.save({"l_lstm.weight_ih_l0": t(4 * hidden, n_inputs), "l_lstm.weight_hh_l0": t(4 * hidden, hidden),
                "l_lstm.bias_ih_l0": t(4 * hidden), "l_lstm.bias_hh_l0": t(4 * hidden),
                "l_linear.weight": t(1, hidden), "l_linear.bias": torch.tensor([0.5])}, path)


LSTM_INPUTS = ["outdoor_dry_bulb_temperature", "indoor_dry_bulb_temperature_cooling_set_point", "cooling_demand",
               "heating_demand", "hour_sin", "hour_cos", "indoor_dry_bulb_temperature"]


def lstm_district(tmp_path: Path, *, hvac_mode: float, combined_action: bool = True,
                  lstm_overrides: dict | None = None) -> Path:
    """A one-building example district whose building runs a tiny LSTM (lookback 2) with a heat pump for cooling
    and one for heating, the given hvac_mode in every row, and the cooling_or_heating_device action."""
    schema = write_example_district(tmp_path, n_buildings=1, hours=HOURS, seed=4)
    csv = tmp_path / "Building_1.csv"
    frame = pd.read_csv(csv)
    _set_columns(csv, hvac_mode=hvac_mode, indoor_dry_bulb_temperature_cooling_set_point=24.0,
                 indoor_dry_bulb_temperature_heating_set_point=20.0, indoor_dry_bulb_temperature=22.0,
                 occupant_count=2.0, heating_demand=0.0, cooling_demand=frame["cooling_demand"])
    _tiny_lstm(tmp_path / "Building_1.pth", len(LSTM_INPUTS))

    def edit(raw):
        b = raw["buildings"]["Building_1"]
        b["type"] = "citylearn.building.LSTMDynamicsBuilding"
        b["heating_device"] = {"type": "citylearn.energy_model.HeatPump", "autosize": False,
                               "attributes": {"nominal_power": 3.0, "efficiency": 0.25}}
        attributes = {"input_size": len(LSTM_INPUTS), "hidden_size": 3, "num_layers": 1, "lookback": LOOKBACK,
                      "filename": "Building_1.pth", "input_observation_names": LSTM_INPUTS,
                      "input_normalization_minimum": [0.0, 15.0, 0.0, 0.0, -1.0, -1.0, 15.0],
                      "input_normalization_maximum": [40.0, 30.0, 10.0, 10.0, 1.0, 1.0, 35.0]}
        attributes.update(lstm_overrides or {})
        b["dynamics"] = {"type": "citylearn.dynamics.LSTMDynamics", "attributes": attributes}
        action = "cooling_or_heating_device" if combined_action else "cooling_device"
        raw["actions"] = {**raw["actions"], action: {"active": True}}
        raw["random_seed"] = 7

    _edit(schema, edit)
    return schema


# ------------------------------------------------------------------------------------------ hvac_mode 3
def test_hvac_mode_3_is_read_and_4_refused_in_one_line(tmp_path):
    schema = write_example_district(tmp_path, n_buildings=1, hours=HOURS, seed=1)
    _set_columns(tmp_path / "Building_1.csv", hvac_mode=3)
    assert (load_schema(schema).buildings[0].series["hvac_mode"] == 3).all()
    _set_columns(tmp_path / "Building_1.csv", hvac_mode=4)
    with pytest.raises(SchemaError) as error:
        load_schema(schema)
    assert "Building_1.csv" in _one_line(error) and "'hvac_mode'" in str(error.value)


def _demands_after(schema: Path, action: float) -> tuple[float, float, CityLearnEnv]:
    """Recorded (cooling, heating) demand [kWh] at the first step where the LSTM is warm, under ``action``."""
    env = CityLearnEnv(schema)
    env.reset(seed=0)
    for _ in range(LOOKBACK + 2):
        env.step(np.array([0.0, 0.0, action]))
    t = env.t
    series = env.series()
    return float(series["cooling_demand"][0, t]), float(series["heating_demand"][0, t]), env


def test_auto_mode_lets_the_action_choose_cooling_or_heating(tmp_path):
    schema = lstm_district(tmp_path, hvac_mode=3)
    config = load_schema(schema)
    b = config.buildings[0]
    t_out = b.series["outdoor_dry_bulb_temperature"]
    # upstream: cooling demand = max electric power x COP in hvac modes 1 and 3, heating in 2 and 3
    cooling, heating, env = _demands_after(schema, -0.5)
    t = env.t
    cop_c = b.cooling_device.efficiency * (8.0 + 273.15) / (t_out[t] - 8.0)
    cop_c = 20.0 if not 0 < cop_c <= 20 else cop_c
    assert cooling == pytest.approx(0.5 * b.cooling_device.nominal_power * cop_c, rel=1e-9)
    assert heating == 0.0
    cooling, heating, env = _demands_after(schema, +0.5)
    cop_h = b.heating_device.efficiency * (45.0 + 273.15) / (45.0 - t_out[t])
    assert heating == pytest.approx(0.5 * 3.0 * cop_h, rel=1e-9) and cooling == 0.0


def test_cooling_mode_gives_no_heating_for_a_heating_action(tmp_path):
    cooling, heating, _ = _demands_after(lstm_district(tmp_path, hvac_mode=1), +0.5)
    assert cooling == 0.0 and heating == 0.0


# ------------------------------------------------------------------------------------------ LSTM nulls
def test_null_lstm_sizes_are_read_from_the_weights(tmp_path):
    schema = lstm_district(tmp_path, hvac_mode=1,
                           lstm_overrides={"input_size": None, "hidden_size": None, "num_layers": None})
    block = load_schema(schema).buildings[0].cooling_model
    assert (block.input_size, block.hidden_size, block.num_layers) == (len(LSTM_INPUTS), 3, 1)
    env = CityLearnEnv(schema)
    env.reset(seed=0)
    for _ in range(5):
        obs, *_ = env.step(np.zeros(env.action_space.shape))
    assert np.isfinite(obs).all()


@pytest.mark.parametrize("key", ["lookback", "input_observation_names", "input_normalization_minimum"])
def test_a_null_the_weights_cannot_tell_is_one_line(tmp_path, key):
    schema = lstm_district(tmp_path, hvac_mode=1, lstm_overrides={key: None})
    with pytest.raises(SchemaError) as error:
        load_schema(schema)
    assert f"'buildings.Building_1.dynamics.attributes.{key}'" in _one_line(error) and "is null" in str(error.value)


def test_input_size_disagreeing_with_the_names_is_one_line(tmp_path):
    schema = lstm_district(tmp_path, hvac_mode=1, lstm_overrides={"input_size": 5})
    with pytest.raises(SchemaError) as error:
        load_schema(schema)
    assert "input_size disagree" in _one_line(error)


# ------------------------------------------------------------------------------------------ autosize 2.2+
def _autosize_district(tmp_path: Path, pv: dict | None = None, battery: dict | None = None) -> Path:
    schema = write_example_district(tmp_path, n_buildings=1, hours=HOURS, seed=2)
    (tmp_path / "weather.epw").write_text("LOCATION,Somewhere\n")  # only its presence is checked offline

    def edit(raw):
        b = raw["buildings"]["Building_1"]
        raw["random_seed"] = 3
        if pv is not None:
            b["pv"] = {"type": "citylearn.energy_model.PV", "autosize": True, "autosize_attributes": pv}
        if battery is not None:
            b["electrical_storage"]["autosize"] = True
            b["electrical_storage"]["autosize_attributes"] = battery

    _edit(schema, edit)
    return schema


def test_pv_autosize_with_epw_and_roof_area(tmp_path):
    schema = _autosize_district(tmp_path, pv={"epw_filepath": "weather.epw", "zero_net_energy_proportion": 0.8})
    b = load_schema(schema).buildings[0]
    s = b.series
    consumption = pvb.baseline_consumption(s, b.cooling_device, b.heating_device, b.dhw_device)
    expected = 0.8 * consumption.sum() / (s["solar_generation"].sum() / 1000.0)
    assert b.pv_nominal_power == pytest.approx(expected, rel=1e-12) and expected > 0
    # the roof caps it at roof_area / 5.263 m2 per kW
    roofed = _autosize_district(tmp_path / "roof", pv={"epw_filepath": "weather.epw", "roof_area": 10.0})
    assert load_schema(roofed).buildings[0].pv_nominal_power == pytest.approx(10.0 / 5.263)
    # the default ZNE share (0.7, 1.0) is drawn with the device's upstream seed
    drawn = _autosize_district(tmp_path / "drawn", pv={"epw_filepath": "weather.epw"})
    u = upstream_uniform(upstream_device_seed("Building_1", "citylearn.building.Building", "pv",
                                              "citylearn.energy_model.PV", 3))
    assert load_schema(drawn).buildings[0].pv_nominal_power == pytest.approx(expected / 0.8 * (0.7 + 0.3 * u))


@pytest.mark.parametrize(("attrs", "text"), [
    ({"epw_filepath": "missing.epw"}, "missing.epw"),
    ({"epw_filepath": "weather.epw", "use_sample_target": True}, "lbl-tracking_the_sun-res-pv.csv"),
    ({"epw_filepath": "weather.epw", "roof_area": "big"}, "roof_area"),
    ({"epw_filepath": "weather.epw", "sizing": 1}, "unknown autosize attribute"),
])
def test_pv_autosize_problems_are_one_line(tmp_path, attrs, text):
    with pytest.raises(SchemaError) as error:
        load_schema(_autosize_district(tmp_path, pv=attrs))
    assert text in _one_line(error)


def test_pv_autosize_on_a_building_without_solar_profile_reads_the_epw(tmp_path):
    # no profile in the data: PVWatts on the EPW (citylearn_env/pvwatts.py); this EPW is not one: one line
    pytest.importorskip("pvlib")
    schema = _autosize_district(tmp_path, pv={"epw_filepath": "weather.epw", "roof_area": 50.0})
    _set_columns(tmp_path / "Building_1.csv", solar_generation=0.0)
    with pytest.raises(SchemaError) as error:
        load_schema(schema)
    assert "weather.epw" in _one_line(error) and "not a readable EPW" in str(error.value)


def test_battery_autosize_2_2_rule(tmp_path):
    schema = _autosize_district(tmp_path, battery={"duration": 2.0, "parallel": False, "safety_factor": 1.5})
    b = load_schema(schema).buildings[0]
    consumption = pvb.baseline_consumption(b.series, b.cooling_device, b.heating_device, b.dhw_device)
    peak = consumption.reshape(-1, 24).max(axis=1).mean()
    assert b.electrical_storage.nominal_power == pytest.approx(peak)
    assert b.electrical_storage.capacity == pytest.approx(peak * 2.0 * 1.5)
    # no attributes: duration drawn in (1.5, 3.5) with the device's upstream seed; CityLearn 2.1's rule: 0
    plain = _autosize_district(tmp_path / "plain", battery=None)
    _edit(plain, lambda raw: raw["buildings"]["Building_1"]["electrical_storage"].__setitem__("autosize", True))
    u = upstream_uniform(upstream_device_seed("Building_1", "citylearn.building.Building", "electrical_storage",
                                              "citylearn.energy_model.Battery", 3))
    assert load_schema(plain).buildings[0].electrical_storage.capacity == pytest.approx(peak * (1.5 + 2.0 * u))
    assert load_schema(plain, settings="citylearn-2.1").buildings[0].electrical_storage.capacity == 0.0


# ------------------------------------------------------------------------------------------ occupant models
def _fitted(n_classes: int, seed: int):
    sklearn = pytest.importorskip("sklearn.linear_model")
    rs = np.random.RandomState(seed)
    x = rs.normal(size=(120, 3)) * [2.0, 2.0, 1.0] + [22.0, 22.0, 0.0]
    y = np.digitize(x[:, 2] + 0.3 * (x[:, 0] - 22.0), np.linspace(-1, 1, n_classes - 1))
    return sklearn.LogisticRegression(max_iter=5000).fit(x, y), x


@pytest.mark.parametrize("n_classes", [2, 3])
def test_logistic_model_read_without_sklearn_predicts_as_sklearn(tmp_path, n_classes):
    model, x = _fitted(n_classes, n_classes)
    path = tmp_path / "model.pkl"
    path.write_bytes(pickle.dumps(model))
    ours = read_logistic_regression(path, where="occupant")
    assert [ours.predict(row) for row in x] == model.predict(x).tolist()


class _Payload:
    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


@pytest.mark.parametrize("payload", ["system", "other_class"])
def test_a_malicious_or_foreign_pickle_is_refused_in_one_line_and_never_run(tmp_path, payload):
    marker = tmp_path / "ran"
    path = tmp_path / "model.pkl"
    obj = _Payload(marker) if payload == "system" else {"coef_": pd.DataFrame({"a": [1]})}
    path.write_bytes(pickle.dumps(obj))
    with pytest.raises(SchemaError) as error:
        read_logistic_regression(path, where="buildings.B.occupant.attributes.setpoint_increase_model_filename")
    text = _one_line(error)
    assert "refusing to load" in text and "is not allowed" in text and "model.pkl" in text
    assert not marker.exists()


def _occupant(up: float = 50.0, down: float = -50.0, hold: int | None = None, n: int = HOURS) -> OccupantConfig:
    model, _ = _fitted(2, 0)
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"occupant_{os.getpid()}.pkl"
    path.write_bytes(pickle.dumps(model))
    m = read_logistic_regression(path, where="x")
    path.unlink()
    return OccupantConfig(m, m, {0: 0.5, 1: 1.0}, np.full(n, up), np.zeros(n), np.full(n, down), np.zeros(n),
                          set_point_hold_time_steps=hold)


def test_probability_draw_and_change_rules():
    assert interaction_probability(0.0, 0.5, 0.0) == 0.5
    assert interaction_probability(-1.0, 0.1, 20.0) == pytest.approx(1 / (1 + np.exp(-1.0)))
    assert occupant_draw(0, 5) == np.random.RandomState(6).uniform()  # max(seed, 1) + t
    assert occupant_draw(9, 2) == np.random.RandomState(11).uniform()
    features = np.array([24.0, 24.0, 1.5])
    occupant = _occupant()
    label = occupant.increase.predict(features)
    assert set_point_change(occupant, 3, features, 25.0, 0.3) == occupant.delta_output_map[label]  # only up
    both = _occupant(up=50.0, down=50.0)
    assert set_point_change(both, 3, features, 25.0, 0.3) == 0.0  # both >= r: no change
    down = _occupant(up=-50.0, down=50.0)
    assert set_point_change(down, 3, features, 25.0, 0.3) == -down.delta_output_map[down.decrease.predict(features)]


def _columns(hvac: float, n: int = HOURS) -> dict:
    return {"indoor_dry_bulb_temperature_cooling_set_point": np.full((1, n), 24.0),
            "indoor_dry_bulb_temperature_heating_set_point": np.full((1, n), 20.0),
            "indoor_dry_bulb_temperature_set_point": np.full((1, n), 24.0), "hvac_mode": np.full((1, n), hvac)}


def test_override_holds_then_returns_to_the_data_set_points():
    occupant = _occupant(hold=2)
    model = OccupantModel([(0, occupant)], 1)
    columns = model.reset(_columns(1.0), 0, HOURS, seed=1)
    temperature = np.full((1, HOURS), 25.0)
    warm = np.array([True])
    model.update(3, temperature, warm)
    delta = model.delta[0, 3]
    assert delta > 0
    cooling = columns["indoor_dry_bulb_temperature_cooling_set_point"][0]
    assert (cooling[:3] == 24.0).all() and (cooling[3:] == 24.0 + delta).all()
    assert (columns["indoor_dry_bulb_temperature_set_point"][0, 3:] == 24.0 + delta).all()
    assert (columns["indoor_dry_bulb_temperature_heating_set_point"] == 20.0).all()  # not in play in mode 1
    # nobody acts for two steps (probabilities 0): the hold runs out and the data set points return from t + 1
    model.episode = [(0, _occupant(up=-50.0, down=-50.0, hold=2))]
    model.update(4, temperature, warm)
    assert cooling[5] == 24.0 + delta
    model.update(5, temperature, warm)
    assert cooling[5] == 24.0 + delta and (cooling[6:] == 24.0).all()


@pytest.mark.parametrize("hvac", [0.0, 3.0])
def test_no_interaction_when_off_or_auto(hvac):
    model = OccupantModel([(0, _occupant())], 1)
    columns = model.reset(_columns(hvac), 0, HOURS, seed=1)
    model.update(3, np.full((1, HOURS), 25.0), np.array([True]))
    assert model.delta[0, 3] == 0.0 and (columns["indoor_dry_bulb_temperature_cooling_set_point"] == 24.0).all()


def _occupant_district(tmp_path: Path, a_increase: float, a_decrease: float) -> Path:
    schema = lstm_district(tmp_path, hvac_mode=1)
    model, _ = _fitted(3, 1)
    for name in ("increase.pkl", "decrease.pkl"):
        (tmp_path / name).write_bytes(pickle.dumps(model))
    pd.DataFrame({"a_increase": [a_increase] * HOURS, "b_increase": [0.0] * HOURS,
                  "a_decrease": [a_decrease] * HOURS, "b_decrease": [0.0] * HOURS}).to_csv(
        tmp_path / "occupant.csv", index=False)

    def edit(raw):
        b = raw["buildings"]["Building_1"]
        b["type"] = "citylearn.building.LogisticRegressionOccupantInteractionBuilding"
        b["occupant"] = {"type": "citylearn.occupant.LogisticRegressionOccupant",
                         "parameters_filename": "occupant.csv",
                         "attributes": {"setpoint_increase_model_filename": "increase.pkl",
                                        "setpoint_decrease_model_filename": "decrease.pkl",
                                        "delta_output_map": {"0": 0.5, "1": 1.0, "2": 1.5}}}
        raw["observations"]["occupant_interaction_indoor_dry_bulb_temperature_set_point_delta"] = {"active": True}
        raw["observations"]["indoor_dry_bulb_temperature_cooling_set_point"] = {"active": True}

    _edit(schema, edit)
    return schema


def _run(env: CityLearnEnv, seed: int, steps: int = 20) -> np.ndarray:
    env.reset(seed=seed)
    for _ in range(steps):
        env.step(np.zeros(env.action_space.shape))
    return env.data("indoor_dry_bulb_temperature_cooling_set_point")[0, :env.t + 1].copy()


def test_occupant_building_overrides_its_cooling_set_point(tmp_path):
    schema = _occupant_district(tmp_path, a_increase=50.0, a_decrease=-50.0)  # always raises it
    env = CityLearnEnv(schema)
    set_point = _run(env, seed=0)
    names = env.observation_names
    obs = env.flat_observations()[env.layout.central_index]
    delta = env.district.occupants.delta[0]
    first = int(np.flatnonzero(delta)[0])
    # the first step the LSTM predicts (its window of lookback + 1 steps filled from step 1 on): upstream's
    # occupant acts only where the building simulates its temperature
    assert first == LOOKBACK + 1
    assert set(delta[first:env.t + 1]) <= {0.5, 1.0, 1.5} and (set_point[:first] == 24.0).all()
    assert set_point[env.t] == pytest.approx(24.0 + delta.sum())
    # the observations follow the override: the set point and the step's change
    assert obs[names.index("Building_1.indoor_dry_bulb_temperature_cooling_set_point")] == pytest.approx(set_point[env.t])
    assert obs[names.index("Building_1.occupant_interaction_indoor_dry_bulb_temperature_set_point_delta")] == delta[env.t]
    # a new episode starts again from the data set's set points
    env.reset(seed=0)
    assert (env.data("indoor_dry_bulb_temperature_cooling_set_point") == 24.0).all()


def test_occupant_draws_follow_the_reset_seed(tmp_path):
    schema = _occupant_district(tmp_path, a_increase=0.0, a_decrease=0.0)  # p = 0.5 both: draws decide nothing
    env = CityLearnEnv(schema)
    assert (_run(env, seed=1) == 24.0).all()  # both probabilities at 0.5: >= r together or < r together
    schema = _occupant_district(tmp_path / "half", a_increase=0.0, a_decrease=-50.0)  # up with p = 0.5
    env = CityLearnEnv(schema)
    a, b, c = _run(env, seed=1), _run(env, seed=1), _run(env, seed=2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    draws = np.array([occupant_draw(1, t) for t in range(LOOKBACK + 1, 21)])
    changed = np.flatnonzero(np.diff(a)) + 1
    np.testing.assert_array_equal(changed, np.flatnonzero(draws <= 0.5) + LOOKBACK + 1)


@pytest.mark.parametrize(("edit", "text"), [
    (lambda b: b.pop("occupant"), "needs an occupant"),
    (lambda b: b["occupant"]["attributes"]["delta_output_map"].pop("2"), "no change given for model class(es) [2]"),
    (lambda b: b["occupant"].__setitem__("type", "citylearn.occupant.Mystery"), "unknown occupant type"),
    (lambda b: b["occupant"].__setitem__("parameters_filename", "nope.csv"), "nope.csv"),
    (lambda b: b.__setitem__("type", "citylearn.building.LSTMDynamicsBuilding"), "an occupant needs building type"),
])
def test_occupant_schema_problems_are_one_line(tmp_path, edit, text):
    schema = _occupant_district(tmp_path, 0.0, 0.0)
    _edit(schema, lambda raw: edit(raw["buildings"]["Building_1"]))
    with pytest.raises(SchemaError) as error:
        load_schema(schema)
    assert text in _one_line(error)


# ------------------------------------------------------------------------------------------ on upstream's data
def _v24_copy(tmp_path: Path) -> Path:
    need_shared(V24_LSTM / "schema.json")
    folder = tmp_path / "v24"
    shutil.copytree(V24_LSTM, folder)
    return folder / "schema.json"


def test_upstream_2023_set_as_a_county_neighbourhood_build(tmp_path):
    """Upstream's 2023 set edited the way the neighbourhood builder writes schemas: hvac_mode 3, PV autosized
    from an EPW with a roof area, battery autosized, null LSTM sizes; it loads and runs."""
    schema = _v24_copy(tmp_path)
    shutil.copy(SHARED / "data" / "weather" / "USA_TX_Travis.County_AMY2018.epw", schema.parent / "weather.epw")

    def edit(raw):
        raw["simulation_end_time_step"] = 71
        for b in raw["buildings"].values():
            b["pv"] = {"type": "citylearn.energy_model.PV", "autosize": True,
                       "autosize_attributes": {"epw_filepath": "weather.epw", "roof_area": 40.0}}
            b["electrical_storage"]["autosize"] = True
            for key in ("input_size", "hidden_size", "num_layers"):
                b["dynamics"]["attributes"][key] = None

    _edit(schema, edit)
    for csv in schema.parent.glob("Building_*.csv"):
        _set_columns(csv, hvac_mode=3)
    env = CityLearnEnv(schema, settings="citylearn-2.5")
    env.reset(seed=0)
    for _ in range(env.episode_length - 1):
        obs, reward, *_ = env.step(env.action_space.sample())
        assert np.isfinite(obs).all() and np.isfinite(reward)
    assert all(0 < b.pv_nominal_power <= 40.0 / 5.263 + 1e-9 for b in env.config.buildings)


def test_upstream_2023_set_with_an_occupant_building(tmp_path):
    """A Quebec-style occupant building (heating mode) on upstream's 2023 LSTM data: loads, runs, overrides."""
    schema = _v24_copy(tmp_path)
    model, _ = _fitted(2, 3)
    (schema.parent / "up.pkl").write_bytes(pickle.dumps(model))
    pd.DataFrame({"a_increase": [50.0] * 2208, "b_increase": [0.0] * 2208, "a_decrease": [-50.0] * 2208,
                  "b_decrease": [0.0] * 2208}).to_csv(schema.parent / "occupant.csv", index=False)

    def edit(raw):
        raw["simulation_end_time_step"] = 47
        b = raw["buildings"]["Building_1"]
        b["type"] = "citylearn.building.LogisticRegressionOccupantInteractionBuilding"
        b["occupant"] = {"type": "citylearn.occupant.LogisticRegressionOccupant", "parameters_filename": "occupant.csv",
                         "attributes": {"setpoint_increase_model_filename": "up.pkl",
                                        "setpoint_decrease_model_filename": "up.pkl",
                                        "delta_output_map": {"0": 1.0, "1": 2.0}}}

    _edit(schema, edit)
    env = CityLearnEnv(schema, settings="citylearn-2.5")
    env.reset(seed=0)
    for _ in range(env.episode_length - 1):
        obs, *_ = env.step(np.zeros(env.action_space.shape))
        assert np.isfinite(obs).all()
    assert env.district.occupants.delta[0].sum() > 0
    lookback = env.config.buildings[0].cooling_model.lookback
    # the 2.5 preset acts from row 0 (act-then-advance): the LSTM first predicts, and the occupant first acts, at
    # row lookback, the step whose call fills the window (row lookback + 1 with CityLearn 2.1's timing)
    assert np.flatnonzero(env.district.occupants.delta[0])[0] == lookback
