"""LSTM dynamics: the torch-free .pth reader and the batched LSTM bank (golden CityLearn 2.1.2 traces)."""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
import torch

from citylearn_env.dataset import DynamicsBlock
from citylearn_env.dynamics import LSTMBank, LSTMSpec, read_pth_state_dict
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_1, CORRECTED
from tests.conftest import DATASET, GOLDEN, need_shared

PTH = [DATASET / f"Building_{i}.pth" for i in range(1, 7)]
BACKENDS = ["numba", "numpy"]


# ---------------------------------------------------------------------------------------------- reader
def test_reader_matches_torch_on_citylearn_weights():
    need_shared(*PTH)
    for path in PTH:
        ours = read_pth_state_dict(path)
        ref = torch.load(path, weights_only=True)["model_state_dict"]
        assert list(ours) == list(ref)
        for key, tensor in ref.items():
            assert ours[key].dtype == np.float32 and ours[key].shape == tuple(tensor.shape)
            np.testing.assert_array_equal(ours[key], tensor.numpy(), err_msg=f"{path.name} {key}")


def test_reader_honours_dtypes_strides_offsets_and_bare_state_dicts(tmp_path):
    base = torch.arange(60, dtype=torch.float64).reshape(6, 10)
    tensors = {
        "transposed": base[:, 2:5].T,  # non-contiguous view
        "offset": base.reshape(-1)[17:29],  # shares the storage at an offset
        "f32": torch.linspace(-1, 1, 7, dtype=torch.float32),
        "f16": torch.tensor([0.5, -2.0, 1e-3], dtype=torch.float16),
        "i64": torch.tensor([[1, -2], [3, 2**40]]),
        "u8": torch.tensor([0, 255], dtype=torch.uint8),
        "flag": torch.tensor([True, False]),
        "scalar": torch.tensor(3.25),
        "param": torch.nn.Parameter(torch.ones(2, 3)),
    }
    path = tmp_path / "bare.pth"
    torch.save(tensors, path)
    ours = read_pth_state_dict(path)
    for key, tensor in tensors.items():
        expected = tensor.detach().numpy()
        assert ours[key].dtype == expected.dtype, key
        np.testing.assert_array_equal(ours[key], expected, err_msg=key)


class _Evil:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.mark.parametrize("where", ["top", "optimizer"])
def test_reader_refuses_code_in_the_pickle(tmp_path, where):
    marker = tmp_path / "pwned"
    evil = _Evil(marker)
    checkpoint = {"model_state_dict": {"w": torch.ones(2)}, "epoch": 3}
    if where == "top":
        checkpoint["payload"] = evil
    else:
        checkpoint["optimizer_state_dict"] = {"state": {0: {"step": evil}}, "param_groups": [{"lr": 0.1}]}
    path = tmp_path / "evil.pth"
    torch.save(checkpoint, path)
    with pytest.raises(SchemaError, match=r"refusing to load: global '(posix|os)\.system' is not allowed") as err:
        read_pth_state_dict(path)
    assert "evil.pth" in str(err.value)
    assert not marker.exists()


def test_reader_accepts_checkpoint_with_plain_optimizer_state(tmp_path):
    model = torch.nn.Linear(3, 2)
    optimizer = torch.optim.Adam(model.parameters(), lr=0.01)
    model(torch.ones(1, 3)).sum().backward()
    optimizer.step()
    path = tmp_path / "ckpt.pth"
    torch.save({"model_state_dict": model.state_dict(), "optimizer_state_dict": optimizer.state_dict(),
                "epoch": 1, "train_loss": 0.5}, path)
    ours = read_pth_state_dict(path)
    assert sorted(ours) == ["bias", "weight"]
    np.testing.assert_array_equal(ours["weight"], model.weight.detach().numpy())


def test_reader_rejects_non_zip_and_tensorless_files(tmp_path):
    bad = tmp_path / "legacy.pth"
    bad.write_bytes(b"\x80\x02not a zip")
    with pytest.raises(SchemaError, match="legacy.pth.*zip"):
        read_pth_state_dict(bad)
    empty = tmp_path / "list.pth"
    torch.save({"model_state_dict": {"a": [1, 2]}}, empty)
    with pytest.raises(SchemaError, match="'a'.*not a tensor"):
        read_pth_state_dict(empty)
    with zipfile.ZipFile(tmp_path / "nodata.pth", "w") as z:
        z.writestr("x/version", "3")
    with pytest.raises(SchemaError, match="data.pkl"):
        read_pth_state_dict(tmp_path / "nodata.pth")


# --------------------------------------------------------------------------------- bank against golden
def _spec(block: dict) -> LSTMSpec:
    a = block["attributes"]
    return LSTMSpec(read_pth_state_dict(DATASET / a["filename"]), DynamicsBlock.from_schema(block),
                    source=a["filename"])


def _golden(scenario: str):
    need_shared(GOLDEN / scenario, DATASET)
    schema = json.loads((GOLDEN / scenario / "schema_used.json").read_text())
    names = list(schema["buildings"])
    cooling = [_spec(schema["buildings"][n]["dynamics"]["cooling"]) for n in names]
    heating = [_spec(schema["buildings"][n]["dynamics"]["heating"]) for n in names]
    trace = pd.read_parquet(GOLDEN / scenario / "trace.parquet")
    obs = pd.read_parquet(GOLDEN / scenario / "observations_all.parquet")

    def matrix(frame, column):
        return frame.pivot(index="building", columns="time_step", values=column).loc[names].to_numpy()

    inputs = {name: matrix(obs, name) for name in ("direct_solar_irradiance", "diffuse_solar_irradiance",
                                                    "outdoor_dry_bulb_temperature", "occupant_count",
                                                    "indoor_dry_bulb_temperature_set_point", "month", "hour",
                                                    "day_type")}
    # delivered energy, not the (action-derived) demand
    for k in ("cooling", "heating"):
        inputs[f"{k}_demand"] = matrix(trace, f"energy_from_{k}_device") + matrix(trace, f"energy_from_{k}_storage")
    # the value the building holds at t before prediction: the data-set temperature
    inputs["indoor_dry_bulb_temperature"] = matrix(trace, "indoor_dry_bulb_temperature_without_partial_load")
    return cooling, heating, inputs, matrix(trace, "hvac_mode"), matrix(trace, "indoor_dry_bulb_temperature")


@pytest.mark.parametrize(("scenario", "backend"), [("no_control", "numba"), ("no_control", "numpy"),
                                                   ("full_random", "numba")])
def test_bank_reproduces_citylearn_indoor_temperature(scenario, backend):
    cooling, heating, inputs, hvac, expected = _golden(scenario)
    bank = LSTMBank(cooling, heating, settings=CITYLEARN_2_1, backend=backend)
    assert set(bank.input_names) == set(inputs)
    predicted = np.full(expected.shape, np.nan)
    warm = []
    for t in range(1, expected.shape[1]):
        warm.append(bank.warm(hvac[:, t]).copy())
        predicted[:, t] = bank.step({k: v[:, t] for k, v in inputs.items()}, hvac[:, t])
    # warm-up: 13 appends (t = 1..13) before the first prediction; control (warm) from t = 14
    assert np.isnan(predicted[:, :13]).all() and not np.isnan(predicted[:, 13:]).any()
    assert not np.any(warm[:13]) and np.all(warm[13:])
    np.testing.assert_allclose(predicted[:, 13:], expected[:, 13:], rtol=0, atol=1e-3)


# ------------------------------------------------------------------------ bank against a torch reference
def _torch_reference(spec: LSTMSpec, raw_rows: list[dict], day_type_period: float) -> np.ndarray:
    """Stateful sliding-window prediction with torch.nn.LSTM in float64 (the corrected rules)."""
    n_in, hid = len(spec.input_observation_names), spec.hidden_size
    lstm = torch.nn.LSTM(n_in, hid, spec.num_layers, batch_first=True).double()
    head = torch.nn.Linear(hid, 1).double()
    lstm.load_state_dict({k[len("l_lstm."):]: torch.tensor(v) for k, v in spec.state_dict.items()
                          if k.startswith("l_lstm.")})
    head.load_state_dict({"weight": torch.tensor(spec.state_dict["l_linear.weight"]),
                          "bias": torch.tensor(spec.state_dict["l_linear.bias"])})
    lo, hi = np.array(spec.input_normalization_minimum), np.array(spec.input_normalization_maximum)
    periods = {"hour": 24.0, "month": 12.0, "day_type": day_type_period}
    ti = spec.input_observation_names.index("indoor_dry_bulb_temperature")
    state = (torch.zeros(spec.num_layers, 1, hid, dtype=torch.float64),) * 2
    rows, out = [], []
    for raw in raw_rows:
        x = []
        for name in spec.input_observation_names:
            base = name.rsplit("_", 1)[0]
            if name.endswith(("_sin", "_cos")) and base in periods:
                f = np.sin if name.endswith("_sin") else np.cos
                x.append(f(2 * np.pi * raw[base] / periods[base]))
            else:
                x.append(raw[name])
        rows = (rows + [(np.array(x) - lo) / (hi - lo)])[-(spec.lookback + 1):]
        if len(rows) <= spec.lookback:
            out.append(np.nan)
            continue
        window = np.array(rows[1:])
        window[:, ti] = np.array(rows[:-1])[:, ti]
        with torch.no_grad():
            seq, state = lstm(torch.tensor(window[None]), state)
            y = head(seq[:, -1]).item()
        rows[-1][ti] = y
        out.append(y * (hi[ti] - lo[ti]) + lo[ti])
    return np.array(out)


def _rows(inputs: dict, b: int, steps: range) -> list[dict]:
    return [{k: float(v[b, t]) for k, v in inputs.items()} for t in steps]


def _feed(bank: LSTMBank, rows: list[dict], hvac: list[float]) -> np.ndarray:
    return np.array([bank.step({k: np.array([v]) for k, v in row.items()}, np.array([m]))[0]
                     for row, m in zip(rows, hvac, strict=True)])


def _permuted(spec: LSTMSpec, order: list[int]) -> LSTMSpec:
    """The same model with its inputs re-ordered (weight_ih_l0 columns and bounds follow)."""
    state = dict(spec.state_dict)
    state["l_lstm.weight_ih_l0"] = spec.state_dict["l_lstm.weight_ih_l0"][:, order]
    pick = lambda seq: tuple(seq[i] for i in order)  # noqa: E731
    return LSTMSpec(state, replace(spec.block, input_observation_names=pick(spec.input_observation_names),
                                   input_normalization_minimum=pick(spec.input_normalization_minimum),
                                   input_normalization_maximum=pick(spec.input_normalization_maximum)))


@pytest.mark.parametrize("backend", BACKENDS)
def test_bank_matches_torch_lstm_with_carried_state(backend):
    cooling, _, inputs, _, _ = _golden("full_random")
    rows = _rows(inputs, 2, range(300, 340))
    spec = cooling[2]
    # temperature moved to the front: the corrected mode de-normalises with the temperature's own bounds
    moved = _permuted(spec, [12, *range(12)])
    for s in (spec, moved):
        ours = _feed(LSTMBank([s], settings=CORRECTED, backend=backend), rows, [1.0] * len(rows))
        ref = _torch_reference(s, rows, day_type_period=7.0)
        assert np.isnan(ours[:12]).all() and np.isnan(ref[:12]).all()
        np.testing.assert_allclose(ours[12:], ref[12:], rtol=0, atol=1e-9)
    # lstm_output_uses_last_input_bounds de-normalises with the LAST bound pair: for the moved spec that is the
    # last exogenous input
    last_bounds = replace(CORRECTED, lstm_output_uses_last_input_bounds=True)
    upstream = _feed(LSTMBank([moved], settings=last_bounds, backend=backend), rows, [1.0] * len(rows))
    assert not np.allclose(upstream[12:], ref[12:], atol=0.5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_mode_switch_selects_the_heating_model_and_restarts_its_warm_up(backend):
    cooling, heating, inputs, _, _ = _golden("no_control")
    cool, other = cooling[0], heating[3]  # Building_4's network as "heating" model (input heating_demand)
    heat = LSTMSpec(other.state_dict, replace(other.block, hidden_size=16, num_layers=2, lookback=12))
    assert not np.array_equal(cool.state_dict["l_linear.weight"], heat.state_dict["l_linear.weight"])
    rows = _rows(inputs, 0, range(1, 51))
    hvac = [1.0] * 20 + [2.0] * 30
    bank = LSTMBank([cool], [heat], backend=backend)
    out, warm_before = [], []
    for row, mode in zip(rows, hvac, strict=True):
        warm_before.append(bool(bank.warm(np.array([mode]))[0]))
        out.append(bank.step({k: np.array([v]) for k, v in row.items()}, np.array([mode]))[0])
    out = np.array(out)
    np.testing.assert_allclose(out[:20], _torch_reference(cool, rows[:20], 7.0), rtol=0, atol=1e-9)
    np.testing.assert_allclose(out[20:], _torch_reference(heat, rows[20:], 7.0), rtol=0, atol=1e-9)
    assert np.isnan(out[20:32]).all() and not np.isnan(out[32:]).any()
    assert warm_before[13:20] == [True] * 7 and warm_before[20] is False and warm_before[33] is True
    bank.reset()
    assert not bank.is_warm.any()


def test_bank_rejects_inconsistent_specs():
    need_shared(PTH[0])
    state = read_pth_state_dict(PTH[0])
    names = ("a", "b", "c", "d", "e", "f", "g", "h", "i", "j", "k", "l", "indoor_dry_bulb_temperature")
    block = DynamicsBlock("model.pth", names, (0.0,) * 13, (1.0,) * 13, hidden_size=16, num_layers=2, lookback=12)
    missing = {k: v for k, v in state.items() if k != "l_lstm.bias_hh_l1"}
    with pytest.raises(SchemaError, match="'l_lstm.bias_hh_l1'.*missing"):
        LSTMBank([LSTMSpec(missing, block)])
    with pytest.raises(SchemaError, match=r"'l_lstm.weight_ih_l0'.*shape \(64, 13\), expected \(32, 13\)"):
        LSTMBank([LSTMSpec(state, replace(block, hidden_size=8))])
    with pytest.raises(SchemaError, match="'c'.*maximum equals minimum"):
        LSTMBank([LSTMSpec(state, replace(block, input_normalization_maximum=(1.0, 1.0, 0.0) + (1.0,) * 10))])
    bank = LSTMBank([LSTMSpec(state, block)])
    with pytest.raises(SchemaError, match="'a' missing"):
        bank.step({}, np.array([1.0]))


def test_modules_import_without_torch_numba_or_pandas():
    import subprocess
    import sys

    code = ("import sys, citylearn_env.dynamics, citylearn_env.outages; "
            "print(sorted(m for m in ('torch', 'numba', 'pandas', 'prefect') if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "[]"
