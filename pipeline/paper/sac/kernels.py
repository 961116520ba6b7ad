"""The element-wise steps of :class:`pipeline.paper.sac.fast.FastSAC`'s update, each one pass over its arrays.

Two implementations with the same signatures, both working in place on preallocated torch tensors:

* :class:`TorchKernels`: torch operations (any dtype; the bfloat16 path, and float32 where numba is not
  installed -- numba is the optional ``fast`` extra);
* :class:`NumbaKernels`: numba loops on the float32 tensors' shared-memory NumPy views. One loop replaces a
  chain of torch operations (a bias add, a ReLU and a gradient mask are one pass instead of three, the
  squashed-Gaussian sample of 256 rows one call instead of ~20 kernel launches of a few microseconds each).
  Arithmetic is float32 in torch's order; ``exp``, ``tanh`` and ``log`` come from the C library rather than
  torch's vectorised ones (results equal to float32 rounding).

Shapes: K stacked critics (2 or 4), B batch rows, H hidden units, D observations, A actions; Z = D + A + 1
(the critic input with its column of ones). ``small`` kernels take float32 tensors whatever the products'
precision; ``wide`` ones (:meth:`bias_relu_`, :meth:`mask_`, :meth:`outer_mask`) the products' dtype.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.paper.sac.lean import GAMMA, LOG_STD_MAX, LOG_STD_MIN, SQUASH_EPSILON

_HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)


class TorchKernels:
    """The update's element-wise steps as torch operations (any dtype)."""

    def __init__(self):
        import torch  # torch: the CLI imports this module; torch loads on first use

        self.torch = torch

    def register(self, *tensors) -> None:
        """Tensors that live as long as the update (buffers and their views): nothing to do here."""

    # ------------------------------------------------------------------ wide: (K, N, H) activations
    def linear_relu(self, x, w, b, out) -> None:
        """``out = relu(x @ w + b)``: x (K, N, I), w (K, I, H), b (K, 1, H), out (K, N, H) (or without K)."""
        torch = self.torch
        (torch.addmm if x.dim() == 2 else torch.baddbmm)(b, x, w, out=out)
        relu_(out)

    def mask_(self, grad, activation) -> None:
        """``grad`` zeroed in place where the ReLU output ``activation`` is 0 (same shapes)."""
        relu_backward_(grad, activation)

    def outer_mask(self, d, w_t, activation, out, col_sum) -> None:
        """``out = (d @ w_t) * [activation > 0]`` with d (K, N, J) and w_t (K, J, H) for J = 1 or 2A (a
        rank-J product: the output layer's backward), and ``col_sum`` (K, 1, H) float32 = out summed over N
        (the hidden layer's bias gradient)."""
        torch = self.torch
        d = d.to(out.dtype)
        (torch.mul if d.shape[-1] == 1 else torch.matmul)(d, w_t.to(out.dtype), out=out)
        relu_backward_(out, activation)
        col_sum.copy_(out.sum(-2, keepdim=True))

    # ------------------------------------------------------------------ small: (B, A) float32 rows
    def fill_inputs(self, obs, action, next_obs, x, z, zpi) -> None:
        """The networks' inputs (ones columns preset): x (2B, D + 1) = [s; s'], z (4, B, Z) = (s', .) for the
        target critics and (s, a) for the critics, zpi (B, Z) = (s, .); actions of the policy come later."""
        batch, d = obs.shape
        x[:batch, :d].copy_(obs)
        x[batch:, :d].copy_(next_obs)
        z[:2, :, :d].copy_(next_obs)
        z[2:, :, :d].copy_(obs)
        z[2:, :, d:-1].copy_(action)
        zpi[:, :d].copy_(obs)

    def sample(self, out_t, noise, next_noise, target_entropy: float, buf: dict, z, zpi) -> float:
        """Squashed Gaussian draws for s (columns :B of ``out_t`` (2A, 2B): mean rows, then log-std rows)
        and s' (columns B:). Writes ``buf`` entries action, std, om (1 - a^2), inside (log-std inside its
        clamp, 1.0 or 0.0), next_logp (B,); the actions into zpi (B, Z) and z's target members (0, 1).
        Returns mean(log pi + target entropy) (the entropy coefficient's gradient, negated)."""
        torch = self.torch
        from pipeline.paper.sac.lean import squashed_gaussian

        batch, act = noise.shape
        out = out_t.float().t()
        raw = out[:batch, act:]
        action, log_prob, std, om = squashed_gaussian(out[:batch, :act], raw.clamp(LOG_STD_MIN, LOG_STD_MAX),
                                                      noise)
        next_action, next_logp, _, _ = squashed_gaussian(
            out[batch:, :act], out[batch:, act:].clamp(LOG_STD_MIN, LOG_STD_MAX), next_noise)
        buf["action"].copy_(action)
        buf["std"].copy_(std)
        buf["om"].copy_(om)
        torch.logical_and(raw >= LOG_STD_MIN, raw <= LOG_STD_MAX, out=buf["inside"])
        buf["next_logp"].copy_(next_logp)
        d = zpi.shape[1] - act - 1
        zpi[:, d:-1].copy_(action)
        z[:2, :, d:-1].copy_(next_action)
        return float((log_prob + target_entropy).mean())

    def critic_dq(self, q_t, reward, done, next_logp, ent_coef: float, dq, dq_sum) -> None:
        """dL/dQ of the critics (K = 2, B, 1) from all four members' Q (4, 1, B) (target critics first): the
        soft Bellman target r + (1 - done) gamma (min_k Q'_k - alpha log pi'), then (Q_k - target) / B;
        ``dq_sum`` (2, 1, 1) = dq summed over B (the output bias gradient)."""
        torch = self.torch
        q = q_t.transpose(1, 2).float()
        next_q = q[:2].min(dim=0).values
        target = reward + (1.0 - done) * GAMMA * (next_q - ent_coef * next_logp.unsqueeze(1))
        torch.div(q[2:] - target, q.shape[1], out=dq)
        torch.sum(dq, dim=1, keepdim=True, out=dq_sum)

    def lowest(self, q_t, dq) -> None:
        """dL/dQ of the actor's loss through min_k Q_k: -1/B for the minimum member, else 0; q_t (K, 1, B),
        dq (K, B, 1)."""
        q = q_t.transpose(1, 2).float()
        dq.copy_((q == q.min(dim=0, keepdim=True).values).float() * (-1.0 / q.shape[1]))

    def actor_dout(self, da_t, ent_coef: float, noise, buf: dict, dout, dout_sum) -> None:
        """dL/d(actor output) (B, 2A) from the critics' dQ/da (K, A, B) summed over members: the squashing
        correction, the tanh and the reparameterisation (module docstring of :mod:`pipeline.paper.sac.fast`);
        ``dout_sum`` (1, 2A) = dout summed over B."""
        torch = self.torch
        batch, act = noise.shape
        action, om = buf["action"], buf["om"]
        d_action = da_t.float().sum(0).t()
        d_action = d_action + (ent_coef / batch) * 2 * action / (om + SQUASH_EPSILON)
        d_u = d_action * om
        dout[:, :act].copy_(d_u)
        dout[:, act:].copy_((d_u * buf["std"] * noise - ent_coef / batch) * buf["inside"])
        torch.sum(dout, dim=0, keepdim=True, out=dout_sum)


class NumbaKernels(TorchKernels):
    """:class:`TorchKernels` as numba loops: every ``small`` step, and the ``wide`` ones in float32."""

    def __init__(self, jit):
        super().__init__()
        self.jit = jit
        self.views: dict[int, tuple] = {}

    def register(self, *tensors) -> None:
        """Keep the NumPy views of float32 ``tensors`` (each ``.numpy()`` costs ~1.5 us, an update makes ~60)."""
        for t in tensors:
            if t.dtype == self.torch.float32:
                self.views[id(t)] = (t, t.numpy())

    def _np(self, t) -> np.ndarray:
        """``t.numpy()``, kept for registered tensors."""
        kept = self.views.get(id(t))
        return kept[1] if kept is not None and kept[0] is t else t.numpy()

    def _np3(self, t) -> np.ndarray:
        """:meth:`_np` as (K, N, H): a 2-D tensor gains a leading axis of 1."""
        a = self._np(t)
        return a[None] if a.ndim == 2 else a

    def linear_relu(self, x, w, b, out) -> None:
        if out.dtype != self.torch.float32:
            return super().linear_relu(x, w, b, out)
        (self.torch.mm if x.dim() == 2 else self.torch.bmm)(x, w, out=out)
        self.jit["bias_relu"](self._np3(out), self._np3(b))

    def mask_(self, grad, activation) -> None:
        if grad.dtype != self.torch.float32:
            return super().mask_(grad, activation)
        self.jit["mask"](self._np3(grad), self._np3(activation))

    def outer_mask(self, d, w_t, activation, out, col_sum) -> None:
        if out.dtype != self.torch.float32:
            return super().outer_mask(d, w_t, activation, out, col_sum)
        w_t = self._np3(w_t)
        self.jit["outer_mask"](self._np3(d), w_t if w_t.flags.c_contiguous else np.ascontiguousarray(w_t),
                               self._np3(activation), self._np3(out), self._np3(col_sum))

    def fill_inputs(self, obs, action, next_obs, x, z, zpi) -> None:
        if x.dtype != self.torch.float32:
            return super().fill_inputs(obs, action, next_obs, x, z, zpi)
        self.jit["fill_inputs"](obs.numpy(), action.numpy(), next_obs.numpy(), self._np(x), self._np(z),
                                self._np(zpi))

    def sample(self, out_t, noise, next_noise, target_entropy: float, buf: dict, z, zpi) -> float:
        if z.dtype != self.torch.float32:
            return super().sample(out_t, noise, next_noise, target_entropy, buf, z, zpi)
        np_ = self._np
        return self.jit["sample"](np_(out_t), noise.numpy(), next_noise.numpy(), np.float32(target_entropy),
                                  np_(buf["action"]), np_(buf["std"]), np_(buf["om"]), np_(buf["inside"]),
                                  np_(buf["next_logp"]), np_(z), np_(zpi))

    def critic_dq(self, q_t, reward, done, next_logp, ent_coef: float, dq, dq_sum) -> None:
        q = self._np(q_t) if q_t.dtype == self.torch.float32 else q_t.float().numpy()
        self.jit["critic_dq"](q, reward.numpy(), done.numpy(), self._np(next_logp), np.float32(ent_coef),
                              self._np(dq), self._np(dq_sum))

    def lowest(self, q_t, dq) -> None:
        q = self._np(q_t) if q_t.dtype == self.torch.float32 else q_t.float().numpy()
        self.jit["lowest"](q, self._np(dq))

    def actor_dout(self, da_t, ent_coef: float, noise, buf: dict, dout, dout_sum) -> None:
        batch, np_ = noise.shape[0], self._np
        da = np_(da_t) if da_t.dtype == self.torch.float32 else da_t.float().numpy()
        self.jit["actor_dout"](da, np.float32(ent_coef / batch), np.float32(ent_coef / batch * 2), noise.numpy(),
                               np_(buf["action"]), np_(buf["std"]), np_(buf["om"]), np_(buf["inside"]), np_(dout),
                               np_(dout_sum))


def kernels(prefer_numba: bool = True) -> TorchKernels:
    """:class:`NumbaKernels` where numba is installed (and ``prefer_numba``), else :class:`TorchKernels`."""
    jit = _compiled() if prefer_numba else None
    return NumbaKernels(jit) if jit else TorchKernels()


def relu_(x):
    """ReLU in place. A bfloat16 tensor is clamped through its int16 view: a set sign bit makes the int16
    negative, so clamping at 0 zeroes exactly the negative values (and -0.0) without the float conversion
    torch's bfloat16 element-wise kernels make (~4x faster here)."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    if x.dtype == torch.bfloat16:
        x.view(torch.int16).clamp_min_(0)
        return x
    return x.relu_()


def relu_backward_(grad, activation):
    """``grad`` zeroed in place where the ReLU output ``activation`` (>= 0) is not positive. A bfloat16
    ``grad`` is multiplied through its int16 view by ``min(bits, 1)`` of the activation's (1 exactly where
    the activation is positive): no float conversion."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    if grad.dtype == torch.bfloat16:
        grad.view(torch.int16).mul_(activation.view(torch.int16).clamp_max(1))
        return grad
    return grad.masked_fill_(activation <= 0, 0.0)


def relu_backward(grad, activation):
    """:func:`relu_backward_` on ``grad`` in place for bfloat16, on a copy otherwise (torch's
    ``threshold_backward``)."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    if grad.dtype == torch.bfloat16:
        return relu_backward_(grad, activation)
    return torch.ops.aten.threshold_backward(grad, activation, 0)


# ---------------------------------------------------------------------- the numba loops (float32 arrays)
_F0, _F1, _HALF = np.float32(0.0), np.float32(1.0), np.float32(0.5)
_LO, _HI = np.float32(LOG_STD_MIN), np.float32(LOG_STD_MAX)
_EPS, _GAMMA, _C = np.float32(SQUASH_EPSILON), np.float32(GAMMA), np.float32(_HALF_LOG_2PI)


def _bias_relu(x, b):  # pragma: no cover - compiled by numba
    """x (K, N, H) = max(x + b, 0) in place; b (K, 1, H)."""
    for k in range(x.shape[0]):
        for n in range(x.shape[1]):
            for h in range(x.shape[2]):
                v = x[k, n, h] + b[k, 0, h]
                x[k, n, h] = v if v > _F0 else _F0


def _mask(g, a):  # pragma: no cover - compiled by numba
    """g (K, N, H) = 0 where a <= 0, in place."""
    for k in range(g.shape[0]):
        for n in range(g.shape[1]):
            for h in range(g.shape[2]):
                g[k, n, h] = g[k, n, h] if a[k, n, h] > _F0 else _F0


def _masked_row(d, w_t, mask, row):  # pragma: no cover - compiled by numba
    """row (H,) = d (J,) @ w_t (J, H) where mask > 0, else 0: one pass for J = 1 (the critics) and J = 2 (the
    actor of one action)."""
    hidden, rank = row.shape[0], d.shape[0]
    if rank == 1:
        for h in range(hidden):
            row[h] = d[0] * w_t[0, h] if mask[h] > _F0 else _F0
    elif rank == 2:
        for h in range(hidden):
            row[h] = d[0] * w_t[0, h] + d[1] * w_t[1, h] if mask[h] > _F0 else _F0
    else:
        for h in range(hidden):
            row[h] = d[0] * w_t[0, h]
        for j in range(1, rank):
            for h in range(hidden):
                row[h] += d[j] * w_t[j, h]
        for h in range(hidden):
            row[h] = row[h] if mask[h] > _F0 else _F0


def _outer_mask(d, w_t, a, out, col_sum):  # pragma: no cover - compiled by numba
    """out (K, N, H) = (d (K, N, J) @ w_t (K, J, H)) where a > 0, else 0; col_sum (K, 1, H) = sum over N
    (a second pass: loops over few arrays are the ones the compiler vectorises)."""
    for k in range(out.shape[0]):
        sums = col_sum[k, 0]
        sums[:] = _F0
        for n in range(out.shape[1]):
            row = out[k, n]
            _masked_row(d[k, n], w_t[k], a[k, n], row)
            for h in range(row.shape[0]):
                sums[h] += row[h]


def _fill_inputs(obs, action, next_obs, x, z, zpi):  # pragma: no cover - compiled by numba
    batch, dim = obs.shape
    for b in range(batch):
        for i in range(dim):
            x[b, i] = zpi[b, i] = z[2, b, i] = z[3, b, i] = obs[b, i]
            x[batch + b, i] = z[0, b, i] = z[1, b, i] = next_obs[b, i]
        for i in range(action.shape[1]):
            z[2, b, dim + i] = z[3, b, dim + i] = action[b, i]


def _draw(mu, raw, noise):  # pragma: no cover - compiled by numba
    """One squashed Gaussian coordinate: (action, std, 1 - a^2, log-prob term, squash term, inside)."""
    log_std = min(max(raw, _LO), _HI)
    std = np.exp(log_std)
    action = np.tanh(mu + std * noise)
    om = _F1 - action * action
    gauss = -_HALF * (noise * noise) - log_std - _C
    inside = _F1 if raw >= _LO and raw <= _HI else _F0
    return action, std, om, gauss, np.log(om + _EPS), inside


def _sample(out_t, noise, next_noise, target, action, std, om, inside, next_logp, z, zpi):  # pragma: no cover
    batch, act = noise.shape
    dim = zpi.shape[1] - act - 1
    total = 0.0
    for b in range(batch):
        gauss, squash, next_gauss, next_squash = _F0, _F0, _F0, _F0
        for i in range(act):
            a, s, o, g, q, inn = _draw(out_t[i, b], out_t[act + i, b], noise[b, i])
            action[b, i], std[b, i], om[b, i], inside[b, i] = a, s, o, inn
            zpi[b, dim + i] = a
            gauss += g
            squash += q
            a, s, o, g, q, inn = _draw(out_t[i, batch + b], out_t[act + i, batch + b], next_noise[b, i])
            z[0, b, dim + i] = z[1, b, dim + i] = a
            next_gauss += g
            next_squash += q
        next_logp[b] = next_gauss - next_squash
        total += gauss - squash + target
    return total / batch


def _critic_dq(q_t, reward, done, next_logp, ent_coef, dq, dq_sum):  # pragma: no cover - compiled by numba
    batch = q_t.shape[2]
    scale = np.float32(batch)
    for k in range(2):
        dq_sum[k, 0, 0] = _F0
    for b in range(batch):
        next_q = min(q_t[0, 0, b], q_t[1, 0, b])
        target = reward[b, 0] + (_F1 - done[b, 0]) * _GAMMA * (next_q - ent_coef * next_logp[b])
        for k in range(2):
            v = (q_t[2 + k, 0, b] - target) / scale
            dq[k, b, 0] = v
            dq_sum[k, 0, 0] += v


def _lowest(q_t, dq):  # pragma: no cover - compiled by numba
    batch = q_t.shape[2]
    weight = np.float32(-1.0 / batch)
    for b in range(batch):
        low = q_t[0, 0, b]
        for k in range(1, q_t.shape[0]):
            low = min(low, q_t[k, 0, b])
        for k in range(q_t.shape[0]):
            dq[k, b, 0] = weight if q_t[k, 0, b] == low else _F0


def _actor_dout(da_t, alpha_b, two_alpha_b, noise, action, std, om, inside, dout, dout_sum):  # pragma: no cover
    batch, act = noise.shape
    dout_sum[0, :] = _F0
    for b in range(batch):
        for i in range(act):
            d = da_t[0, i, b]
            for k in range(1, da_t.shape[0]):
                d += da_t[k, i, b]
            d = d + two_alpha_b * action[b, i] / (om[b, i] + _EPS)
            d_u = d * om[b, i]
            d_log_std = (d_u * std[b, i] * noise[b, i] - alpha_b) * inside[b, i]
            dout[b, i], dout[b, act + i] = d_u, d_log_std
            dout_sum[0, i] += d_u
            dout_sum[0, act + i] += d_log_std


_KERNELS = {"bias_relu": _bias_relu, "mask": _mask, "outer_mask": _outer_mask, "fill_inputs": _fill_inputs,
            "sample": _sample, "critic_dq": _critic_dq, "lowest": _lowest, "actor_dout": _actor_dout}
_COMPILED: dict | None = None


def _compiled() -> dict | None:
    """The numba-compiled loops (cached on disk by numba), or None when numba is not installed."""
    global _COMPILED
    if _COMPILED is None:
        try:
            from numba import njit  # lazy: numba is an optional dependency (the ``fast`` extra)
        except ImportError:  # pragma: no cover - numba is optional
            _COMPILED = {}
        else:
            for name in ("_draw", "_masked_row"):  # helpers, inlined into the kernels
                globals()[name] = njit(cache=True, nogil=True, error_model="numpy", inline="always")(globals()[name])
            _COMPILED = {name: njit(cache=True, nogil=True, error_model="numpy")(fn) for name, fn in _KERNELS.items()}
    return _COMPILED or None
