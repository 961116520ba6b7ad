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

The numpy path (:class:`NumpyGroupStep`, the plain install's: numba is an extra) cannot loop cheaply over
buildings, steps and gates, so it batches: every active model of a group advances in one stacked matmul per
step of a wavefront over the layers (:class:`_Plan`: lookback + L - 1 matmuls per environment step, not
lookback * L), with the layer-0 input projection and the bias folded into that matmul, gates from
one exp as in the numba kernel, and work arrays and laid-out weights reused across steps. Results equal the
numba kernel's up to round-off (~1e-14 degC in float64; identical after the float32 rounding in the runs
compared).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable

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


#: entries one :class:`NumpyGroupStep` keeps: an input plan and an LSTM plan per group and set of active slots
#: (a mode switch that changes the set makes new ones); an LSTM plan holds about 2.5 copies of the group's
#: weights (~100 kB per building for 2 layers of 16 units), so few are kept
_PLAN_CACHE_SIZE = 6


def _index(ids: np.ndarray) -> slice | np.ndarray:
    """``ids`` as a slice when they are consecutive (views instead of copies), else the array itself."""
    if len(ids) and np.array_equal(ids, np.arange(ids[0], ids[0] + len(ids))):
        return slice(int(ids[0]), int(ids[0]) + len(ids))
    return ids


#: gate blocks of the numpy path's pre-activations: f, i, g, o (torch's rows are i, f, g, o)
_GATE_ORDER = (1, 0, 2, 3)


def _gate_constants(n_hidden: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(scale, numerator, offset) per gate row, so that one exp serves all four gates as in the numba kernel.

    ``scale`` is in torch's row order (i, f, g, o): the weights and biases are pre-multiplied by it (-1 for the
    sigmoid gates, 2 for g: exact in binary floating point). ``numerator`` and ``offset`` are in
    :data:`_GATE_ORDER` (f, i, g, o): ``gate = numerator / (exp(z) + 1) + offset`` gives sigmoid(u) =
    1 / (1 + exp(-u)) and tanh(u) = 1 - 2 / (exp(2u) + 1). (np.tanh costs about 2.5 times np.exp in float64
    without AVX-512; it serves the cell state only, a fifth of the values.)"""
    scale = np.repeat([-1.0, -1.0, 2.0, -1.0], n_hidden)
    return scale, np.repeat([1.0, 1.0, -2.0, 1.0], n_hidden), np.repeat([0.0, 0.0, 1.0, 0.0], n_hidden)


class _Inputs:
    """Per-step input work of one set of active slots: raw-input gather, sin/cos encoding, normalisation."""

    def __init__(self, bidx: np.ndarray, slots: np.ndarray, src, kind, period, lo, span):
        self.index, self.out_index = _index(slots), _index(bidx)
        self.src, self.column = src[slots], bidx[:, None]
        kinds = kind[slots].ravel()
        self.sin, self.cos = np.flatnonzero(kinds == 1), np.flatnonzero(kinds == 2)
        periods = period[slots].ravel()
        self.sin_period, self.cos_period = periods[self.sin], periods[self.cos]
        self.lo, self.span = lo[slots], span[slots]

    def row(self, raw: np.ndarray) -> np.ndarray:
        """(B, n_in) newest normalised inputs (step 1 of the module docstring)."""
        v = raw[self.src, self.column]
        flat = v.reshape(-1)
        if len(self.sin):
            flat[self.sin] = np.sin(2.0 * np.pi * flat[self.sin] / self.sin_period)
        if len(self.cos):
            flat[self.cos] = np.cos(2.0 * np.pi * flat[self.cos] / self.cos_period)
        v -= self.lo
        v /= self.span
        return v


class _Wave:
    """One wavefront step k: layers ``lo..hi`` advance together, layer l at window step k - l, reading row k of
    the plan's ``seq`` and writing the new hidden states into row k + 1.

    The gate pre-activations ``z`` (B, 1, 4*n*H) are gate-major (f of every active layer, then i, g, o: each
    gate one 2-D view) and contiguous, so the four gate operations run on one plain block."""

    def __init__(self, plan: _Plan, k: int, lo: int, hi: int, weights: np.ndarray):
        n, n_hidden = plan.seq.shape[0], plan.n_hidden
        width = (hi - lo + 1) * n_hidden
        cols = slice(lo * n_hidden, (hi + 1) * n_hidden)
        self.numerator, self.offset = (np.repeat(v, width) for v in _gate_constants(1)[1:])
        self.row, self.weights = plan.seq[:, k:k + 1], weights
        self.c, self.tmp, self.h_out = plan.c[:, cols], plan.tmp[:, cols], plan.seq[:, k + 1, cols]
        self.z = np.zeros((n, 1, 4 * width))
        self.f, self.i, self.g, self.o = (self.z[:, 0, j * width:(j + 1) * width] for j in range(4))

    def run(self) -> None:
        """Gate pre-activations (bias and input projection included), the gates, then the new cell and hidden
        states of the wave's layers: c = f c + i g, h = o tanh(c)."""
        z = np.matmul(self.row, self.weights, out=self.z)
        np.exp(z, out=z)
        z += 1.0
        np.divide(self.numerator, z, out=z)
        z += self.offset
        self.c *= self.f
        np.multiply(self.i, self.g, out=self.tmp)
        self.c += self.tmp
        np.tanh(self.c, out=self.tmp)
        np.multiply(self.o, self.tmp, out=self.h_out)


class _Plan:
    """The stacked LSTMs of one set of active slots, laid out for a wavefront over the layers.

    Layer l's step s depends on layer l's step s - 1 and layer l - 1's step s only, so wave k advances every
    layer l with 0 <= k - l < lookback in ONE batched matmul ``seq[:, k] @ W``. Row k of ``seq`` (B, waves + 1,
    K) holds ``[h_0 .. h_{L-1}, x_k, 1]`` (K = L*H + n_in + 1: the hidden states after wave k - 1, the window's
    input row k, a constant 1) and W (B, K, L*4H) holds W_hh of layer l in block (h_l, l), W_ih of layer l in
    block (h_{l-1}, l), layer 0's W_ih in block (x, 0) and the biases in the last row, the constant 1's (zeros
    elsewhere add exact zeros). Layers not yet started keep the carried hidden state: every row starts as a
    copy of it. The cell states ``c`` (B, L*H) are updated in place.
    """

    def __init__(self, bidx: np.ndarray, slots: np.ndarray, lookback: int, tcol, out_lo, out_span,
                 wih0t, wihrt, whht, bias, wlin, blin):
        n, n_layers, n_hidden, n_in = len(slots), whht.shape[1], whht.shape[2], wih0t.shape[1]
        self.index, self.out_index, self.lookback = _index(slots), _index(bidx), lookback
        self.n_layers, self.n_hidden, self.n_in = n_layers, n_hidden, n_in
        self.tcol, self.rows = tcol[slots], np.arange(n)
        self.uniform_tcol = int(self.tcol[0]) if np.all(self.tcol == self.tcol[0]) else None
        self.out_lo, self.out_span, self.wlin, self.blin = out_lo[slots], out_span[slots], wlin[slots], blin[slots]
        self.out_lo32, self.out_span32 = self.out_lo.astype(np.float32), self.out_span.astype(np.float32)
        scale = _gate_constants(n_hidden)[0]
        n_waves = lookback + n_layers - 1
        self.seq = np.zeros((n, n_waves + 1, n_layers * n_hidden + n_in + 1))
        self.seq[:, :, -1] = 1.0
        self.c = np.zeros((n, n_layers * n_hidden))  # the cell states, gathered and scattered per step
        self.tmp = np.zeros_like(self.c)
        big = self._weights(slots, wih0t, wihrt, whht, bias, scale)
        self._columns: dict[tuple[int, int], np.ndarray] = {}
        self.waves = [self._wave(k, big) for k in range(n_waves)]

    def _weights(self, slots, wih0t, wihrt, whht, bias, scale) -> np.ndarray:
        """W (B, K, L*4H) of the class docstring, every gate column pre-multiplied by ``scale``."""
        n_layers, n_hidden = self.n_layers, self.n_hidden
        g4, lh = 4 * n_hidden, n_layers * n_hidden
        big = np.zeros((len(slots), lh + self.n_in + 1, n_layers * g4))
        big[:, lh:lh + self.n_in, :g4] = wih0t[slots] * scale
        for layer in range(n_layers):
            cols = slice(layer * g4, (layer + 1) * g4)
            big[:, layer * n_hidden:(layer + 1) * n_hidden, cols] = whht[slots, layer] * scale
            if layer:
                big[:, (layer - 1) * n_hidden:layer * n_hidden, cols] = wihrt[slots, layer - 1] * scale
            big[:, -1, cols] = bias[slots, layer] * scale
        return big

    def _wave(self, k: int, big: np.ndarray) -> _Wave:
        """Wave ``k``: the active layers and their columns of ``big``, gate-major (contiguous)."""
        lo, hi = max(0, k - self.lookback + 1), min(self.n_layers - 1, k)
        n, rows = big.shape[:2]
        layers = big.reshape(n, rows, self.n_layers, 4, self.n_hidden)[:, :, lo:hi + 1][:, :, :, _GATE_ORDER]
        key = (lo, hi)
        if key not in self._columns:
            self._columns[key] = np.ascontiguousarray(layers.transpose(0, 1, 3, 2, 4)).reshape(n, rows, -1)
        return _Wave(self, k, lo, hi, self._columns[key])

    def load_window(self, buf: np.ndarray, f32: bool) -> None:
        """The LSTM input window into ``seq`` rows 0..lookback-1: buffer rows 1..lookback, the temperature
        column from rows 0..lookback-1, rounded to float32 when ``f32``."""
        rows = buf[self.index]
        lh = self.n_layers * self.n_hidden
        window = self.seq[:, :self.lookback, lh:lh + self.n_in]
        window[:] = rows[:, 1:]
        if self.uniform_tcol is not None:
            window[:, :, self.uniform_tcol] = rows[:, :-1, self.uniform_tcol]
        else:
            window[self.rows, :, self.tcol] = rows[self.rows, :-1, self.tcol]
        if f32:
            window[:] = window.astype(np.float32)

    def run(self, h: np.ndarray, c: np.ndarray) -> None:
        """The window through the stacked LSTM from the carried state ``h``, ``c`` (left at the final state)."""
        lh = self.n_layers * self.n_hidden
        self.seq[:, :, :lh] = h[self.index].reshape(len(self.rows), 1, lh)
        self.c[:] = c[self.index].reshape(self.c.shape)
        with np.errstate(over="ignore"):  # exp(+large) = inf gives the right limits; no warning
            for wave in self.waves:
                wave.run()
        for layer in range(self.n_layers):  # layer l's last step ran in wave lookback - 1 + l
            cols = slice(layer * self.n_hidden, (layer + 1) * self.n_hidden)
            h[self.index, layer] = self.seq[:, self.lookback + layer, cols]
        c[self.index] = self.c.reshape(-1, self.n_layers, self.n_hidden)

    def predict(self, buf: np.ndarray, f32: bool, out: np.ndarray) -> None:
        """y = w_lin . h_top + b_lin into the buffers' newest temperature entry; degC into ``out``."""
        lh = self.n_layers * self.n_hidden
        top = self.seq[:, -1, lh - self.n_hidden:lh]
        y = self.blin + (self.wlin * top).sum(axis=1)
        if f32:
            y = y.astype(np.float32)
            temp = y * self.out_span32 + self.out_lo32
            y = y.astype(np.float64)
        else:
            temp = y * self.out_span + self.out_lo
        if self.uniform_tcol is not None:
            buf[self.index, -1, self.uniform_tcol] = y
        else:
            buf[self.index, -1, self.tcol] = y
        out[self.out_index] = temp


class NumpyGroupStep:
    """Vectorised NumPy version of the group step (same arguments as the numba kernel, same results up to
    round-off): all active models of a group advance together, one batched matmul per wavefront step
    (:class:`_Plan`). Weights laid out for a set of active slots are kept (a few sets) and reused."""

    def __init__(self) -> None:
        self._plans: OrderedDict[tuple, tuple[np.ndarray, object]] = OrderedDict()

    def __getstate__(self) -> dict:
        """Copies and pickles start without plans: a plan's views into its own work arrays would come out of
        ``copy.deepcopy`` or pickle as separate arrays; the copy rebuilds its plans on first use."""
        return {}

    def __setstate__(self, state: dict) -> None:
        self.__init__()

    def _cached(self, key: tuple, owner: np.ndarray, build: Callable[[], object]):
        """The cached object of ``key`` (``owner``: the weight array whose id is in the key, held so that id
        stays its own), built by ``build()`` when missing; least recently used ones dropped."""
        hit = self._plans.get(key)
        if hit is not None and hit[0] is owner:
            self._plans.move_to_end(key)
            return hit[1]
        value = build()
        self._plans[key] = (owner, value)
        while len(self._plans) > _PLAN_CACHE_SIZE:
            self._plans.popitem(last=False)
        return value

    def __call__(self, raw, bidx, slots, src, kind, period, lo, span, tcol, out_lo, out_span,
                 buf, count, wih0t, wihrt, whht, bias, wlin, blin, h, c, f32, out, warm) -> None:
        """One environment step of the group's active slots ``slots`` (buildings ``bidx``); arguments as the
        numba kernel's (module docstring). Buffers, counts, ``h``, ``c``, ``out`` and ``warm`` change in place."""
        key = (slots.tobytes(), bidx.tobytes())
        inputs = self._cached(("in", id(src), *key), src,
                              lambda: _Inputs(bidx, slots, src, kind, period, lo, span))
        lookback = buf.shape[1] - 1
        index = inputs.index
        newest = inputs.row(raw)
        buf[index, :-1] = buf[index, 1:]
        buf[index, -1] = newest
        counts = np.minimum(count[index] + 1, lookback + 1)
        count[index] = counts
        full = counts > lookback
        warm[inputs.out_index] = full
        if not full.all():
            out[bidx[~full]] = np.nan
            if not full.any():
                return
            slots, bidx = slots[full], bidx[full]
            key = (slots.tobytes(), bidx.tobytes())
        plan = self._cached(("lstm", id(wih0t), *key), wih0t,
                            lambda: _Plan(bidx, slots, lookback, tcol, out_lo, out_span, wih0t, wihrt, whht,
                                          bias, wlin, blin))
        plan.load_window(buf, f32)
        plan.run(h, c)
        plan.predict(buf, f32, out)


def numpy_group_step(*args) -> None:
    """One group step with a fresh :class:`NumpyGroupStep` (no plan reuse; the bank keeps one instead)."""
    NumpyGroupStep()(*args)
