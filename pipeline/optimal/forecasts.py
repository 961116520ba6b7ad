"""Forecasts a controller could have, for MPC (issue 29, part 3): at episode step t, the next H steps of every
series the storage LP needs that is not known in advance.

Forecast series (:data:`UNCERTAIN`, data-set columns, (B, N) over the simulation range): the building loads
(``non_shiftable_load`` [kWh], ``dhw_demand``, ``cooling_demand``, ``heating_demand`` [kWh thermal]), the PV
yield ``solar_generation`` [W per kW of PV], ``carbon_intensity`` [kg / kWh] and the outdoor temperature
[degC] (the heat pumps' COPs follow from it). Not forecast: ``electricity_pricing`` is a published tariff (a
controller knows it ahead, :data:`KNOWN`), and so is the calendar (hour, day type). Outages are not known ahead:
the plant of a forecast has none after the present step (:mod:`pipeline.optimal.window`).

Forecasters (:data:`FORECASTS`):

* ``perfect``: the true series (MPC's behaviour before forecasts existed);
* ``persistence``: the value at the same hour of the latest day already run (t + k - 24 m, m the fewest days
  back that reach a row <= t), or the last value at t where the data holds no such row;
* ``day_ahead``: mean by hour of day and day type (1-8) over the training rows ``train`` (an inclusive range of
  data rows that must end before the episode starts); an (hour, day type) the training rows never saw takes
  the mean of its hour over every day type;
* ``predicted``: the data set's own ``*_predicted_6h/_12h/_24h`` columns (upstream v2.4 names them ``_1/_2/_3``;
  the value the row's forecast gives for 6, 12, 24 steps later): the outdoor temperature from its own, the PV
  yield from the predicted direct and diffuse irradiance through a least-squares fit per building and hour of
  day (yield = a_h x direct + b_h x diffuse, on the training rows, clipped at 0; used only where it beats the
  day-ahead profile on the last quarter of the training rows, :func:`pv_fit`). A target t + k takes the
  freshest forecast made at a row <= t (the smallest lead >= k); where there is none (k > 24, or a data set
  without predicted columns) and for the series no predicted column maps to (loads, carbon intensity), the
  day-ahead profile.

Every forecaster but ``perfect`` reads the data through :class:`Past`, which refuses any row after the present:
a forecast at t depends only on rows <= t (tests/pipeline/optimal/test_mpc_forecasts.py changes the future rows
and checks it).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.errors import InputError

FORECASTS = ("perfect", "persistence", "day_ahead", "predicted")
UNCERTAIN = ("non_shiftable_load", "dhw_demand", "cooling_demand", "heating_demand", "solar_generation",
             "carbon_intensity", "outdoor_dry_bulb_temperature")
KNOWN = ("electricity_pricing",)
#: predicted-column suffix -> lead [steps]: the row's forecast of the value that many steps later
LEADS = (("6h", 6), ("12h", 12), ("24h", 24))
IRRADIANCE = ("direct_solar_irradiance", "diffuse_solar_irradiance")
DAY = 24
DAY_TYPES = 8


class FutureRowError(AssertionError):
    """A forecaster asked for a data row after the present (a bug: forecasts may only use the past)."""


@dataclass(frozen=True, eq=False)
class Data:
    """What forecasters read: data-set ``columns`` (name -> (B, N) over the simulation range), ``start``: the
    data row of episode step 0, and the calendar ``hour`` (1-24) and ``day_type`` (1-8), (N,), known ahead."""

    columns: Mapping[str, np.ndarray]
    start: int
    hour: np.ndarray
    day_type: np.ndarray


def data_of(env) -> Data:
    """The forecast data of ``env``'s current episode (call after ``env.reset``)."""
    columns = env.district.signals.columns
    return Data(columns=columns, start=int(env.episode_start), hour=np.asarray(columns["hour"][0], dtype=int),
                day_type=np.asarray(columns["day_type"][0], dtype=int))


class Past:
    """The data rows up to ``now`` (inclusive): :meth:`rows` refuses any later row."""

    def __init__(self, columns: Mapping[str, np.ndarray], now: int):
        self.columns, self.now = columns, now

    def rows(self, name: str, rows: np.ndarray) -> np.ndarray:
        """(B, k) values of column ``name`` at data ``rows`` (k,), every one in 0 .. now."""
        rows = np.asarray(rows, dtype=np.intp)
        if rows.size and (rows.max() > self.now or rows.min() < 0):
            raise FutureRowError(f"{name}: rows {rows.min()}..{rows.max()} requested at row {self.now}")
        return self.columns[name][:, rows]


class Forecaster:
    """Base: :meth:`window` gives the forecasts of :data:`UNCERTAIN` for the steps after t."""

    name = "perfect"

    def __init__(self, data: Data):
        self.data = data

    def window(self, t: int, horizon: int) -> dict[str, np.ndarray]:
        """name -> (B, ``horizon``) forecasts for episode steps t + 1 .. t + horizon, made at step t."""
        now = self.data.start + t
        targets = now + 1 + np.arange(horizon)
        past = Past(self.data.columns, now)
        return {name: self.series(past, name, targets) for name in UNCERTAIN}

    def series(self, past: Past, name: str, targets: np.ndarray) -> np.ndarray:
        """(B, k) forecast of ``name`` at data rows ``targets``: here the truth (``perfect`` may look ahead)."""
        return self.data.columns[name][:, targets]


class Persistence(Forecaster):
    """The same hour of the latest day already run, else the last value."""

    name = "persistence"

    def series(self, past: Past, name: str, targets: np.ndarray) -> np.ndarray:
        days = -(-(targets - past.now) // DAY)
        rows = targets - DAY * days
        return past.rows(name, np.where(rows >= 0, rows, past.now))


class DayAhead(Forecaster):
    """Mean by hour of day and day type over the training rows ``train`` (inclusive, before the episode)."""

    name = "day_ahead"

    def __init__(self, data: Data, train: tuple[int, int] | None):
        super().__init__(data)
        self.train = training_rows(data, train)
        past = Past(data.columns, self.train[-1])
        self.profiles = {name: profile(past.rows(name, self.train), data.hour[self.train],
                                       data.day_type[self.train]) for name in UNCERTAIN}

    def series(self, past: Past, name: str, targets: np.ndarray) -> np.ndarray:
        hour, day = self.data.hour[targets], self.data.day_type[targets]
        return self.profiles[name][:, np.clip(day, 1, DAY_TYPES), (hour - 1) % DAY]


def training_rows(data: Data, train: tuple[int, int] | None) -> np.ndarray:
    """The data rows of ``train`` (inclusive; None: every row before the episode), refused unless they lie
    before the episode's first row (nothing learned from the future)."""
    first, last = (0, data.start - 1) if train is None else (int(train[0]), int(train[1]))
    if not 0 <= first <= last < data.start:
        raise InputError(f"the training rows {first}..{last} must lie before the episode's first data row "
                         f"{data.start} (and not be empty): a forecaster learns only from the past", column="train")
    return np.arange(first, last + 1)


def profile(values: np.ndarray, hour: np.ndarray, day_type: np.ndarray) -> np.ndarray:
    """Mean of ``values`` (B, k) by day type and hour, (B, 9, 24) indexed [b, day type 1-8, hour - 1];
    a cell with no sample takes its hour's mean over every day type."""
    b = values.shape[0]
    hours = (hour - 1) % DAY
    cells = np.clip(day_type, 1, DAY_TYPES) * DAY + hours
    total = np.zeros((b, (DAY_TYPES + 1) * DAY))
    for i in range(b):
        total[i] = np.bincount(cells, weights=values[i], minlength=total.shape[1])
    count = np.bincount(cells, minlength=total.shape[1])
    by_hour = np.stack([np.bincount(hours, weights=values[i], minlength=DAY) for i in range(b)])
    hour_mean = by_hour / np.maximum(np.bincount(hours, minlength=DAY), 1)
    out = np.where(count > 0, total / np.maximum(count, 1), np.tile(hour_mean, DAY_TYPES + 1))
    return out.reshape(b, DAY_TYPES + 1, DAY)


class Predicted(DayAhead):
    """The data set's predicted columns where they map to a series, else the day-ahead profile."""

    name = "predicted"

    def __init__(self, data: Data, train: tuple[int, int] | None):
        super().__init__(data, train)
        self.pv_fit = pv_fit(data, self.train) if all(_has_predictions(data, n) for n in IRRADIANCE) else None

    def series(self, past: Past, name: str, targets: np.ndarray) -> np.ndarray:
        base = super().series(past, name, targets)
        if name == "outdoor_dry_bulb_temperature" and _has_predictions(self.data, name):
            return self._predicted(past, name, targets, base)
        if name == "solar_generation" and self.pv_fit is not None:
            direct, diffuse = (self._predicted(past, n, targets, None) for n in IRRADIANCE)
            hour = (self.data.hour[targets] - 1) % DAY
            pv = self.pv_fit[:, 0, hour] * direct + self.pv_fit[:, 1, hour] * diffuse
            return np.where(np.isnan(pv), base, np.maximum(pv, 0.0))
        return base

    def _predicted(self, past: Past, name: str, targets: np.ndarray, fallback: np.ndarray | None) -> np.ndarray:
        """Freshest forecast of ``name`` at each target row (the smallest lead reaching it from a row <= now);
        ``fallback`` (NaN when None) where no forecast reaches it."""
        shape = (self.data.columns[name].shape[0], targets.size)
        out = np.full(shape, np.nan) if fallback is None else fallback.copy()
        done = np.zeros(targets.size, bool)
        for suffix, lead in LEADS:
            rows = targets - lead
            use = ~done & (rows <= past.now) & (rows >= 0)
            if use.any():
                out[:, use] = past.rows(f"{name}_predicted_{suffix}", rows[use])
                done |= use
        return out


def pv_fit(data: Data, train: np.ndarray) -> np.ndarray | None:
    """Per building and hour of day, yield = a_h x direct + b_h x diffuse irradiance [W/kW from W/m2] by least
    squares over the ``train`` rows, (B, 2, 24); None where the fit (on the first three quarters of the rows)
    misses the last quarter by more than the day-ahead profile does: the data set's PV then does not follow its
    weather file closely enough for predicted irradiance to help."""
    past = Past(data.columns, int(train[-1]))
    x = np.stack([past.rows(n, train) for n in IRRADIANCE], axis=2)  # (B, k, 2)
    y = past.rows("solar_generation", train)
    hour = (data.hour[train] - 1) % DAY
    cut = max(1, train.size * 3 // 4)
    first, rest = slice(0, cut), slice(cut, None)
    prior = profile(y[:, first], data.hour[train][first], data.day_type[train][first])
    guess = prior[:, np.clip(data.day_type[train][rest], 1, DAY_TYPES), hour[rest]]
    trial = _hour_fit(x[:, first], y[:, first], hour[first])
    fitted = np.maximum(trial[:, 0, hour[rest]] * x[:, rest, 0] + trial[:, 1, hour[rest]] * x[:, rest, 1], 0.0)
    if cut < train.size and np.abs(fitted - y[:, rest]).mean() >= np.abs(guess - y[:, rest]).mean():
        return None
    return _hour_fit(x, y, hour)


def _hour_fit(x: np.ndarray, y: np.ndarray, hour: np.ndarray) -> np.ndarray:
    """Least-squares (a_h, b_h) of y = a_h x[..., 0] + b_h x[..., 1] per building and hour, (B, 2, 24)."""
    onehot = np.eye(DAY)[hour]  # (k, 24)
    out = np.zeros((y.shape[0], 2, DAY))
    for i in range(y.shape[0]):
        design = np.concatenate([onehot * x[i, :, :1], onehot * x[i, :, 1:]], axis=1)
        out[i] = np.linalg.lstsq(design, y[i], rcond=None)[0].reshape(2, DAY)
    return out


def _has_predictions(data: Data, name: str) -> bool:
    return all(f"{name}_predicted_{suffix}" in data.columns for suffix, _ in LEADS)


def forecaster(kind: str, env, train: tuple[int, int] | None = None) -> Forecaster:
    """The forecaster ``kind`` (:data:`FORECASTS`) of ``env``'s current episode; ``train``: inclusive data rows
    the day-ahead profiles (and the PV fit) are learned from (default: every row before the episode)."""
    data = data_of(env)
    if kind == "perfect":
        return Forecaster(data)
    if kind == "persistence":
        return Persistence(data)
    if kind == "day_ahead":
        return DayAhead(data, train)
    if kind == "predicted":
        return Predicted(data, train)
    raise InputError(f"unknown forecast {kind!r}; known: {', '.join(FORECASTS)}", column="forecast")
