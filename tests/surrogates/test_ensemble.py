"""Ensembling K LSTMs into one exported LSTM (block-diagonal weights, averaging head): the merged model's
predictions are the mean of the members' (a property of the construction, checked to float precision), and the
environment's torch-free reader runs the merged .pth with the torch rollout's numbers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from citylearn_env.settings import CORRECTED
from surrogates.config import TrainConfig
from surrogates.evaluate import bank_rollout, predict_segment
from surrogates.export import dynamics_block, save_checkpoint
from surrogates.model import LSTMModel, Normalization, feature_matrix, merge_ensemble, rollout
from surrogates.train import Trained, run_segments, train_surrogate
from tests.surrogates.test_suite_closed_loop import one_r_one_c


def members(k: int, inputs: int = 5, hidden: int = 4, layers: int = 2) -> list[LSTMModel]:
    out = []
    for seed in range(k):
        torch.manual_seed(seed)
        out.append(LSTMModel(inputs, hidden, layers).double())
    return out


@pytest.mark.parametrize("layers", [1, 2, 3])
def test_merged_prediction_is_the_members_mean(layers):
    models = members(3, layers=layers)
    merged = merge_ensemble(models).double()
    assert (merged.hidden_size, merged.num_layers) == (12, layers)
    x = torch.from_numpy(np.random.default_rng(1).uniform(0, 1, (2, 40, 5)))
    with torch.no_grad():
        # teacher forced: every member sees the same inputs, so the mean is exact step by step (state carried)
        mean = torch.stack([rollout(m, x, 6, closed_loop=False) for m in models]).mean(0)
        ours = rollout(merged, x, 6, closed_loop=False)
    np.testing.assert_allclose(ours.numpy(), mean.numpy(), rtol=0, atol=1e-12)


def test_merge_of_one_member_is_the_member():
    (model,) = members(1)
    merged = merge_ensemble([model])
    for name, value in model.state_dict().items():
        torch.testing.assert_close(merged.state_dict()[name], value, rtol=0, atol=0)


def test_members_must_match():
    with pytest.raises(ValueError, match="share"):
        merge_ensemble([LSTMModel(5, 4, 2), LSTMModel(5, 6, 2)])


def test_merged_export_runs_in_the_environment_reader(tmp_path):
    table = one_r_one_c(hours=24 * 20, references=(0, 2, 3))
    inputs = ["outdoor_dry_bulb_temperature", "heating_demand", "hour_sin", "hour_cos",
              "indoor_dry_bulb_temperature"]
    norm = Normalization.fit(feature_matrix(table, inputs))
    models = [m.float() for m in members(3, inputs=len(inputs), hidden=4)]
    merged = merge_ensemble(models)
    config = TrainConfig(inputs=tuple(inputs), lookback=6, hidden_size=12, progress=False)
    trained = Trained(merged, norm, inputs, config, {"train": [], "validation": [], "test": []})
    pth = save_checkpoint(trained, tmp_path / "merged.pth")
    block = dynamics_block(trained, str(pth)).to_schema()
    segment = run_segments(table)[3]
    ours = predict_segment(merged, norm, inputs, 6, table, segment, closed_loop=True)
    hours = bank_rollout(pth, block, table, [segment], dataclasses.replace(CORRECTED, lstm_float32=True))
    np.testing.assert_allclose(hours["predicted"].to_numpy(), ours, atol=1e-4)


def test_trained_ensemble_is_the_mean_of_its_seeded_members():
    table = one_r_one_c(hours=24 * 30, references=(0, 2, 3, 4))
    tiny = TrainConfig(hidden_size=4, epochs=2, pretrain_steps=10, validation_hours=72, progress=False)
    merged = train_surrogate(table, dataclasses.replace(tiny, ensemble=2))
    alone = [train_surrogate(table, dataclasses.replace(tiny, seed=seed)) for seed in (0, 1)]
    assert merged.model.hidden_size == 8
    segment = run_segments(table)[4]
    one_step = [predict_segment(t.model, t.normalization, t.inputs, 6, table, segment, closed_loop=False)
                for t in (merged, *alone)]
    np.testing.assert_allclose(one_step[0], (one_step[1] + one_step[2]) / 2, atol=1e-4)
