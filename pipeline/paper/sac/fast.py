"""SB3's SAC update with hand-written gradients: the ``fast`` back end of :mod:`pipeline.paper.sac.train`.

:class:`FastSAC` runs exactly the update of :class:`pipeline.paper.sac.lean.LeanSAC` (the same parameters, random
draws, losses and Adam steps; :mod:`pipeline.paper.sac.train` lists the stable-baselines3 defaults reproduced)
without autograd: every gradient is written out below, so one update is ~25 matrix products, two fused Adam
steps and a dozen one-pass element-wise loops (:mod:`pipeline.paper.sac.kernels`: numba where installed, else
torch operations) instead of a recorded graph; parameters live in merged float32 tensors (no copies), and every
buffer and view is made once. With ``bf16=True`` (where
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

import functools
import math

import numpy as np

from pipeline.paper.sac.kernels import kernels, relu_, relu_backward
from pipeline.paper.sac.lean import BATCH_SIZE, HIDDEN, LEARNING_RATE, LOG_STD_MAX, LOG_STD_MIN, TAU, LeanSAC

__all__ = ["FastSAC", "FusedAdam", "ScalarAdam", "relu_", "relu_backward"]

#: torch.optim.Adam's defaults (SB3 leaves them)
BETA1, BETA2, ADAM_EPS = 0.9, 0.999, 1e-8


class FusedAdam:
    """torch's Adam with its defaults on float32 tensors, as one fused kernel per step: torch.optim.Adam
    (fused=True) without its per-call bookkeeping. ``step(grads)`` takes the gradients in parameter order
    (``last_grads`` shows the last ones; with ``merged_first``, the first parameter is a first layer's weight
    with its bias as last row, and ``last_grads`` shows its gradient split back into weight and bias)."""

    def __init__(self, params, lr: float = LEARNING_RATE, *, merged_first: bool = False):
        import torch  # torch: the CLI imports this module; torch loads on first use

        self.torch, self.params, self.lr, self.merged_first = torch, list(params), lr, merged_first
        self.exp_avg = [torch.zeros_like(p) for p in self.params]
        self.exp_avg_sq = [torch.zeros_like(p) for p in self.params]
        self.count = torch.zeros((), dtype=torch.float32)

    def step(self, grads) -> None:
        torch = self.torch
        self.count.add_(1)
        self.grads = grads = [g.float().contiguous() for g in grads]
        torch._fused_adam_(self.params, grads, self.exp_avg, self.exp_avg_sq, [], [self.count] * len(grads),
                           lr=self.lr, beta1=BETA1, beta2=BETA2, weight_decay=0.0, eps=ADAM_EPS, amsgrad=False,
                           maximize=False)

    @property
    def last_grads(self) -> list:
        """The last step's gradients, the merged first layer's split into weight and bias rows."""
        if not self.merged_first:
            return self.grads
        return [self.grads[0][..., :-1, :], self.grads[0][..., -1:, :], *self.grads[1:]]


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
    """:class:`LeanSAC` with hand-written gradients (see the module docstring); same constructor, plus
    ``numba``: fuse the element-wise steps with numba where it is installed (:mod:`pipeline.paper.sac.kernels`;
    False: torch operations, the same results to float32 rounding)."""

    def __init__(self, obs_dim: int, act_dim: int, *, seed: int = 0, bf16: bool = False, threads: int = 1,
                 numba: bool = True):
        super().__init__(obs_dim, act_dim, seed=seed, bf16=bf16, threads=threads)
        torch = self.torch
        self.dtype = torch.bfloat16 if bf16 else torch.float32
        self.kernels = kernels(prefer_numba=numba)
        # float32 parameters re-homed, values unchanged: each first layer's weight and bias as one (in + 1, H)
        # matrix (inputs carry a trailing column of ones: one product, and the bias gradient comes out of the
        # weight gradient's), and the target critics (members 0, 1) stacked with the critics (2, 3), so both
        # run as one batched product per layer. actor, critic and critic_target are views into these.
        self.actor_params = _merged_first(self.actor)
        self.stack = [torch.cat([t, c]) for t, c in zip(_merged_first(self.critic_target),
                                                          _merged_first(self.critic), strict=True)]
        self.actor = _split_first(self.actor_params)
        self.critic = _split_first([p[2:] for p in self.stack])
        self.critic_target = _split_first([p[:2] for p in self.stack])
        self.numpy_actor = [p.numpy() for p in self.actor]  # views: Adam's in-place updates show through
        self.actor_adam = FusedAdam(self.actor_params, merged_first=True)
        self.critic_params, self.target_params = [p[2:] for p in self.stack], [p[:2] for p in self.stack]
        self.critic_adam = FusedAdam(self.critic_params, merged_first=True)
        self.ent_adam = ScalarAdam(float(self.log_ent_coef))
        # the products' operands: the float32 parameters themselves, or bfloat16 copies refreshed after each
        # Adam step (rounded once per update, not per product)
        self.actor_lp = self._low_precision(self.actor_params)
        self.stack_lp = self._low_precision(self.stack)
        self.critic_lp, self.target_lp = [p[2:] for p in self.stack_lp], [p[:2] for p in self.stack_lp]
        self._buffers(obs_dim, act_dim)

    def _make_optimizers(self) -> None:
        """No autograd: parameters are plain tensors, stepped by one fused Adam call per network (made in
        ``__init__`` once the parameters are re-homed) and a float Adam for the entropy coefficient."""
        for p in (*self.actor, *self.critic, self.log_ent_coef):
            p.requires_grad_(False)

    def _low_precision(self, params: list) -> list:
        """``params`` themselves in float32, else their copies in the products' dtype."""
        return params if self.dtype == self.torch.float32 else [p.to(self.dtype) for p in params]

    def _refresh(self, low: list, params: list) -> None:
        """Copy ``params`` into their low-precision copies ``low`` (nothing in float32, where they are the
        same tensors)."""
        if self.dtype != self.torch.float32:
            self.torch._foreach_copy_(low, params)

    def _buffers(self, obs_dim: int, act_dim: int, batch: int = BATCH_SIZE) -> None:
        """Every intermediate of an update, allocated once (products write into them with ``out=``), and
        every view the update takes of them and of the parameters, taken once: ``lp`` tensors are in the
        products' dtype, the rest float32. K = 2 critics, Z = D + A + 1."""
        torch, lp, f32 = self.torch, self.dtype, self.torch.float32
        hidden, z_dim = HIDDEN, obs_dim + act_dim + 1
        e, f = functools.partial(torch.empty, dtype=lp), functools.partial(torch.empty, dtype=f32)

        def ones_column(*shape):
            t = torch.zeros(shape, dtype=lp)
            t[..., -1] = 1.0
            return t

        self.batch = batch
        # inputs: x (2B, D + 1) = [s; s'] | 1 for the actor; z (4, B, Z) = (s', a') for the target critics and
        # (s, a) for the critics | 1; zpi (B, Z) = (s, a~pi(s)) | 1
        self.x, self.z, self.zpi = ones_column(2 * batch, obs_dim + 1), ones_column(4, batch, z_dim), \
            ones_column(batch, z_dim)
        self.h1, self.h2 = e(2 * batch, hidden), e(2 * batch, hidden)  # actor activations on [s; s']
        self.out_t = e(2 * act_dim, 2 * batch)  # actor outputs (mean, log-std), transposed
        self.g1, self.g2, self.q_t = e(4, batch, hidden), e(4, batch, hidden), e(4, 1, batch)  # stacked critics
        # the critics on a~pi(s) reuse the target critics' activations (dead once their Q is read), and the
        # actor's backward one critic's gradients: a smaller working set (caches)
        self.g1pi, self.g2pi, self.qpi_t = self.g1[:2], self.g2[:2], e(2, 1, batch)
        self.dg1, self.dg2 = e(2, batch, hidden), e(2, batch, hidden)  # dL/d(critic activations)
        self.dh1, self.dh2 = self.dg1[0], self.dg2[0]  # dL/d(actor activations)
        self.da_t = e(2, act_dim, batch)  # dQ_k/da, transposed
        self.rows = {name: f(batch, act_dim) for name in ("action", "std", "om", "inside")}
        self.rows["next_logp"] = f(batch)
        self.dq, self.dq_pi, self.dout = f(2, batch, 1), f(2, batch, 1), f(batch, 2 * act_dim)
        self.dq_lp, self.dq_pi_lp, self.dout_lp = (t if lp == f32 else e(*t.shape) for t in
                                                   (self.dq, self.dq_pi, self.dout))
        # gradients in the parameters' order (first layer merged): products' in their dtype, sums in float32;
        # the output layers' weight gradients computed transposed
        self.critic_grads = [e(2, z_dim, hidden), e(2, hidden, hidden), f(2, 1, hidden), e(2, 1, hidden),
                             f(2, 1, 1)]
        self.actor_grads = [e(obs_dim + 1, hidden), e(hidden, hidden), f(1, hidden), e(2 * act_dim, hidden),
                            f(1, 2 * act_dim)]
        self.col_scratch = f(2, 1, hidden)
        self._views()
        self.kernels.register(self.x, self.z, self.zpi, self.h1, self.h2, self.out_t, self.g1, self.g2, self.q_t,
                              self.g1pi, self.g2pi, self.qpi_t, self.dg1, self.dg2, self.dh1, self.dh2, self.da_t,
                              *self.rows.values(), self.dq, self.dq_pi, self.dout, *self.critic_grads,
                              *self.actor_grads, self.col_scratch, self.g1c, self.g2c, self.h1s, self.h2s,
                              self.dq_lp, self.dq_pi_lp, self.dout_lp,
                              *(() if self.actor_w3_t is None else (self.actor_w3_t,)))

    def _views(self) -> None:
        """The views one update takes (of parameters, which Adam updates in place, and of buffers), taken once:
        a view costs microseconds of dispatch, and an update takes dozens."""
        b = self.batch
        first, w2, b2, w3, b3 = self.actor_lp
        # float32: the actor's output weight as a contiguous (2A, H) copy, refreshed at each update's start; the
        # BLAS runs the product with the strided view w3^T 6x slower (101 against 16 us on AVX-512)
        self.actor_w3_t = w3.t().contiguous() if self.dtype == self.torch.float32 else None
        self.actor_ops = (first, w2, b2, w3.t() if self.actor_w3_t is None else self.actor_w3_t, b3.t(), w2.t())
        self.stack_ops = _network_views(self.stack_lp)
        self.critic_ops = _network_views(self.critic_lp)
        self.action_rows = self.critic_lp[0][:, self.obs_dim:self.obs_dim + self.act_dim]  # (2, A, H)
        self.g1c, self.g2c, self.zc = self.g1[2:], self.g2[2:], self.z[2:]  # the critics' members of the stack
        self.zpi2 = self.zpi.expand(2, -1, -1)
        self.xs, self.h1s, self.h2s = self.x[:b], self.h1[:b], self.h2[:b]  # actor rows on s
        self.t = {name: getattr(self, name).transpose(-2, -1) for name in (
            "h2", "g2", "g2pi", "zc", "g1c", "dq_lp", "dg1", "xs", "h1s", "dout_lp")}
        # float32: each member's output product on its own (K addmm are 2.5-4x faster than one baddbmm of
        # (1, H) x (H, B) members; bfloat16 the other way round), views taken once
        self.stack_q, self.critic_q = (None if self.dtype != self.torch.float32 else tuple(
            (ops[4][k], ops[3][k], g2_t[k], q_t[k]) for k in range(q_t.shape[0]))
            for ops, g2_t, q_t in ((self.stack_ops, self.t["g2"], self.q_t),
                                   (self.critic_ops, self.t["g2pi"], self.qpi_t)))
        cg, ag = self.critic_grads, self.actor_grads
        self.critic_step = [*cg[:3], cg[3].transpose(1, 2), cg[4]]
        self.actor_step = [*ag[:3], ag[3].t(), ag[4]]

    # ------------------------------------------------------------------ networks
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

    def _critics_forward(self, ops: tuple, z, g1, g2, g2_t, q_t, members: tuple | None) -> None:
        """Stacked critics (``ops`` of :func:`_network_views`) on inputs z (K, B, Z): hidden activations into
        g1, g2 (K, B, H) (g2_t: g2's transposed view), Q transposed into q_t (K, 1, B): a product with a
        thin right operand (1 or 2A columns: the output layers, their weight gradients, the gradient by the
        action) runs several times slower in the BLAS than its transpose, so those run transposed
        ((A B)^T = B^T A^T; measured on (256, 256) x (256, 1): 4-10x faster; benchmarks/README.md). ``members``:
        the output product's per-member views (float32), else one batched product."""
        first, w2, b2, w3_t, b3, _ = ops
        self.torch.bmm(z, first, out=g1)
        relu_(g1)
        self.kernels.linear_relu(g1, w2, b2, g2)
        if members is None:
            self.torch.baddbmm(b3, w3_t, g2_t, out=q_t)
        else:
            for bias, weight, activation, q in members:
                self.torch.addmm(bias, weight, activation, out=q)

    def _critics_backward(self, dq, g1, g2, col_sum) -> None:
        """From dL/dQ (K, B, 1) in the products' dtype back through the critics to their first hidden layer:
        dg2, dg1 (K, B, H); the second hidden layer's bias gradient into col_sum (K, 1, H) float32."""
        _, _, _, w3_t, _, w2_t = self.critic_ops
        self.kernels.outer_mask(dq, w3_t, g2, self.dg2, col_sum)
        self.torch.bmm(self.dg2, w2_t, out=self.dg1)
        self.kernels.mask_(self.dg1, g1)

    # ------------------------------------------------------------------ update
    def train_step(self, obs, action, reward, next_obs, done) -> None:
        """One SB3 SAC gradient step on a batch (float32 tensors; reward and done shaped (batch, 1))."""
        torch, k, t = self.torch, self.kernels, self.t
        batch = obs.shape[0]
        if batch != self.batch:
            self._buffers(self.obs_dim, self.act_dim, batch)
        if self.actor_w3_t is not None:
            self.actor_w3_t.copy_(self.actor_lp[3].t())
        # actor on s and s' in one pass (2B rows); outputs transposed (2A, 2B)
        k.fill_inputs(obs, action, next_obs, self.x, self.z, self.zpi)
        first, w2, b2, w3_t, b3_t, w2_t = self.actor_ops
        torch.mm(self.x, first, out=self.h1)
        relu_(self.h1)
        k.linear_relu(self.h1, w2, b2, self.h2)
        torch.addmm(b3_t, w3_t, t["h2"], out=self.out_t)
        # noise drawn in LeanSAC's order (s first, then s'); the entropy coefficient read before its update
        noise = torch.randn((batch, self.act_dim), generator=self.generator)
        next_noise = torch.randn((batch, self.act_dim), generator=self.generator)
        mean_log_prob = k.sample(self.out_t, noise, next_noise, self.target_entropy, self.rows, self.z, self.zpi)
        ent_coef = math.exp(self.ent_adam.value)
        self.log_ent_coef.fill_(self.ent_adam.step(-mean_log_prob))
        # target critics on (s', a') and critics on (s, a): one pass over the four stacked members
        self._critics_forward(self.stack_ops, self.z, self.g1, self.g2, t["g2"], self.q_t, self.stack_q)
        grads = self.critic_grads
        k.critic_dq(self.q_t, reward, done, self.rows["next_logp"], ent_coef, self.dq, grads[4])
        _copy(self.dq, self.dq_lp)
        self._critics_backward(self.dq_lp, self.g1c, self.g2c, grads[2])
        torch.bmm(t["zc"], self.dg1, out=grads[0])
        torch.bmm(t["g1c"], self.dg2, out=grads[1])
        torch.bmm(t["dq_lp"], self.g2c, out=grads[3])
        self.critic_adam.step(self.critic_step)
        self._refresh(self.critic_lp, self.critic_params)
        # actor update against the updated critics: dQ/da of the minimum member, back through both critics
        self._critics_forward(self.critic_ops, self.zpi2, self.g1pi, self.g2pi, t["g2pi"], self.qpi_t,
                              self.critic_q)
        k.lowest(self.qpi_t, self.dq_pi)
        _copy(self.dq_pi, self.dq_pi_lp)
        self._critics_backward(self.dq_pi_lp, self.g1pi, self.g2pi, self.col_scratch)
        torch.bmm(self.action_rows, t["dg1"], out=self.da_t)
        grads = self.actor_grads
        k.actor_dout(self.da_t, ent_coef, noise, self.rows, self.dout, grads[4])
        _copy(self.dout, self.dout_lp)
        # actor backward on the s rows of the forward pass
        k.outer_mask(self.dout_lp, w3_t, self.h2s, self.dh2, grads[2])
        torch.mm(self.dh2, w2_t, out=self.dh1)
        k.mask_(self.dh1, self.h1s)
        torch.mm(t["xs"], self.dh1, out=grads[0])
        torch.mm(t["h1s"], self.dh2, out=grads[1])
        torch.mm(t["dout_lp"], self.h2s, out=grads[3])
        self.actor_adam.step(self.actor_step)
        self._refresh(self.actor_lp, self.actor_params)
        torch._foreach_lerp_(self.target_params, self.critic_params, TAU)
        self._refresh(self.target_lp, self.target_params)


def _copy(source, target) -> None:
    """``source`` into ``target`` unless they are one tensor (float32, where the low-precision copy is it)."""
    if target is not source:
        target.copy_(source)


def _network_views(params: list) -> tuple:
    """What a stacked critic's products take of [first, w2, b2, w3, b3] (K leading): (first, w2, b2, w3^T,
    b3, w2^T)."""
    first, w2, b2, w3, b3 = params
    return first, w2, b2, w3.transpose(1, 2), b3, w2.transpose(1, 2)


def _merged_first(params: list) -> list:
    """An MLP's [w1 (.., in, H), b1 (.., 1, H), w2, b2, w3, b3] as [first (.., in + 1, H), w2, b2, w3, b3]:
    the first layer's weight with its bias as the last row."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    return [torch.cat([p.detach() for p in params[:2]], dim=-2), *(p.detach() for p in params[2:])]


def _split_first(params: list) -> list:
    """:func:`_merged_first` undone as views: [w1, b1, w2, b2, w3, b3]."""
    return [params[0][..., :-1, :], params[0][..., -1:, :], *params[1:]]
