"""Inner loops of :class:`citylearn_env.dynamics.LSTMBank`: one environment step for a group of LSTM models.

Both implementations do the same work for every *active* model slot ``m`` (one per building):

1. shift the model's input buffer ``buf[m]`` (lookback + 1 rows, oldest first) by one row and write the
   newest normalised inputs, built from the raw inputs ``raw`` (n_raw, B): entry ``raw[src[m, i], b]``,
   optionally periodic-encoded (``kind`` 1 = sin, 2 = cos of 2*pi*x/period), then min-max normalised
   ``(x - lo) / span``;
2. once the buffer is full, run the ``lookback``-step window (exogenous inputs from rows 1..lookback, the
   indoor-temperature column ``tcol`` from rows 0..lookback-1) through the stacked LSTM, starting from the
   carried hidden/cell state ``h``, ``c`` and leaving the final state there;
3. ``y = w_lin . h_top + b_lin`` replaces the temperature entry of the newest row, and
   ``y * out_span + out_lo`` is written to ``out[b]`` (NaN while the buffer is not full); ``warm[b]`` records
   whether the buffer is full.

Weights are stored transposed (``wih0t`` (M, I, 4H), ``wihrt`` (M, L-1, H, 4H), ``whht`` (M, L, H, 4H)) so the
innermost loop runs over the 4H gate rows (i, f, g, o) and vectorises without reordering any sum.
``f32`` (the bank passes ``settings.lstm_float32``) rounds the window inputs and the output to float32 as torch
does in CityLearn 2.1; ``period`` holds the sin/cos periods (day_type: ``settings.lstm_day_type_period``)
and ``out_lo``/``out_span`` the de-normalisation bounds the bank chose
(``settings.lstm_output_uses_last_input_bounds``).
The kernels take plain arrays, bools and floats only, never the settings object (numba cannot type it).
numba is imported lazily by :func:`get_numba_kernel`; this module itself needs numpy only.
"""

from __future__ import annotations

import math

import numpy as np

_KERNEL = None


_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00


def _vexp(x, n, out, bits):  # pragma: no cover - compiled by numba
    """out[:n] = exp(x[:n]) in a loop LLVM can vectorise (range reduction + degree-13 Taylor, ~1 ulp)."""
    for i in range(n):
        v = min(max(x[i], -708.0), 709.0)
        k = math.floor(v * _INV_LN2 + 0.5)
        r = (v - k * _LN2_HI) - k * _LN2_LO
        p = 1.0 / 6227020800.0
        p = p * r + 1.0 / 479001600.0
        p = p * r + 1.0 / 39916800.0
        p = p * r + 1.0 / 3628800.0
        p = p * r + 1.0 / 362880.0
        p = p * r + 1.0 / 40320.0
        p = p * r + 1.0 / 5040.0
        p = p * r + 1.0 / 720.0
        p = p * r + 1.0 / 120.0
        p = p * r + 1.0 / 24.0
        p = p * r + 1.0 / 6.0
        p = p * r + 0.5
        p = p * r + 1.0
        p = p * r + 1.0
        out[i] = p
        bits[i] = (np.int64(k) + 1023) << 52
    scale = bits.view(np.float64)
    for i in range(n):
        out[i] *= scale[i]


def _encoded(v, kind, period):  # pragma: no cover - compiled by numba
    """Raw input ``v`` as the model sees it before normalisation: kind 1 sin, 2 cos of 2*pi*v/period, else v."""
    if kind == 1:
        return math.sin(2.0 * math.pi * v / period)
    if kind == 2:
        return math.cos(2.0 * math.pi * v / period)
    return v


def _push_inputs(raw, b, m, src, kind, period, lo, span, buf):  # pragma: no cover - compiled by numba
    """Shift model slot ``m``'s buffer one row (oldest dropped) and write building ``b``'s newest normalised
    inputs in the last row (step 1 of the module docstring)."""
    lookback = buf.shape[1] - 1
    n_in = buf.shape[2]
    for k in range(lookback):
        for i in range(n_in):
            buf[m, k, i] = buf[m, k + 1, i]
    for i in range(n_in):
        buf[m, lookback, i] = (_encoded(raw[src[m, i], b], kind[m, i], period[m, i]) - lo[m, i]) / span[m, i]


def _window_row(buf, m, s, t_col, f32, x):  # pragma: no cover - compiled by numba
    """x = the LSTM input of window step ``s``: buffer row s + 1, the temperature column from row s."""
    for i in range(buf.shape[2]):
        v = buf[m, s, i] if i == t_col else buf[m, s + 1, i]
        x[i] = np.float32(v) if f32 else v


def _gate_sums(m, layer, x, h, wih0t, wihrt, whht, bias, z):  # pragma: no cover - compiled by numba
    """z = bias + W_ih x + W_hh h: the 4H gate pre-activations (i, f, g, o) of one layer."""
    n_hidden = h.shape[2]
    g4 = 4 * n_hidden
    for g in range(g4):
        z[g] = bias[m, layer, g]
    if layer == 0:
        for i in range(wih0t.shape[1]):
            xi = x[i]
            for g in range(g4):
                z[g] += wih0t[m, i, g] * xi
    else:
        for i in range(n_hidden):
            xi = x[i]
            for g in range(g4):
                z[g] += wihrt[m, layer - 1, i, g] * xi
    for j in range(n_hidden):
        hj = h[m, layer, j]
        for g in range(g4):
            z[g] += whht[m, layer, j, g] * hj


def _cell_update(m, layer, z, e, bits, h, c, x):  # pragma: no cover - compiled by numba
    """The gates from the pre-activations ``z``, then the new cell state c and hidden state h of one layer
    (h also copied to ``x``, the next layer's input): sigmoid(u) = 1 / (1 + exp(-u)),
    tanh(u) = 1 - 2 / (exp(2u) + 1)."""
    n_hidden = h.shape[2]
    g4 = 4 * n_hidden
    for g in range(g4):
        z[g] = 2.0 * z[g] if 2 * n_hidden <= g < 3 * n_hidden else -z[g]
    _vexp(z, g4, e, bits)
    for j in range(n_hidden):
        gi = 1.0 / (1.0 + e[j])
        gf = 1.0 / (1.0 + e[n_hidden + j])
        gg = 1.0 - 2.0 / (e[2 * n_hidden + j] + 1.0)
        cj = gf * c[m, layer, j] + gi * gg
        c[m, layer, j] = cj
        z[j] = 2.0 * cj
    _vexp(z, n_hidden, e, bits)
    for j in range(n_hidden):
        go = 1.0 / (1.0 + e[3 * n_hidden + j])
        hj = go * (1.0 - 2.0 / (e[j] + 1.0))
        h[m, layer, j] = hj
        x[j] = hj


def _predict(m, b, h, wlin, blin, out_lo, out_span, f32, out):  # pragma: no cover - compiled by numba
    """y = w_lin . h_top + b_lin (normalised); writes the de-normalised temperature [degC] to ``out[b]``."""
    n_hidden = h.shape[2]
    y = blin[m]
    for j in range(n_hidden):
        y += wlin[m, j] * h[m, h.shape[1] - 1, j]
    if f32:
        y = np.float32(y)
        out[b] = np.float32(np.float32(y) * np.float32(out_span[m]) + np.float32(out_lo[m]))
    else:
        out[b] = y * out_span[m] + out_lo[m]
    return y


def _lstm_group_step(raw, bidx, slots, src, kind, period, lo, span, tcol, out_lo, out_span,
                     buf, count, wih0t, wihrt, whht, bias, wlin, blin, h, c, f32, out, warm):  # pragma: no cover
    lookback = buf.shape[1] - 1
    n_layers = h.shape[1]
    g4 = 4 * h.shape[2]
    x = np.empty(max(buf.shape[2], h.shape[2]))
    z = np.empty(g4)
    e = np.empty(g4)
    bits = np.empty(g4, dtype=np.int64)
    for a in range(slots.shape[0]):
        m = slots[a]
        b = bidx[a]
        _push_inputs(raw, b, m, src, kind, period, lo, span, buf)
        if count[m] <= lookback:
            count[m] += 1
        warm[b] = count[m] > lookback
        if not warm[b]:
            out[b] = np.nan
            continue
        for s in range(lookback):
            _window_row(buf, m, s, tcol[m], f32, x)
            for layer in range(n_layers):
                _gate_sums(m, layer, x, h, wih0t, wihrt, whht, bias, z)
                _cell_update(m, layer, z, e, bits, h, c, x)
        buf[m, lookback, tcol[m]] = _predict(m, b, h, wlin, blin, out_lo, out_span, f32, out)


#: helpers the group step resolves as module globals when numba compiles it: swapped for jitted, inlined ones
_HELPERS = ("_vexp", "_encoded", "_push_inputs", "_window_row", "_gate_sums", "_cell_update", "_predict")


def get_numba_kernel():
    """The numba-compiled version of the group step, or None when numba is not installed."""
    global _KERNEL
    if _KERNEL is None:
        try:
            from numba import njit  # lazy: numba is an optional dependency
        except ImportError:  # pragma: no cover - numba is optional
            _KERNEL = False
        else:
            for name in _HELPERS:
                globals()[name] = njit(cache=True, nogil=True, inline="always")(globals()[name])
            _KERNEL = njit(cache=True, nogil=True)(_lstm_group_step)
    return _KERNEL or None


def numpy_group_step(raw, bidx, slots, src, kind, period, lo, span, tcol, out_lo, out_span,
                     buf, count, wih0t, wihrt, whht, bias, wlin, blin, h, c, f32, out, warm) -> None:
    """Vectorised NumPy version of the group step (same arguments, same results up to round-off)."""
    lookback = buf.shape[1] - 1
    n_layers, n_hidden = h.shape[1], h.shape[2]
    v = raw[src[slots], bidx[:, None]]
    k, p = kind[slots], period[slots]
    angle = 2.0 * np.pi * v / p
    v = np.where(k == 1, np.sin(angle), np.where(k == 2, np.cos(angle), v))
    buf[slots, :-1] = buf[slots, 1:]
    buf[slots, -1] = (v - lo[slots]) / span[slots]
    count[slots] = np.minimum(count[slots] + 1, lookback + 1)
    full = count[slots] > lookback
    warm[bidx] = full
    out[bidx[~full]] = np.nan
    if not full.any():
        return
    slots, bidx = slots[full], bidx[full]
    rows = np.arange(len(slots))
    window = buf[slots, 1:].copy()
    window[rows, :, tcol[slots]] = buf[slots, :-1][rows, :, tcol[slots]]
    if f32:
        window = window.astype(np.float32).astype(np.float64)
    hh, cc = h[slots], c[slots]
    seq = window
    for layer in range(n_layers):
        w_in = wih0t[slots] if layer == 0 else wihrt[slots, layer - 1]
        proj = seq @ w_in + bias[slots, layer][:, None, :]
        w_hh = whht[slots, layer]
        hl, cl = hh[:, layer], cc[:, layer]
        hs = np.empty((len(slots), lookback, n_hidden))
        for s in range(lookback):
            zz = proj[:, s] + (hl[:, None, :] @ w_hh)[:, 0]
            sig = 1.0 / (1.0 + np.exp(-zz))
            cl = sig[:, n_hidden:2 * n_hidden] * cl + sig[:, :n_hidden] * np.tanh(zz[:, 2 * n_hidden:3 * n_hidden])
            hl = sig[:, 3 * n_hidden:] * np.tanh(cl)
            hs[:, s] = hl
        hh[:, layer], cc[:, layer] = hl, cl
        seq = hs
    h[slots], c[slots] = hh, cc
    y = blin[slots] + (wlin[slots] * hh[:, -1]).sum(axis=1)
    if f32:
        y = y.astype(np.float32)
        temp = y * out_span[slots].astype(np.float32) + out_lo[slots].astype(np.float32)
        y = y.astype(np.float64)
    else:
        temp = y * out_span[slots] + out_lo[slots]
    buf[slots, -1, tcol[slots]] = y
    out[bidx] = temp
