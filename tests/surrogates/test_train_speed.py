"""The trainer's faster paths compute what the plain formulation computes: the EMA update, the closed-loop
rollout with autograd and without, and the bfloat16-update option (deterministic, float32 export)."""

from __future__ import annotations

from dataclasses import replace

import pytest
import torch

from surrogates.config import TrainConfig
from surrogates.model import LSTMModel, rollout
from surrogates.precision import capability
from surrogates.sources.fmu import simulate_ilv_fmu
from surrogates.train import ema_update, train_surrogate
from tests.surrogates.fmu.build import VARIABLE_MAP, synthetic_house


def test_ema_update_by_hand():
    mean, other = torch.tensor([4.0, -2.0]), torch.tensor([[1.0]])
    ema_update([mean, other], [torch.tensor([8.0, 2.0]), torch.tensor([[3.0]])], 0.75)
    # 0.75 * 4 + 0.25 * 8 = 5; 0.75 * -2 + 0.25 * 2 = -1; 0.75 * 1 + 0.25 * 3 = 1.5 (all exact in binary)
    assert mean.tolist() == [5.0, -1.0] and other.tolist() == [[1.5]]


def stepwise(model: LSTMModel, x: torch.Tensor, lookback: int, closed_loop: bool) -> torch.Tensor:
    """Plain re-statement: per hour, the window of exogenous hours t-L+1..t and temperatures t-L..t-1 through
    the ``nn.LSTM`` module with the carried state, the prediction appended to the history."""
    temps, state, out = [x[:, t, -1] for t in range(lookback)], None, []
    for t in range(lookback, x.shape[1]):
        window = torch.cat([x[:, t - lookback + 1:t + 1, :-1], torch.stack(temps[-lookback:], 1)[..., None]], 2)
        hidden, state = model.l_lstm(window, state)
        y = model.l_linear(hidden[:, -1]).squeeze(-1)
        out.append(y)
        temps.append(y if closed_loop else x[:, t, -1])
    return torch.stack(out, 1)


@pytest.mark.parametrize("closed_loop", [True, False])
def test_rollout_values_and_gradients_match_the_stepwise_loop(closed_loop):
    torch.manual_seed(3)
    model = LSTMModel(5, hidden_size=7, num_layers=2)
    x = torch.rand(4, 20, 5)
    ours, plain = rollout(model, x, 6, closed_loop=closed_loop), stepwise(model, x, 6, closed_loop)
    torch.testing.assert_close(ours, plain, rtol=1e-6, atol=1e-7)
    params = list(model.parameters())
    for a, b in zip(torch.autograd.grad(ours.square().sum(), params), torch.autograd.grad(plain.square().sum(), params),
                    strict=True):
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-7)
    with torch.no_grad():  # the no-autograd path (validation, evaluation) gives the same values
        torch.testing.assert_close(rollout(model, x, 6, closed_loop=closed_loop), plain.detach(), rtol=1e-6,
                                   atol=1e-7)


@pytest.fixture(scope="module")
def table(room_fmu):
    house = synthetic_house(room_fmu, days=21, t_mean=6.0)
    return simulate_ilv_fmu(room_fmu, house, VARIABLE_MAP, n_partial=4, seed=0, start_values={"T0": 22.0})


@pytest.mark.skipif(not capability().native_bf16,
                    reason=f"bfloat16 is emulated on this CPU ({capability().describe()}): its speed and "
                           "rounding there are not the behaviour under test")
def test_bf16_updates_are_deterministic_and_export_float32(table):
    config = TrainConfig(epochs=2, pretrain_steps=20, chunk_hours=24, validation_hours=120, hidden_size=8,
                         progress=False, precision="bfloat16")
    first, again = train_surrogate(table, config), train_surrogate(table, config)
    plain = train_surrogate(table, replace(config, precision="float32"))
    state, state_again, state_plain = (t.model.state_dict() for t in (first, again, plain))
    assert first.precision.precision == "bfloat16" and plain.precision.precision == "float32"
    assert all(torch.equal(v, state_again[k]) for k, v in state.items())
    assert all(v.dtype == torch.float32 for v in state.values())
    assert any(not torch.equal(v, state_plain[k]) for k, v in state.items())  # the option acts
