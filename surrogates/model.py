"""The LSTM surrogate: input features, min-max normalisation, the network and its stateful closed-loop rollout.

Network (CityLearn-compatible): ``l_lstm = nn.LSTM(input_size, hidden_size, num_layers, batch_first=True)``,
the top layer's output at the last window row goes through ``l_linear = nn.Linear(hidden_size, 1)``; the
output is the normalised indoor temperature. State-dict keys ``l_lstm.weight_ih_l0`` ... ``l_linear.bias``.

Inference mode (what citylearn_env runs; :func:`rollout` is its torch reference, used for training and
evaluation alike). For a run with normalised inputs ``x[t]`` (indoor temperature last) and lookback ``L``:

* the first ``L`` hours are warm-up: their indoor temperatures are the data values;
* for ``t >= L`` the window is ``L`` rows: exogenous inputs of hours ``t-L+1 .. t`` and the indoor
  temperature of hours ``t-L .. t-1`` (the ``L+1``-slot buffer of CityLearn);
* the hidden and cell states start at zeros at the first prediction and are carried from one window to the
  next although consecutive windows overlap by ``L-1`` rows (stateful sliding window);
* the prediction for ``t`` replaces the indoor temperature of ``t`` in the history (closed loop).

Periodic inputs: ``x_sin = sin(2 pi x / P)``, ``x_cos = cos(2 pi x / P)`` with P = 12 for ``month``, 24 for
``hour`` (1..24) and 7 for ``day_type`` (1..7; the holiday code 8 wraps onto 1). The period 7 is the one the
published CityLearn models were trained with (their stored bounds contain sin(4 pi / 7)); CityLearn 2.1's
runtime used 8, which is an upstream bug.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import pandas as pd
import torch
from torch import nn

from citylearn_env.dataset import PERIODS as _PERIODS
from citylearn_env.dataset import periodic_encoding, split_periodic_name
from surrogates.config import DEFAULT_INPUTS

PERIODS = dict(_PERIODS)  # month 12, hour 24, day_type 7 (the trained models' periods)


@contextmanager
def torch_threads(n: int = 1) -> Iterator[None]:
    """Run torch with ``n`` intra-op threads, then restore. The window ops are tiny: one thread is fastest,
    and on a busy 2-core machine two threads can be ~50x slower (spin-waiting)."""
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def periodic(values: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """(sin, cos) of ``2 pi values / period`` (:func:`citylearn_env.dataset.periodic_encoding`)."""
    return periodic_encoding(values, period)


def feature_matrix(table: pd.DataFrame, names: Sequence[str]) -> np.ndarray:
    """Raw (un-normalised) inputs, shape (rows, len(names)), in the order of ``names``."""
    columns = []
    for name in names:
        base, kind = split_periodic_name(name, PERIODS)
        if kind is not None:
            sin, cos = periodic(table[base].to_numpy(dtype=float), PERIODS[base])
            columns.append(sin if kind == "sin" else cos)
        else:
            columns.append(table[name].to_numpy(dtype=float))
    return np.column_stack(columns)


def available_inputs(table: pd.DataFrame, names: Sequence[str] = DEFAULT_INPUTS) -> list[str]:
    """``names`` without the columns the table lacks (e.g. the optional set point)."""
    def present(name: str) -> bool:
        base, kind = split_periodic_name(name, PERIODS)
        return name in table.columns or (kind is not None and base in table.columns)

    return [n for n in names if present(n)]


@dataclass(frozen=True)
class Normalization:
    """Min-max bounds per input (same order as the input names)."""

    minimum: np.ndarray
    maximum: np.ndarray

    @classmethod
    def fit(cls, features: np.ndarray) -> Normalization:
        """Bounds of the (training) feature rows; a constant input gets max = min + 1."""
        low, high = features.min(axis=0), features.max(axis=0)
        high = np.where(high - low > 1e-9, high, low + 1.0)
        return cls(low.astype(float), high.astype(float))

    def apply(self, features: np.ndarray) -> np.ndarray:
        return (features - self.minimum) / (self.maximum - self.minimum)

    def target_to_celsius(self, y: np.ndarray) -> np.ndarray:
        return y * (self.maximum[-1] - self.minimum[-1]) + self.minimum[-1]


class LSTMModel(nn.Module):
    """Stacked LSTM + linear head with CityLearn's parameter names (``l_lstm``, ``l_linear``)."""

    def __init__(self, input_size: int, hidden_size: int = 16, num_layers: int = 2):
        super().__init__()
        self.input_size, self.hidden_size, self.num_layers = input_size, hidden_size, num_layers
        self.l_lstm = nn.LSTM(input_size, hidden_size, num_layers, batch_first=True)
        self.l_linear = nn.Linear(hidden_size, 1)

    def forward(self, window: torch.Tensor, state=None):
        """window (batch, lookback, input_size) -> (normalised temperature (batch,), new (h, c) state)."""
        return self.step(window, state, self.flat_weights())

    def flat_weights(self) -> list[torch.Tensor]:
        """The LSTM's parameters in ``torch.lstm``'s order (w_ih, w_hh, b_ih, b_hh per layer)."""
        return [w for layer in self.l_lstm.all_weights for w in layer]

    def step(self, window: torch.Tensor, state, weights: Sequence[torch.Tensor]):
        """:meth:`forward` with the weights list given (``flat_weights()``, fetched once per rollout): the same
        ``torch.lstm`` kernel ``nn.LSTM`` calls, without the module's per-call checks. A ``None`` state starts
        at zeros, as in ``nn.LSTM``."""
        if state is None:
            zeros = window.new_zeros(self.num_layers, window.shape[0], self.hidden_size)
            state = (zeros, zeros)
        out, h, c = torch.lstm(window, state, weights, True, self.num_layers, 0.0, self.training, False, True)
        y = nn.functional.linear(out[:, -1], self.l_linear.weight, self.l_linear.bias)
        return y.squeeze(-1), (h, c)

    def sequence(self, rows: torch.Tensor, weights: Sequence[torch.Tensor]) -> torch.Tensor:
        """(batch, hours) outputs of one LSTM pass over ``rows`` (batch, hours, input_size) from zero state,
        the head applied at every row: with lookback 1 and the data temperatures in the rows, this is the
        stateful sliding window's one-step (teacher-forced) prediction of every hour in one kernel call."""
        zeros = rows.new_zeros(self.num_layers, rows.shape[0], self.hidden_size)
        out, _, _ = torch.lstm(rows, (zeros, zeros), weights, True, self.num_layers, 0.0, self.training, False, True)
        return nn.functional.linear(out, self.l_linear.weight, self.l_linear.bias).squeeze(-1)


def seeded_model(input_size: int, hidden_size: int, num_layers: int, seed: int) -> LSTMModel:
    """An :class:`LSTMModel` with PyTorch's default initialisation (``nn.LSTM``'s and ``nn.Linear``'s
    ``reset_parameters``, in their order) drawn from a local generator seeded with ``seed``: bit-identical to
    ``torch.manual_seed(seed); LSTMModel(...)`` run alone, but it neither reads nor changes torch's global
    random state, which every thread of the process shares (two trainings in a thread pool seeding and drawing
    from it at once got each other's numbers). Built on the meta device first: no global draw at all."""
    with torch.device("meta"):
        model = LSTMModel(input_size, hidden_size, num_layers)
    model = model.to_empty(device="cpu")
    generator = torch.Generator().manual_seed(seed)
    stdv = 1.0 / math.sqrt(hidden_size)
    with torch.no_grad():
        for weight in model.l_lstm.parameters():
            nn.init.uniform_(weight, -stdv, stdv, generator=generator)
        nn.init.kaiming_uniform_(model.l_linear.weight, a=math.sqrt(5), generator=generator)
        bound = 1 / math.sqrt(hidden_size)  # the head's fan-in
        nn.init.uniform_(model.l_linear.bias, -bound, bound, generator=generator)
    return model


def rollout(model: LSTMModel, x: torch.Tensor, lookback: int, closed_loop: bool = True,
            state=None) -> torch.Tensor:
    """Run the stateful sliding-window inference over sequences (see module docstring).

    Parameters
    ----------
    x : (batch, hours, inputs) normalised inputs, indoor temperature last (data values; only the first
        ``lookback`` are used when ``closed_loop``).
    closed_loop : feed predictions back (True, the environment's mode) or use the data temperatures
        (one-step-ahead, teacher forcing).

    Returns
    -------
    (batch, hours - lookback) normalised predictions for hours ``lookback .. hours-1``.

    Closed loop with autograd (training): the exogenous rows of every window are views of one ``unfold`` of
    ``x`` (window ``k`` predicts hour ``lookback + k`` from exogenous hours ``k+1 .. k+lookback``); the fed-back
    temperatures are kept as a list and stacked per window (no in-place write into a tensor autograd saved).
    Otherwise (one-step mode, or no autograd) :func:`_rollout_rows`. Lookback 1 in closed loop (float32):
    :func:`_rollout_cells`, the same network stepped as cells; lookback 1 in one-step mode from a zero state:
    :meth:`LSTMModel.sequence`, one kernel call over the hours (what stepping the windows computes).
    """
    weights = model.flat_weights()
    if closed_loop and lookback == 1 and not torch.is_autocast_enabled("cpu"):
        return _rollout_cells(model, x, state, weights)
    if not closed_loop and lookback == 1 and state is None:  # teacher-forced: one pass over the rows
        return model.sequence(_teacher_rows(x), weights)
    if not closed_loop or not torch.is_grad_enabled():
        return _rollout_rows(model, x, lookback, state, weights, feed_back=closed_loop)
    windows = x[:, 1:, :-1].unfold(1, lookback, 1).transpose(2, 3)  # (batch, hours - lookback, L, inputs - 1)
    history = list(x[:, :lookback, -1].unbind(1))
    predictions = []
    for k in range(x.shape[1] - lookback):
        window = torch.cat([windows[:, k], torch.stack(history[k:k + lookback], dim=1).unsqueeze(-1)], dim=2)
        y, state = model.step(window, state, weights)
        predictions.append(y)
        history.append(y)
    return torch.stack(predictions, dim=1)


def _rollout_cells(model: LSTMModel, x: torch.Tensor, state, weights: Sequence[torch.Tensor]) -> torch.Tensor:
    """Closed-loop :func:`rollout` with lookback 1, the LSTM stepped hour by hour as its cell equations
    (gates ``i, f, g, o`` in PyTorch's order; ``c = sigmoid(f) c + sigmoid(i) tanh(g)``, ``h = sigmoid(o)
    tanh(c)``) with the two bias vectors summed once: the same function as one ``torch.lstm`` call per hour
    (to float rounding, ~1e-7), without that kernel's fixed cost per call, which dominates at one timestep
    and 16 units (AMD EPYC, one thread: 1.6x faster per training update, 2x without autograd). With or
    without autograd; nothing is written in place."""
    layers, hidden = model.num_layers, model.hidden_size
    w_ih = [weights[4 * k].t() for k in range(layers)]
    w_hh = [weights[4 * k + 1].t() for k in range(layers)]
    bias = [weights[4 * k + 2] + weights[4 * k + 3] for k in range(layers)]
    if state is None:
        h = [x.new_zeros(x.shape[0], hidden) for _ in range(layers)]
        c = list(h)
    else:
        h, c = list(state[0].unbind(0)), list(state[1].unbind(0))
    head_w, head_b = model.l_linear.weight.t(), model.l_linear.bias
    temperature = x[:, 0, -1:]
    predictions = []
    for k in range(1, x.shape[1]):
        layer_input = torch.cat([x[:, k, :-1], temperature], dim=1)
        for j in range(layers):
            gates = torch.addmm(torch.addmm(bias[j], layer_input, w_ih[j]), h[j], w_hh[j])
            i, f, g, o = gates.chunk(4, dim=1)
            c[j] = torch.sigmoid(f) * c[j] + torch.sigmoid(i) * torch.tanh(g)
            h[j] = torch.sigmoid(o) * torch.tanh(c[j])
            layer_input = h[j]
        temperature = torch.addmm(head_b, layer_input, head_w)
        predictions.append(temperature)
    return torch.cat(predictions, dim=1)


def _teacher_rows(x: torch.Tensor) -> torch.Tensor:
    """Row ``j`` = the exogenous inputs of hour ``j + 1`` and the data temperature of hour ``j`` (a copy)."""
    return torch.cat([x[:, 1:, :-1], x[:, :-1, -1:]], dim=2)


def _rollout_rows(model: LSTMModel, x: torch.Tensor, lookback: int, state, weights: Sequence[torch.Tensor], *,
                  feed_back: bool) -> torch.Tensor:
    """:func:`rollout` from one shifted copy of ``x`` whose row ``j`` holds the exogenous inputs of hour ``j+1``
    and the temperature of hour ``j``; window ``k`` is the view of rows ``k .. k+L-1``. ``feed_back`` (closed
    loop, no autograd): each prediction is written into the next windows' temperature in place; otherwise the
    data temperatures stay (one-step mode, autograd allowed: nothing is written)."""
    rows = _teacher_rows(x)
    predictions = []
    for k in range(x.shape[1] - lookback):
        y, state = model.step(rows[:, k:k + lookback], state, weights)
        predictions.append(y)
        if feed_back and k + lookback < rows.shape[1]:
            rows[:, k + lookback, -1] = y
    return torch.stack(predictions, dim=1)

