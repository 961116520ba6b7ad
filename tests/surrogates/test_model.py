"""Features, normalisation, splits and the stateful closed-loop rollout of the LSTM surrogate."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import torch

from surrogates.config import DEFAULT_INPUTS
from surrogates.model import LSTMModel, Normalization, _rollout_rows, feature_matrix, rollout
from surrogates.train import Segment, perturb_history, split_segments, warm_start_sequences
from tests.surrogates.test_ilv import make_table


def test_periodic_encoding_matches_published_bounds():
    # the 2023 CityLearn models store day_type_sin max sin(4 pi / 7) = 0.97493 and cos min cos(6 pi / 7)
    table = pd.DataFrame({"day_type": np.arange(1, 8), "hour": np.arange(1, 8), "month": np.arange(1, 8)})
    x = feature_matrix(table, ["day_type_sin", "day_type_cos", "hour_sin", "month_cos"])
    assert x[:, 0].max() == pytest.approx(0.97493, abs=1e-5)
    assert x[:, 1].min() == pytest.approx(-0.90097, abs=1e-5)
    assert x[5, 2] == pytest.approx(1.0)  # hour 6 of 24 -> sin(pi / 2)
    assert x[2, 3] == pytest.approx(0.0, abs=1e-12)  # March -> cos(pi / 2)


def test_default_inputs_keep_temperature_last_and_normalization():
    assert DEFAULT_INPUTS[-1] == "indoor_dry_bulb_temperature"
    norm = Normalization.fit(np.array([[0.0, 5.0, 20.0], [10.0, 5.0, 30.0]]))
    np.testing.assert_allclose(norm.apply(np.array([[5.0, 5.0, 25.0]])), [[0.5, 0.0, 0.5]])
    assert norm.target_to_celsius(np.array([0.25]))[0] == pytest.approx(22.5)


def citylearn_style(model: LSTMModel, x: np.ndarray, lookback: int) -> list[float]:
    """Step-by-step re-statement of CityLearn's LSTMDynamicsBuilding loop: a (lookback+1)-slot buffer per
    input, exogenous slots 1.. and temperature slots ..-1 form the window, the hidden state is carried, the
    prediction overwrites the newest temperature slot."""
    buffer: list[list[float]] = []
    state, out = None, []
    for t in range(len(x)):
        buffer.append(list(x[t]))
        buffer = buffer[-(lookback + 1):]
        if len(buffer) < lookback + 1:
            continue
        rows = [buffer[i + 1][:-1] + [buffer[i][-1]] for i in range(lookback)]
        window = torch.tensor([rows], dtype=torch.float32)
        with torch.no_grad():
            y, state = model(window, state)
        buffer[-1][-1] = float(y[0])
        out.append(float(y[0]))
    return out


@pytest.mark.parametrize("lookback", [1, 6])
def test_rollout_is_the_citylearn_loop(lookback):
    torch.manual_seed(0)
    model = LSTMModel(4, hidden_size=5, num_layers=2)
    x = np.random.default_rng(1).random((30, 4)).astype(np.float32)
    with torch.no_grad():
        ours = rollout(model, torch.from_numpy(x)[None], lookback)[0].numpy()
    # first prediction once lookback + 1 hours are buffered (hour `lookback`, CityLearn >= 2.4 timing)
    reference = citylearn_style(model, x, lookback)
    np.testing.assert_allclose(ours, reference, atol=1e-6)
    with torch.no_grad():  # one-step mode uses the data temperatures and differs from closed loop
        one_step = rollout(model, torch.from_numpy(x)[None], lookback, closed_loop=False)[0].numpy()
    assert np.abs(one_step - ours).max() > 1e-4
    assert len(ours) == 30 - lookback


def test_closed_loop_cells_match_the_lstm_module_with_gradients():
    """The lookback-1 closed loop runs the cell equations itself (training and validation): its predictions
    from a given state and the gradients they give every parameter are those of the ``nn.LSTM`` module
    called hour by hour with the prediction fed back."""
    torch.manual_seed(0)
    model = LSTMModel(4, hidden_size=6, num_layers=2)
    x = torch.from_numpy(np.random.default_rng(4).random((3, 25, 4)).astype(np.float32))
    h0 = torch.randn(2, 3, 6) * 0.5
    state = (h0, torch.randn(2, 3, 6) * 0.5)
    ours = rollout(model, x, 1, state=state)
    ours.square().mean().backward()
    grads = [p.grad.clone() for p in model.parameters()]
    model.zero_grad()
    temperature, carried, reference = x[:, 0, -1], state, []
    for k in range(1, x.shape[1]):
        window = torch.cat([x[:, k, :-1], temperature[:, None]], dim=1)[:, None]
        out, carried = model.l_lstm(window, carried)
        temperature = model.l_linear(out[:, -1]).squeeze(-1)
        reference.append(temperature)
    reference = torch.stack(reference, dim=1)
    reference.square().mean().backward()
    torch.testing.assert_close(ours, reference, atol=1e-6, rtol=1e-5)
    for ours_grad, parameter in zip(grads, model.parameters(), strict=True):
        torch.testing.assert_close(ours_grad, parameter.grad, atol=1e-6, rtol=1e-4)


def test_state_dict_keys_are_upstream():
    keys = list(LSTMModel(13, 16, 2).state_dict())
    assert keys == [f"l_lstm.{w}_l{k}" for k in (0, 1) for w in ("weight_ih", "weight_hh", "bias_ih", "bias_hh")] \
        + ["l_linear.weight", "l_linear.bias"]


def test_splits_by_run_and_month():
    hours = 24 * 120  # January .. April 2026 starting on the 5th: four calendar months
    table = make_table(hours=hours, references=(0, 1, 2, 3, 4, 5))
    from surrogates.ilv import validate_ilv

    clean = validate_ilv(table)
    splits = split_segments(clean)
    run_of = clean["reference"].to_numpy()
    for segments in splits.values():
        for seg in segments:  # never across a run boundary
            assert run_of[seg.start] == run_of[seg.stop - 1] == seg.reference
    refs = {role: sorted({s.reference for s in segs}) for role, segs in splits.items()}
    assert refs == {"train": [2, 3], "validation": [0, 4], "test": [0, 5]}  # ideal months only with use_ideal
    splits_ideal = split_segments(clean, use_ideal=True)
    months = {role: sorted({int(clean["month"].iloc[s.start]) for s in segs if s.reference == 0})
              for role, segs in splits_ideal.items()}
    assert months == {"train": [1, 4], "validation": [2, 5], "test": [3]}  # Jan 5 .. May 4
    held_out = [s for s in splits["test"] if s.reference == 5]
    assert len(held_out) == 1 and held_out[0].stop - held_out[0].start == hours  # the held-out run whole
    with_ff = split_segments(clean, use_free_float=True)
    assert 1 in {s.reference for s in with_ff["train"]}
    assert math.isclose(sum(s.stop - s.start for r in splits_ideal.values() for s in r), 5 * hours)


def test_sequence_pass_is_the_one_step_rollout_at_lookback_1():
    """With lookback 1 the stateful sliding window is a plain recurrent model: one LSTM pass over the rows
    (exogenous inputs of hour t+1, data temperature of hour t) gives the one-step rollout's predictions,
    which is what the lookback-1 warm start trains on and what ``rollout`` runs in one-step mode."""
    torch.manual_seed(0)
    model = LSTMModel(4, hidden_size=5, num_layers=2)
    x = torch.from_numpy(np.random.default_rng(2).random((3, 40, 4)).astype(np.float32))
    rows = torch.cat([x[:, 1:, :-1], x[:, :-1, -1:]], dim=2)
    with torch.no_grad():
        whole = model.sequence(rows, model.flat_weights())
        stepped = _rollout_rows(model, x, 1, None, model.flat_weights(), feed_back=False)  # window by window
        one_step = rollout(model, x, 1, closed_loop=False)
    np.testing.assert_allclose(whole.numpy(), stepped.numpy(), atol=1e-6)
    np.testing.assert_allclose(one_step.numpy(), stepped.numpy(), atol=1e-6)


def test_history_perturbation_leaves_the_clean_start_alone():
    """The warm start's noise spares the first ``clean_hours`` of each sample, has the requested spread
    elsewhere, and does not change the random stream (the same draw with or without a clean start)."""
    temps = torch.linspace(0.0, 1.0, 64 * 48).reshape(64, 48, 1)
    clean = perturb_history(temps, 0.06, 6, np.random.default_rng(3))
    full = perturb_history(temps, 0.06, 0, np.random.default_rng(3))
    assert torch.equal(clean[:, :6], temps[:, :6])
    assert torch.equal(clean[:, 6:], full[:, 6:])
    spread = float((clean[:, 6:] - temps[:, 6:]).std())
    assert spread == pytest.approx(0.06, rel=0.05)  # 2688 draws: the sample std is within ~1.4 % (1 sigma)
    assert perturb_history(temps, 0.0, 6, np.random.default_rng(3)) is temps


def test_run_starts_are_in_every_warm_start_pass():
    """With anchors, each pass holds the first sequence of each anchored run; with random offsets alone, it
    is drawn only when the offset happens to be 0."""
    x = np.arange(400, dtype=float).reshape(-1, 1)
    runs = [Segment(2, 0, 200), Segment(3, 200, 400)]
    with_starts = [warm_start_sequences(x, runs, 24, np.random.default_rng(k), runs[:1]) for k in range(20)]
    without = [warm_start_sequences(x, runs, 24, np.random.default_rng(k)) for k in range(20)]
    first = x[:25].astype(np.float32)
    assert all(any(np.array_equal(seq, first) for seq in samples) for samples in with_starts)
    assert sum(any(np.array_equal(seq, first) for seq in samples) for samples in without) < 5
    assert all(len(a) == len(b) + 1 for a, b in zip(with_starts, without, strict=True))
    assert all(samples.dtype == np.float32 and samples.shape[1:] == (25, 1) for samples in with_starts)
