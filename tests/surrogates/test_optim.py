"""FlatAdam: PyTorch's Adam on one flat buffer, the module unchanged to its readers."""

from __future__ import annotations

import torch

from surrogates.model import LSTMModel
from surrogates.optim import FlatAdam


def _loss(model: LSTMModel, x: torch.Tensor) -> torch.Tensor:
    return model.sequence(x, model.flat_weights()).square().mean()


def test_updates_are_torch_adams_bit_for_bit():
    torch.manual_seed(0)
    ours, theirs = LSTMModel(5, 8, 2), LSTMModel(5, 8, 2)
    theirs.load_state_dict(ours.state_dict())
    flat = FlatAdam(ours, lr=0.02)
    reference = torch.optim.Adam(theirs.parameters(), lr=0.02, foreach=True)
    generator = torch.Generator().manual_seed(1)
    for step in range(30):
        x = torch.rand(4, 12, 5, generator=generator)
        flat.zero_grad()
        _loss(ours, x).backward()
        reference.zero_grad()
        _loss(theirs, x).backward()
        for a, b in zip(ours.parameters(), theirs.parameters(), strict=True):
            assert torch.equal(a.grad, b.grad), step
        flat.step()
        reference.step()
    for (name, a), b in zip(ours.state_dict().items(), theirs.state_dict().values(), strict=True):
        assert torch.equal(a, b), name
        assert a.data_ptr() != b.data_ptr()


def test_parameters_live_in_the_buffer_and_gradients_accumulate_there():
    torch.manual_seed(2)
    model = LSTMModel(3, 4, 1)
    before = {k: v.clone() for k, v in model.state_dict().items()}
    flat = FlatAdam(model, lr=0.1)
    for key, value in model.state_dict().items():  # same values, now views of one buffer
        assert torch.equal(value, before[key])
    assert flat.values.numel() == sum(p.numel() for p in model.parameters())
    x = torch.rand(2, 6, 3)
    _loss(model, x).backward()
    assert flat.grads.abs().sum() > 0
    assert torch.equal(torch.cat([p.grad.reshape(-1) for p in model.parameters()]), flat.grads)
    flat.step()
    assert all(not torch.equal(v, before[k]) for k, v in model.state_dict().items())
    flat.zero_grad()
    assert all(p.grad.abs().sum() == 0 for p in model.parameters())


def test_clipping_is_clip_grad_norm():
    torch.manual_seed(3)
    ours, theirs = LSTMModel(3, 4, 2), LSTMModel(3, 4, 2)
    theirs.load_state_dict(ours.state_dict())
    flat = FlatAdam(ours, lr=0.01)
    x = torch.rand(2, 8, 3) * 50.0  # large inputs: a norm above the 0.1 clipped to
    _loss(ours, x).backward()
    _loss(theirs, x).backward()
    norm = flat.clip_grad_norm(0.1)
    expected = torch.nn.utils.clip_grad_norm_(list(theirs.parameters()), 0.1)
    assert norm > 0.1
    assert abs(norm - float(expected)) < 1e-5 * float(expected)
    for a, b in zip(ours.parameters(), theirs.parameters(), strict=True):
        torch.testing.assert_close(a.grad, b.grad, rtol=1e-5, atol=1e-8)
    assert float(torch.linalg.vector_norm(flat.grads)) < 0.1 + 1e-6
