"""SB3's SAC update with hand-written gradients: the ``fast`` back end of :mod:`pipeline.paper.sac.train`.

:class:`FastSAC` runs exactly the update of :class:`pipeline.paper.sac.lean.LeanSAC` (the same parameters, random
draws, losses and Adam steps; :mod:`pipeline.paper.sac.train` lists the stable-baselines3 defaults reproduced)
without autograd: every gradient is written out below, so one update is ~25 matrix products and a few dozen
element-wise operations instead of a recorded graph. With ``bf16=True`` (where
:func:`pipeline.paper.sac.train.sac_precision` chooses bfloat16) the matrix products take bfloat16 operands, while
parameters, Adam state, losses and every element-wise step stay float32; weights are rounded to bfloat16 once
per update, not per product.

Shapes: B batch rows, D observation size, A action size, H = 256 hidden units, K = 2 critics (one stacked
ensemble). ``tests/pipeline/test_paper_sac_fast.py`` checks the float32 gradients against autograd's.

Gradients, for the losses of ``LeanSAC.train_step`` (per row b; sums run over the action dimensions):

* entropy coefficient: d/d log(alpha) of -mean(log(alpha) (log pi + target)) is -mean(log pi + target);
* critics: L = 1/2 sum_k mean_b (Q_k - y)^2, so dL/dQ_k = (Q_k - y) / B, then back through each MLP;
* actor: L = mean_b(alpha log pi - min_k Q_k(s, a)), a = tanh(u), u = mu + sigma eps, sigma = exp(s):
  dL/da = -[k is the minimum] dQ_k/da / B + (alpha / B) 2a / (1 - a^2 + 1e-6) (the squashing correction),
  dL/du = dL/da (1 - a^2), dL/dmu = dL/du, dL/ds = dL/du sigma eps - alpha / B where s is inside its clamp
  [-20, 2] (else 0) -- the Gaussian term -eps^2/2 does not depend on mu or s once u is reparameterised.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.paper.sac.lean import (
    GAMMA,
    LEARNING_RATE,
    LOG_STD_MAX,
    LOG_STD_MIN,
    SQUASH_EPSILON,
    TAU,
    LeanSAC,
    squashed_gaussian,
)

#: torch.optim.Adam's defaults (SB3 leaves them)
BETA1, BETA2, ADAM_EPS = 0.9, 0.999, 1e-8


def relu_(x):
    """ReLU in place. A bfloat16 tensor is clamped through its int16 view: a set sign bit makes the int16
    negative, so clamping at 0 zeroes exactly the negative values (and -0.0) without the float conversion
    torch's bfloat16 element-wise kernels make (~4x faster here)."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    if x.dtype == torch.bfloat16:
        x.view(torch.int16).clamp_min_(0)
        return x
    return x.relu_()


def relu_backward(grad, activation):
    """``grad`` where the ReLU output ``activation`` (>= 0) is positive, else 0. A bfloat16 ``grad`` is
    overwritten: an in-place integer product of its int16 view with ``min(bits, 1)`` of the activation's
    (1 exactly where the activation is positive)."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    if grad.dtype == torch.bfloat16:
        grad.view(torch.int16).mul_(activation.view(torch.int16).clamp_max(1))
        return grad
    return torch.ops.aten.threshold_backward(grad, activation, 0)


class FusedAdam:
    """torch's Adam with its defaults on float32 tensors, as one fused kernel per step: torch.optim.Adam
    (fused=True) without its per-call bookkeeping. ``step(grads)`` takes the gradients in parameter order
    (kept as ``last_grads`` for inspection)."""

    def __init__(self, params, lr: float = LEARNING_RATE):
        import torch  # torch: the CLI imports this module; torch loads on first use

        self.torch, self.params, self.lr = torch, list(params), lr
        self.exp_avg = [torch.zeros_like(p) for p in self.params]
        self.exp_avg_sq = [torch.zeros_like(p) for p in self.params]
        self.count = torch.zeros((), dtype=torch.float32)

    def step(self, grads) -> None:
        torch = self.torch
        self.count.add_(1)
        self.last_grads = grads = [g.float().contiguous() for g in grads]
        torch._fused_adam_(self.params, grads, self.exp_avg, self.exp_avg_sq, [], [self.count] * len(grads),
                           lr=self.lr, beta1=BETA1, beta2=BETA2, weight_decay=0.0, eps=ADAM_EPS, amsgrad=False,
                           maximize=False)


class ScalarAdam:
    """The same Adam for one scalar parameter, in Python floats (the entropy coefficient's logarithm)."""

    def __init__(self, value: float, lr: float = LEARNING_RATE):
        self.value, self.lr, self.m, self.v, self.t = value, lr, 0.0, 0.0, 0

    def step(self, grad: float) -> float:
        self.last_grad = grad
        self.t += 1
        self.m = BETA1 * self.m + (1 - BETA1) * grad
        self.v = BETA2 * self.v + (1 - BETA2) * grad * grad
        denom = math.sqrt(self.v) / math.sqrt(1 - BETA2 ** self.t) + ADAM_EPS
        self.value -= self.lr / (1 - BETA1 ** self.t) * self.m / denom
        return self.value


class FastSAC(LeanSAC):
    """:class:`LeanSAC` with hand-written gradients (see the module docstring); same constructor."""

    def __init__(self, obs_dim: int, act_dim: int, *, seed: int = 0, bf16: bool = False, threads: int = 1):
        super().__init__(obs_dim, act_dim, seed=seed, bf16=bf16, threads=threads)
        torch = self.torch
        self.dtype = torch.bfloat16 if bf16 else torch.float32
        self.numpy_actor = [p.numpy() for p in self.actor]  # views: Adam's in-place updates show through
        # bfloat16 copies of the target critics (members 0, 1) and the critics (members 2, 3) in one stack, so
        # the target and current critics run as one batched product per layer. The first layer's weight and
        # bias share one (in + 1, H) matrix (`*_first`), the inputs carrying a trailing column of ones: one
        # product instead of a product plus a broadcast bias, and the bias gradient comes out of the weight
        # gradient's product.
        self.stack_first, self.stack_lp = _low_precision([torch.cat([t, c]) for t, c in zip(
            self.critic_target, self.critic, strict=True)], self.dtype)
        self.target_lp = [p[:2] for p in self.stack_lp]
        self.critic_lp = [p[2:] for p in self.stack_lp]
        self.critic_first = self.stack_first[2:]
        self.actor_first, self.actor_lp = _low_precision(self.actor, self.dtype)

    def _make_optimizers(self) -> None:
        """No autograd: parameters are plain tensors, stepped by one fused Adam call per network and a float
        Adam for the entropy coefficient."""
        for p in (*self.actor, *self.critic, self.log_ent_coef):
            p.requires_grad_(False)
        self.actor_adam, self.critic_adam = FusedAdam(self.actor), FusedAdam(self.critic)
        self.ent_adam = ScalarAdam(float(self.log_ent_coef))

    # ------------------------------------------------------------------ low-precision copies of the weights
    def _cast_actor(self) -> None:
        self.torch._foreach_copy_(self.actor_lp, self.actor)

    def _cast_critic(self) -> None:
        self.torch._foreach_copy_(self.critic_lp, self.critic)

    def _cast_target(self) -> None:
        self.torch._foreach_copy_(self.target_lp, self.critic_target)

    # ------------------------------------------------------------------ networks
    def _actor_forward(self, obs):
        """Actor MLP on (N, D) float32 observations: (out (N, 2A) float32, saved activations)."""
        torch = self.torch
        _, _, w2, b2, w3, b3 = self.actor_lp
        x = _with_ones(obs).to(self.dtype)
        h1 = relu_(torch.mm(x, self.actor_first))
        h2 = relu_(torch.addmm(b2, h1, w2))
        return _thin(torch.addmm(b3.t(), w3.t(), h2.t())).float(), (x, h1, h2)

    def _actor_params(self, obs):
        """Mean and clamped log-std for acting (a few rows): float32 weights, where bfloat16 products of a
        single row are slower, not faster."""
        torch = self.torch
        w1, b1, w2, b2, w3, b3 = self.actor
        h = torch.addmm(b1, obs, w1).relu_()
        out = torch.addmm(b3, torch.addmm(b2, h, w2).relu_(), w3)
        return out[:, :self.act_dim], out[:, self.act_dim:].clamp(LOG_STD_MIN, LOG_STD_MAX)

    def explore(self, obs):
        """LeanSAC's rollout draw for one observation in NumPy on the float32 weights (shared memory, no copy):
        a batch of one costs more in torch's dispatch than in its arithmetic. Same noise draw, same stream."""

        w1, b1, w2, b2, w3, b3 = self.numpy_actor
        h = np.maximum(np.asarray(obs, dtype=np.float32) @ w1 + b1[0], 0.0)
        out = np.maximum(h @ w2 + b2[0], 0.0) @ w3 + b3[0]
        log_std = np.clip(out[self.act_dim:], LOG_STD_MIN, LOG_STD_MAX)
        noise = self.torch.randn((1, self.act_dim), generator=self.generator).numpy()[0]
        return np.tanh(out[:self.act_dim] + np.exp(log_std) * noise)

    def _squash(self, out, noise):
        """Squashed Gaussian sample from actor outputs (N, 2A) and noise (N, A): action, log-prob (N,),
        and what the actor gradient needs."""
        raw_log_std = out[:, self.act_dim:]
        log_std = raw_log_std.clamp(LOG_STD_MIN, LOG_STD_MAX)
        action, log_prob, std, one_minus_a2 = squashed_gaussian(out[:, :self.act_dim], log_std, noise)
        inside = (raw_log_std >= LOG_STD_MIN) & (raw_log_std <= LOG_STD_MAX)
        return action, log_prob, (std, one_minus_a2, inside)

    def _critic_input(self, obs, action, members: int = 2):
        """(s, a, 1) rows as the critics' input, repeated for ``members`` stacked critics:
        (members, B, D + A + 1)."""
        return _with_ones(self.torch.cat([obs, action], dim=1)).to(self.dtype).expand(members, -1, -1)

    def _critic_forward(self, params, first, z):
        """The stacked critics (``params``, first layer ``first``) on their inputs ``z`` (members, B, D + A + 1):
        (Q (members, B, 1) float32, saved activations)."""
        torch = self.torch
        _, _, v2, c2, v3, c3 = params
        g1 = relu_(torch.bmm(z, first))
        g2 = relu_(torch.baddbmm(c2, g1, v2))
        return _thin(torch.baddbmm(c3, v3.transpose(1, 2), g2.transpose(1, 2))).float(), (z, g1, g2)

    def _critic_backward(self, dq, saved, *, weights: bool):
        """Back through both critics from dL/dQ (K, B, 1): weight gradients (``weights``) or dL/d(action)."""
        torch = self.torch
        z, g1, g2 = saved
        _, _, v2, _, v3, _ = self.critic_lp
        dq_lp = dq.to(self.dtype)
        dg2 = relu_backward(dq_lp * v3.transpose(1, 2), g2)  # (K, B, 1) x (K, 1, H): an outer product
        dg1 = relu_backward(torch.bmm(dg2, v2.transpose(1, 2)), g1)
        if not weights:
            action_rows = self.critic_first[:, self.obs_dim:self.obs_dim + self.act_dim]
            return _thin(torch.bmm(action_rows, dg1.transpose(1, 2))).float().sum(0)
        first = torch.bmm(z.transpose(1, 2), dg1)  # weight rows, then the bias row (the ones column)
        return [first[:, :-1], first[:, -1:],
                torch.bmm(g1.transpose(1, 2), dg2), dg2.sum(1, keepdim=True),
                _thin(torch.bmm(dq_lp.transpose(1, 2), g2)), dq.sum(1, keepdim=True)]

    def _actor_backward(self, dout, saved):
        """Weight gradients of the actor MLP from dL/d(out) (B, 2A) float32 and the saved activations."""
        torch = self.torch
        x, h1, h2 = saved
        _, _, w2, _, w3, _ = self.actor_lp
        dout_lp = dout.to(self.dtype)
        dh2 = relu_backward(torch.mm(dout_lp, w3.t()), h2)
        dh1 = relu_backward(torch.mm(dh2, w2.t()), h1)
        first = torch.mm(x.t(), dh1)
        return [first[:-1], first[-1:], torch.mm(h1.t(), dh2), dh2.sum(0, keepdim=True),
                _thin(torch.mm(dout_lp.t(), h2)), dout.sum(0, keepdim=True)]

    # ------------------------------------------------------------------ update
    def train_step(self, obs, action, reward, next_obs, done) -> None:
        """One SB3 SAC gradient step on a batch (float32 tensors; reward and done shaped (batch, 1))."""
        torch = self.torch
        with torch.no_grad():
            batch = obs.shape[0]
            # actor on s and s' in one pass; noise drawn in LeanSAC's order (s first, then s')
            out, saved = self._actor_forward(torch.cat([obs, next_obs]))
            noise = torch.randn((batch, self.act_dim), generator=self.generator)
            action_pi, log_prob, (std, one_minus_a2, inside) = self._squash(out[:batch], noise)
            # entropy coefficient (read before its own update, as SB3 does)
            ent_coef = math.exp(self.ent_adam.value)
            self.log_ent_coef.fill_(self.ent_adam.step(-float((log_prob + self.target_entropy).mean())))
            # critic target and update
            next_noise = torch.randn((batch, self.act_dim), generator=self.generator)
            next_action, next_log_prob, _ = self._squash(out[batch:], next_noise)
            # target critics on (s', a') and critics on (s, a): one pass over the stacked members
            z = torch.cat([self._critic_input(next_obs, next_action), self._critic_input(obs, action)])
            q_all, saved_all = self._critic_forward(self.stack_lp, self.stack_first, z)
            next_q = q_all[:2].min(dim=0).values
            target = reward + (1.0 - done) * GAMMA * (next_q - ent_coef * next_log_prob.unsqueeze(1))
            q, critic_saved = q_all[2:], tuple(t[2:] for t in saved_all)
            self.critic_adam.step(self._critic_backward((q - target) / batch, critic_saved, weights=True))
            self._cast_critic()
            # actor update against the updated critics
            q_pi, pi_saved = self._critic_forward(self.critic_lp, self.critic_first,
                                                 self._critic_input(obs, action_pi))
            lowest = (q_pi == q_pi.min(dim=0, keepdim=True).values).float()  # (K, B, 1): the minimum's member
            d_action = self._critic_backward(lowest * (-1.0 / batch), pi_saved, weights=False)
            d_action = d_action + (ent_coef / batch) * 2 * action_pi / (one_minus_a2 + SQUASH_EPSILON)
            d_u = d_action * one_minus_a2
            d_log_std = (d_u * std * noise - ent_coef / batch) * inside
            actor_saved = tuple(t[:batch] for t in saved)
            self.actor_adam.step(self._actor_backward(torch.cat([d_u, d_log_std], dim=1), actor_saved))
            self._cast_actor()
            torch._foreach_lerp_(self.critic_target, self.critic, TAU)
            self._cast_target()


def _thin(product):
    """The transpose (a view) of a product computed transposed. A product with a thin right operand (1 or
    2A columns: the output layers, their weight gradients, the gradient by the action) runs several times
    slower in the BLAS than its transpose (a few rows times a wide matrix): ``(A B)^T = B^T A^T``, so those
    are computed as ``B^T A^T`` and read through this view (measured on ``(256, 256) x (256, 1)``: 4-10x
    faster; benchmarks/README.md)."""
    return product.transpose(-2, -1)


def _with_ones(x):
    """``x`` (..., N, F) with a trailing column of ones: (..., N, F + 1)."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    return torch.cat([x, x.new_ones((*x.shape[:-1], 1))], dim=-1)


def _low_precision(params, dtype):
    """``dtype`` copies of an MLP's float32 parameters [w1 (.., in, H), b1 (.., 1, H), w2, b2, w3, b3]:
    ``first``, the first layer's weight with its bias as a last row (.., in + 1, H), and six tensors shaped
    like ``params`` (the first two are views into ``first``), to refresh with ``torch._foreach_copy_``."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    first = torch.cat(params[:2], dim=-2).to(dtype)
    return first, [first[..., :-1, :], first[..., -1:, :], *(p.to(dtype) for p in params[2:])]
