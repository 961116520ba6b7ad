"""Physics ranges on what the LSTM models are and produce (issue 30, part 5): weights must be floating point and
of a trained model's size, and a predicted indoor temperature outside -50..80 degC stops the episode with one
line naming the building and the time step. The unit tests need nothing outside the repository."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, load_schema
from citylearn_env.dataset import DynamicsBlock
from citylearn_env.dynamics import MAX_ABS_WEIGHT, LSTMBank, LSTMSpec
from citylearn_env.errors import DynamicsError, SchemaError
from citylearn_env.thermal import INDOOR_RANGE_C, check_indoor_range
from tests.conftest import DATASET, need_shared

NAMES = ("outdoor_dry_bulb_temperature", "cooling_demand", "indoor_dry_bulb_temperature")
HIDDEN = 4


def small_state(seed: int = 0) -> dict[str, np.ndarray]:
    """A 1-layer LSTM of hidden 4 over three inputs and its linear head, weights of order 0.1."""
    rng = np.random.default_rng(seed)
    n = len(NAMES)
    return {"l_lstm.weight_ih_l0": rng.normal(0, 0.1, (4 * HIDDEN, n)).astype(np.float32),
            "l_lstm.weight_hh_l0": rng.normal(0, 0.1, (4 * HIDDEN, HIDDEN)).astype(np.float32),
            "l_lstm.bias_ih_l0": np.zeros(4 * HIDDEN, np.float32), "l_lstm.bias_hh_l0": np.zeros(4 * HIDDEN, np.float32),
            "l_linear.weight": rng.normal(0, 0.1, (1, HIDDEN)).astype(np.float32),
            "l_linear.bias": np.zeros(1, np.float32)}


BLOCK = DynamicsBlock("small.pth", NAMES, (0.0, 0.0, 10.0), (40.0, 5.0, 40.0), hidden_size=HIDDEN, num_layers=1,
                      lookback=1)


def test_a_small_trained_size_model_loads():
    bank = LSTMBank([LSTMSpec(small_state(), BLOCK, source="small.pth")])
    assert bank.input_names


@pytest.mark.parametrize("value", [1e30, -2e4])
def test_finite_but_absurd_weights_are_refused_naming_the_tensor(value):
    state = small_state()
    state["l_lstm.weight_hh_l0"][2, 1] = value
    with pytest.raises(SchemaError) as error:
        LSTMBank([LSTMSpec(state, BLOCK, source="small.pth")])
    text = str(error.value)
    assert "small.pth" in text and "'l_lstm.weight_hh_l0'" in text and f"{MAX_ABS_WEIGHT:g}" in text
    assert "\n" not in text


def test_integer_weights_are_refused():
    state = small_state()
    state["l_linear.weight"] = np.ones((1, HIDDEN), dtype=np.int64)
    with pytest.raises(SchemaError, match=r"'l_linear.weight'.*floating point, found int64"):
        LSTMBank([LSTMSpec(state, BLOCK, source="small.pth")])


def test_indoor_range_check_passes_warm_up_and_plausible_values():
    check_indoor_range(np.array([21.5, np.nan, -49.0, 79.9]), ["A", "B", "C", "D"], 3)
    check_indoor_range(np.array([np.nan, np.nan]), ["A", "B"], 0)


@pytest.mark.parametrize("value", [2e32, -60.0, np.inf, -np.inf])
def test_an_impossible_indoor_temperature_names_the_building_and_step(value):
    with pytest.raises(DynamicsError) as error:
        check_indoor_range(np.array([22.0, np.nan, value]), ["Building_1", "Building_2", "Building_3"], 17)
    text = str(error.value)
    assert "buildings.Building_3.dynamics" in text and "row 17" in text and "time step 17" in text
    low, high = INDOOR_RANGE_C
    assert f"{low:g}..{high:g} degC" in text and "\n" not in text
    assert isinstance(error.value, SchemaError)  # the CLI prints it as one line, exit 2


def test_a_model_that_predicts_an_impossible_temperature_stops_the_episode(tmp_path):
    """The shared 2023 set (48 h) with Building_1's head biased to +50 (normalised units, so far above any
    indoor temperature; the weights stay within the limit): the episode stops at the first prediction."""
    torch = pytest.importorskip("torch")
    need_shared(DATASET / "schema.json")
    folder = tmp_path / "lstm"
    shutil.copytree(DATASET, folder)
    pth = folder / "Building_1.pth"
    checkpoint = torch.load(pth, weights_only=True)
    state = checkpoint.get("model_state_dict", checkpoint)
    head = next(k for k in state if k.endswith("bias") and "lstm" not in k)
    state[head].fill_(50.0)
    torch.save(checkpoint, pth)
    config = load_schema(folder / "schema.json")
    env = CityLearnEnv(config.with_episode([(0, 47)]))
    env.reset(seed=0)
    with pytest.raises(DynamicsError) as error:
        for _ in range(47):
            env.step(np.zeros(env.action_space.shape))
    text = str(error.value)
    assert "buildings.Building_1.dynamics" in text and "time step" in text and "\n" not in text
