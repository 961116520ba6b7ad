"""Adam over one flat buffer: the surrogate's optimiser.

The surrogate has ten small parameter tensors (two LSTM layers of four, the head's two). PyTorch's Adam, even
multi-tensor, pays a fixed cost per tensor and per step (about 1 ms of the ~5 ms of a warm-start update on
one thread of the AMD EPYC); zeroing and clipping the gradients pay it again. :class:`FlatAdam` moves every
parameter into one contiguous buffer (the parameters become views of it; the module, its state dict and its
``torch.lstm`` weights are unchanged to their readers) and gives every gradient a view of a second buffer, so
autograd accumulates into it in place: zeroing, clipping and the Adam update are a handful of operations on
one tensor each.

The update is PyTorch's Adam (no weight decay, no AMSGrad) operation for operation: ``m.lerp_(g, 1 - b1)``;
``v.mul_(b2).addcmul_(g, g, 1 - b2)``; ``p.addcdiv_(m, v.sqrt() / (1 - b2^t)^0.5 + eps, -lr / (1 - b1^t))``,
elementwise on the same float32 values, hence the same bits as ``torch.optim.Adam`` (tested). The clipping
is ``torch.nn.utils.clip_grad_norm_``'s, scale by ``min(1, max_norm / (norm + 1e-6))``, with the norm taken
over the one buffer (equal to the per-tensor norms' norm to float rounding).
"""

from __future__ import annotations

import torch
from torch import nn


class FlatAdam:
    """Adam on ``module``'s parameters, re-homed into one flat float32 buffer (see the module docstring).

    ``lr`` may be changed between steps (the closed-loop phases do). ``betas`` and ``eps`` as in
    :class:`torch.optim.Adam`.
    """

    def __init__(self, module: nn.Module, lr: float, betas: tuple[float, float] = (0.9, 0.999),
                 eps: float = 1e-8):
        parameters = list(module.parameters())
        total = sum(p.numel() for p in parameters)
        self.values = torch.empty(total, dtype=torch.float32)
        self.grads = torch.zeros(total, dtype=torch.float32)
        offset = 0
        with torch.no_grad():
            for p in parameters:
                n = p.numel()
                self.values[offset:offset + n].copy_(p.reshape(-1))
                p.data = self.values[offset:offset + n].view_as(p)
                p.grad = self.grads[offset:offset + n].view_as(p)
                offset += n
        self.lr, self.betas, self.eps = lr, betas, eps
        self.exp_avg = torch.zeros_like(self.values)
        self.exp_avg_sq = torch.zeros_like(self.values)
        self.steps = 0

    def zero_grad(self) -> None:
        """Gradients to zero in place (autograd then accumulates into the views)."""
        self.grads.zero_()

    def clip_grad_norm(self, max_norm: float) -> float:
        """Scale the gradients to a total 2-norm of at most ``max_norm``; returns the norm before."""
        norm = torch.linalg.vector_norm(self.grads)
        self.grads.mul_(torch.clamp(max_norm / (norm + 1e-6), max=1.0))
        return float(norm)

    @torch.no_grad()
    def step(self) -> None:
        """One Adam update of every parameter."""
        self.steps += 1
        beta1, beta2 = self.betas
        self.exp_avg.lerp_(self.grads, 1.0 - beta1)
        self.exp_avg_sq.mul_(beta2).addcmul_(self.grads, self.grads, value=1.0 - beta2)
        step_size = self.lr / (1.0 - beta1 ** self.steps)
        denominator = (self.exp_avg_sq.sqrt() / (1.0 - beta2 ** self.steps) ** 0.5).add_(self.eps)
        self.values.addcdiv_(self.exp_avg, denominator, value=-step_size)
