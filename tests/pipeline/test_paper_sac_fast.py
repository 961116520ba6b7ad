"""The ``fast`` SAC back end: hand-written gradients against autograd's, and its Adam against torch's."""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch")

from pipeline.paper.sac.fast import FastSAC, FusedAdam, ScalarAdam  # noqa: E402
from pipeline.paper.sac.lean import LeanSAC  # noqa: E402
from surrogates.precision import capability  # noqa: E402

OBS, ACT, BATCH = 7, 3, 256
#: the bfloat16 path runs only where the CPU multiplies bfloat16 natively (surrogates.precision); elsewhere
#: its products are emulated, seconds per update, and that path is not what the defaults run
native_bf16 = pytest.mark.skipif(
    not capability().native_bf16,
    reason=f"bfloat16 is emulated on this CPU ({capability().describe()}): the defaults run float32 here")


def _batch(seed: int = 5):
    g = torch.Generator().manual_seed(seed)
    return (torch.randn(BATCH, OBS, generator=g), torch.rand(BATCH, ACT, generator=g) * 2 - 1,
            torch.randn(BATCH, 1, generator=g), torch.randn(BATCH, OBS, generator=g),
            (torch.rand(BATCH, 1, generator=g) < 0.1).float())


def _relative(reference, other) -> float:
    return float((reference - other).abs().max() / reference.abs().max())


def test_float32_gradients_equal_autograd():
    """Same seed, same batch: every gradient of three successive updates equals the one autograd computes for
    LeanSAC (float32; the residual is summation order, ~1e-6 of the largest entry)."""
    lean, fast = LeanSAC(OBS, ACT, seed=3), FastSAC(OBS, ACT, seed=3, bf16=False)
    batch = _batch()
    for _ in range(3):
        lean.train_step(*batch)
        fast.train_step(*batch)
        for p, g in zip(lean.actor + lean.critic, fast.actor_adam.last_grads + fast.critic_adam.last_grads,
                        strict=True):
            if p.grad.abs().max() > 0:
                assert _relative(p.grad, g) < 1e-5
        assert fast.ent_adam.last_grad == pytest.approx(float(lean.log_ent_coef.grad), rel=1e-6)
    for p, q in zip(lean.actor + lean.critic + lean.critic_target, fast.actor + fast.critic + fast.critic_target,
                    strict=True):
        assert float((p.detach() - q).abs().max()) < 1e-4  # three Adam steps of at most lr = 3e-4 each


@native_bf16
def test_bfloat16_gradients_close_to_float32():
    """bfloat16 products (8-bit mantissa, relative rounding 2^-9 per operand) keep each gradient within a few
    percent of the float32 one."""
    lean, fast = LeanSAC(OBS, ACT, seed=1), FastSAC(OBS, ACT, seed=1, bf16=True)
    batch = _batch(7)
    lean.train_step(*batch)
    fast.train_step(*batch)
    for p, g in zip(lean.actor + lean.critic[:4], fast.actor_adam.last_grads + fast.critic_adam.last_grads[:4],
                    strict=True):
        assert float((p.grad - g).norm() / p.grad.norm()) < 0.05


def test_fused_adam_equals_torch_adam():
    g = torch.Generator().manual_seed(0)
    params = [torch.randn(5, 4, generator=g), torch.randn(3, generator=g)]
    reference = [p.clone().requires_grad_(True) for p in params]
    optimiser = torch.optim.Adam(reference, lr=1e-2)
    fused = FusedAdam(params, lr=1e-2)
    for _ in range(5):
        grads = [torch.randn(p.shape, generator=g) for p in params]
        for p, grad in zip(reference, grads, strict=True):
            p.grad = grad.clone()
        optimiser.step()
        fused.step(grads)
    for p, q in zip(reference, params, strict=True):
        assert torch.allclose(p.detach(), q, atol=1e-6)


def test_scalar_adam_equals_torch_adam():
    reference = torch.zeros(1, requires_grad=True)
    optimiser = torch.optim.Adam([reference], lr=3e-4)
    scalar = ScalarAdam(0.0, lr=3e-4)
    for grad in (5.0, -2.0, 0.5, 3.0, -1e-3):
        reference.grad = torch.tensor([grad])
        optimiser.step()
        scalar.step(grad)
    assert scalar.value == pytest.approx(float(reference.detach()), abs=1e-8)


def test_numpy_rollout_draw_equals_torch_draw():
    """FastSAC's NumPy exploration draw equals LeanSAC's torch draw for the same weights and generator state
    (float32 rounding apart), and stays in step with the weights after an update."""
    import numpy as np

    lean, fast = LeanSAC(OBS, ACT, seed=2), FastSAC(OBS, ACT, seed=2, bf16=False)
    obs = np.linspace(-1.0, 1.0, OBS)
    for _ in range(3):
        assert np.allclose(fast.explore(obs), lean.explore(obs), atol=1e-5)
    batch = _batch(3)
    lean.train_step(*batch)
    fast.train_step(*batch)
    assert np.allclose(fast.explore(obs), lean.explore(obs), atol=1e-4)


def test_subnormals_flushed_only_while_training():
    """Training flushes subnormal floats to zero (a process-wide CPU flag) and gives the flag back: code that
    runs after it (hypothesis, NumPy) sees IEEE subnormals again."""
    from pipeline.paper.sac.train import flushed_subnormals

    tiny = torch.tensor([1e-40], dtype=torch.float32)  # below float32's smallest normal, 1.18e-38
    assert float(tiny * 1.0) > 0
    with flushed_subnormals():
        assert float(tiny * 1.0) == 0.0
    assert float(tiny * 1.0) > 0


@native_bf16
def test_bfloat16_relu_through_int16_view_equals_torch():
    """The int16-view ReLU and its gradient give torch's bfloat16 results, on the values where a sign-bit
    trick could go wrong: -0.0, the smallest subnormals of both signs, +-inf and ordinary values. The one
    difference is the sign of zero: torch keeps -0.0, the clamp gives +0.0 (equal as numbers)."""
    from pipeline.paper.sac.fast import relu_, relu_backward

    tiny = 2.0 ** -133  # the smallest positive bfloat16 subnormal
    special = torch.tensor([-0.0, 0.0, tiny, -tiny, 1e-38, -1e-38, float("inf"), -float("inf"), 3.5, -3.5])
    values = torch.cat([special, torch.randn(4000, generator=torch.Generator().manual_seed(1))]).to(torch.bfloat16)
    ours = relu_(values.clone())
    expected = values.relu()
    assert torch.equal(ours, expected)
    assert int(ours.view(torch.int16).min()) >= 0  # no sign bit left, -0.0 included
    grad = torch.randn(values.shape, generator=torch.Generator().manual_seed(2)).to(torch.bfloat16)
    reference = torch.ops.aten.threshold_backward(grad, expected, 0)
    assert torch.equal(relu_backward(grad.clone(), ours), reference)


def test_numba_kernels_equal_torch_kernels():
    """The fused element-wise steps (numba, where installed) and their torch operations give the same
    updates to float32 rounding: both back ends' parameters after five updates, and every gradient."""
    pytest.importorskip("numba")
    fused, plain = FastSAC(OBS, ACT, seed=4, numba=True), FastSAC(OBS, ACT, seed=4, numba=False)
    assert type(fused.kernels).__name__ == "NumbaKernels" and type(plain.kernels).__name__ == "TorchKernels"
    batch = _batch(9)
    for _ in range(5):
        fused.train_step(*batch)
        plain.train_step(*batch)
        for a, b in zip(fused.actor_adam.last_grads + fused.critic_adam.last_grads,
                        plain.actor_adam.last_grads + plain.critic_adam.last_grads, strict=True):
            if b.abs().max() > 0:
                assert _relative(b, a) < 1e-5
    for p, q in zip(fused.actor + fused.critic + fused.critic_target, plain.actor + plain.critic + plain.critic_target,
                    strict=True):
        assert float((p - q).abs().max()) < 1e-5
