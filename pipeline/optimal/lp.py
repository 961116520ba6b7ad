"""The storage oracle as a linear program, assembled as sparse arrays (no modelling layer).

Variables per storage s and controlled step i (episode step t = i + 1), device-side kWh:
charge c >= 0, discharge d >= 0, energy held after the step E in [0, capacity]; a battery with a
depth-of-discharge floor adds a slack v >= 0 (see below). Per building b and step i with an import price:
grid import g >= 0. With the peak objective: one peak p_k per day k (blocks of 24 steps from the episode
start; an MPC window starts ``plant.day_offset`` steps into its first day, whose peak is at least the running
peak ``plant.peak_floor``).

Constraints (a = 1 - standing loss, r = one-way efficiency, k = electricity per device-side kWh, 1/COP or 1):

* storage balance (the env's storage model, exact): E_i = a E_(i-1) + r_i c_i - d_i / r_i, E_(-1) = initial;
* tank: c_i <= max(0, nominal x COP - demand) (the device's headroom, the env charges after serving the
  demand), d_i <= demand (the tank serves its end use before the device when it discharges); no discharge
  where the device is undersized (plant.py);
* battery: c_i, d_i <= nominal x (alpha_j + beta_j a E_(i-1) / C) for every segment j of the capacity-power
  curve (exact for a concave curve such as the default, a restriction otherwise); c_i + a E_(i-1) <= usable
  capacity_i (the env caps the *device-side* request by the free faded capacity); d_i <= r_(i-1) (E_(i-1) -
  floor + v_i) (the env's depth-of-discharge limit, at the previous step's efficiency; v lets an idle battery
  decay below the floor at a large cost, as the env allows); E_i <= usable capacity_(i+1) / a;
* building import: g_bi >= base net_bi + sum over its storages of k_si (c_si - d_si) (not at outage steps:
  net consumption is 0 there; and only where the import costs something: max(net, 0) x a negative price is
  not convex, so a step with a negative coefficient is left out of the LP's objective -- CityLearn's data sets
  have none); at an outage step the storages charge only from the PV surplus: sum_s k_si c_si <= surplus_bi;
* peak: p_day(t) >= district base net_t + sum_s k_si (c_si - d_si) (outage buildings excluded at their steps);
  p_day is bounded below by the lowest net its day can reach (a valid bound that helps the dual simplex).

Objective: the weighted import coefficients (``objectives.import_coefficients``) times g, peak weight x 24 / T
times sum_k p_k (T the episode's steps, ``plant.episode_steps`` for a window), plus constants of step 0 and of building-steps without a storage; a tiny throughput penalty
(``THROUGHPUT_PENALTY`` x the largest coefficient, on c and d) keeps the LP from charging and discharging in the
same step when it is indifferent, and the slack v costs ``SLACK_PENALTY`` x that coefficient per kWh. The
reported objective leaves both penalties out.

Two variants: ``build(..., relaxed=True)`` writes the relaxation of :mod:`pipeline.optimal.relax` (its optimum is
the certified lower bound; a battery adds stored and removed energies bounded by its efficiency lines, no
penalties); a storage with a ``tangent`` has its balance linearised at a plan (:mod:`pipeline.optimal.polish`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.optimal import objectives as obj
from pipeline.optimal import relax
from pipeline.optimal.plant import Plant, Storage

THROUGHPUT_PENALTY = 1e-5
SLACK_PENALTY = 1e3


@dataclass(frozen=True, eq=False)
class Columns:
    """Column offsets: storage s's charge at ``charge[s] + i`` (likewise discharge, energy, slack: -1 where
    the storage has none); ``imports`` (B, n): the import column of (b, i) or -1; ``peak`` the first day's."""

    n: int
    charge: np.ndarray
    discharge: np.ndarray
    energy: np.ndarray
    slack: np.ndarray
    imports: np.ndarray
    peak: int
    days: int
    total: int
    stored: np.ndarray | None = None
    removed: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class LinearProgram:
    """min cost . x s.t. row_lower <= A x <= row_upper, lower <= x <= upper; A row-wise (start, index, value).
    ``objective``: cost without the penalties; ``constant``: the objective's part no variable affects."""

    cost: np.ndarray
    objective: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    row_lower: np.ndarray
    row_upper: np.ndarray
    start: np.ndarray
    index: np.ndarray
    value: np.ndarray
    constant: float
    columns: Columns


class RowBuilder:
    """Collects blocks of rows as (row, column, value) triplets; a column < 0 is an absent term."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        self.lower: list[np.ndarray] = []
        self.upper: list[np.ndarray] = []
        self.count = 0

    def add(self, lower, upper, *terms: tuple[np.ndarray, np.ndarray | float]) -> None:
        """Add rows lower <= sum of terms <= upper; each term is (columns (k,), values (k,) or a scalar)."""
        lower = np.atleast_1d(np.asarray(lower, dtype=float))
        k = lower.size
        rows = self.count + np.arange(k)
        for cols, vals in terms:
            cols, vals = _full(cols, k, np.intp), _full(vals, k, float)
            keep = cols >= 0
            if keep.all():
                self.rows.append(rows)
                self.cols.append(cols)
                self.vals.append(vals)
            else:
                self.rows.append(rows[keep])
                self.cols.append(cols[keep])
                self.vals.append(vals[keep])
        self.lower.append(lower)
        self.upper.append(_full(upper, k, float))
        self.count += k

    def csr(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start, index, value) of the rows, row-wise."""
        rows = np.concatenate(self.rows) if self.rows else np.zeros(0, np.intp)
        order = np.argsort(rows, kind="stable")
        start = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=self.count))])
        return start, np.concatenate(self.cols)[order], np.concatenate(self.vals)[order]


def _full(values, k: int, dtype) -> np.ndarray:
    """``values`` (a scalar or (k,)) as a (k,) array of ``dtype`` (a cheap broadcast: this runs per LP block)."""
    array = np.asarray(values, dtype=dtype)
    return array if array.shape == (k,) else np.full(k, array.reshape(-1)[0] if array.size == 1 else array, dtype)


def layout(plant: Plant, weights: dict[str, float], coefficient: np.ndarray, relaxed: bool = False) -> Columns:
    """Column offsets for ``plant``: storages first, then imports where they cost something, then peaks.
    ``relaxed``: a battery has stored and removed energies (columns 4 and 5 of its block) and no slack."""
    n, storages = plant.steps - 1, plant.storages
    if relaxed:
        blocks = np.array([5 if s.battery is not None else 3 for s in storages], dtype=np.intp)
    else:
        blocks = np.array([4 if s.battery is not None and s.battery.floor > 0 else 3 for s in storages],
                          dtype=np.intp)
    first = np.concatenate([[0], np.cumsum(blocks * n)])[:-1].astype(np.intp)
    has_storage = np.zeros(len(plant.building_names), bool)
    has_storage[[s.building for s in storages]] = True
    wanted = has_storage[:, None] & (coefficient[:, 1:] > 0) & ~plant.outage[:, 1:]
    total = int(blocks.sum() * n)
    imports = np.full(wanted.shape, -1, dtype=np.intp)
    imports[wanted] = total + np.arange(int(wanted.sum()))
    total += int(wanted.sum())
    days = -(-(plant.day_offset + plant.steps) // obj.DAY_STEPS) if weights[obj.PEAK] > 0 else 0
    peak = total if days else -1
    if relaxed:
        return Columns(n=n, charge=first, discharge=first + n, energy=first + 2 * n,
                       slack=np.full(len(storages), -1, dtype=np.intp), imports=imports, peak=peak, days=days,
                       total=total + days, stored=np.where(blocks == 5, first + 3 * n, -1),
                       removed=np.where(blocks == 5, first + 4 * n, -1))
    return Columns(n=n, charge=first, discharge=first + n, energy=first + 2 * n,
                   slack=np.where(blocks == 4, first + 3 * n, -1), imports=imports, peak=peak, days=days,
                   total=total + days)


def build(plant: Plant, weights: dict[str, float], relaxed: bool = False) -> LinearProgram:
    """The LP of ``plant`` for the objective ``weights`` (see the module docstring). ``relaxed``: the
    relaxation of :mod:`pipeline.optimal.relax` (give it ``relax.relaxed_plant(plant)``): batteries store and
    remove within their efficiency lines, the balance is an inequality, the depth of discharge is its chord,
    outage steps do not cap charging, and the objective has no penalties (its optimum is the bound)."""
    coefficient = obj.import_coefficients(weights, plant.price, plant.carbon)
    cols = layout(plant, weights, coefficient, relaxed)
    n = cols.n
    lower, upper = np.zeros(cols.total), np.full(cols.total, np.inf)
    cost = np.zeros(cols.total)
    rows = RowBuilder()
    for s, storage in enumerate(plant.storages):
        if relaxed and storage.battery is not None:
            _relaxed_battery_rows(rows, storage, s, cols, upper)
        else:
            _storage_rows(rows, storage, s, cols, lower, upper)
    used = cols.imports >= 0
    cost[cols.imports[used]] = coefficient[:, 1:][used]
    base = plant.base_net
    free = np.ones(base.shape, bool)
    free[:, 1:] = ~used
    constant = float((coefficient * np.clip(base, 0.0, None))[free].sum())
    _import_rows(rows, plant, cols)
    if not relaxed:
        _outage_rows(rows, plant, cols)
    if cols.days:
        scale = obj.DAY_STEPS / (plant.episode_steps or plant.steps)
        _peak_rows(rows, plant, cols, lower, cost, weights[obj.PEAK] * scale)
    scale = max(float(cost.max(initial=0.0)), 1e-12)
    objective = cost.copy()
    for s in range(len(plant.storages) if not relaxed else 0):
        cost[cols.charge[s]:cols.energy[s]] += THROUGHPUT_PENALTY * scale
        if cols.slack[s] >= 0:
            cost[cols.slack[s]:cols.slack[s] + n] = SLACK_PENALTY * scale
    start, index, value = rows.csr()
    return LinearProgram(cost=cost, objective=objective, lower=lower, upper=upper,
                         row_lower=np.concatenate(rows.lower), row_upper=np.concatenate(rows.upper),
                         start=start, index=index, value=value, constant=constant, columns=cols)


def _storage_rows(rows: RowBuilder, s: Storage, i: int, cols: Columns, lower: np.ndarray,
                  upper: np.ndarray) -> None:
    """Bounds and rows of storage ``s`` (number ``i``): balance, and a battery's own limits."""
    n = cols.n
    steps = np.arange(n)
    ch, dis, en = cols.charge[i] + steps, cols.discharge[i] + steps, cols.energy[i] + steps
    prev = np.concatenate([[-1], en[:-1]])  # E_(i-1); at i = 0 a constant (the initial energy)
    upper[ch], upper[dis], upper[en] = s.charge_max, s.discharge_max, s.capacity
    a, r = s.retention, s.one_way
    start = np.zeros(n)
    start[0] = a * s.initial_energy
    if s.tangent is None:
        rows.add(start, start, (en, 1.0), (prev, -a), (ch, -r), (dis, 1.0 / r))
    else:
        gain, loss, offset = s.tangent
        rows.add(start + offset, start + offset, (en, 1.0), (prev, -a), (ch, -gain), (dis, loss))
    if s.battery is not None:
        _battery_rows(rows, s, cols.slack[i], ch, dis, en, prev, upper)
    if s.low is not None or s.high is not None:
        low, high = s.window()
        lower[ch], upper[ch] = np.maximum(low, 0.0), np.where(high <= 0, 0.0, np.minimum(upper[ch], high))
        lower[dis], upper[dis] = np.maximum(-high, 0.0), np.where(low >= 0, 0.0, np.minimum(upper[dis], -low))


def _relaxed_battery_rows(rows: RowBuilder, s: Storage, i: int, cols: Columns, upper: np.ndarray) -> None:
    """A battery in the relaxation: E_i - a E_(i-1) - stored_i + removed_i <= 0 (a E_(-1) at i = 0), stored
    and removed within the efficiency lines, the capacity-power and free-capacity rows of the plan's LP at the
    first step's usable capacity, and the depth-of-discharge chord (:mod:`pipeline.optimal.relax`)."""
    n = cols.n
    steps = np.arange(n)
    ch, dis, en = cols.charge[i] + steps, cols.discharge[i] + steps, cols.energy[i] + steps
    put, take = cols.stored[i] + steps, cols.removed[i] + steps
    prev = np.concatenate([[-1], en[:-1]])
    b, a = s.battery, s.retention
    upper[ch], upper[en] = s.charge_max, s.capacity
    start = np.zeros(n)
    start[0] = a * s.initial_energy
    rows.add(np.full(n, -np.inf), start, (en, 1.0), (prev, -a), (put, -1.0), (take, 1.0))
    store, remove = relax.efficiency_lines(b.efficiency, relax.power_range(s), b.extrapolate)
    p = b.nominal_power
    for slope, intercept in store:  # stored <= P intercept + slope c
        rows.add(np.full(n, -np.inf), p * intercept, (put, 1.0), (ch, -slope))
    for slope, intercept in remove:  # removed >= P intercept + slope d
        rows.add(np.full(n, p * intercept), np.inf, (take, 1.0), (dis, -slope))
    later = prev >= 0
    for alpha, beta in b.lines:
        limit0 = max(0.0, p * (alpha + beta * a * s.initial_energy / s.capacity))
        upper[ch[0]], upper[dis[0]] = min(upper[ch[0]], limit0), min(upper[dis[0]], limit0)
        if beta == 0.0:
            upper[ch], upper[dis] = np.minimum(upper[ch], p * alpha), np.minimum(upper[dis], p * alpha)
            continue
        for var in (ch, dis):
            rows.add(np.full(n - 1, -np.inf), p * alpha, (var[later], 1.0), (prev[later], -p * beta * a / s.capacity))
    usable = float(b.usable_capacity[0])
    upper[ch[0]] = min(upper[ch[0]], max(0.0, usable - a * s.initial_energy))
    rows.add(np.full(n - 1, -np.inf), usable, (ch[later], 1.0), (prev[later], a))
    best = float(b.one_way_prev[0])
    upper[dis[0]] = min(upper[dis[0]], max(0.0, best * (s.initial_energy - b.floor)))
    if b.floor > 0:
        chord = best * (s.capacity - b.floor) / s.capacity
        rows.add(np.full(n - 1, -np.inf), 0.0, (dis[later], 1.0), (prev[later], -chord))


def _battery_rows(rows: RowBuilder, s: Storage, slack: int, ch: np.ndarray, dis: np.ndarray, en: np.ndarray,
                  prev: np.ndarray, upper: np.ndarray) -> None:
    """Capacity-power curve, free faded capacity, depth of discharge and the energy ceiling of a battery."""
    b, a, e0 = s.battery, s.retention, s.initial_energy
    p = b.nominal_power
    later = prev >= 0
    for alpha, beta in b.lines:
        limit0 = max(0.0, p * (alpha + beta * a * e0 / s.capacity))
        upper[ch[0]], upper[dis[0]] = min(upper[ch[0]], limit0), min(upper[dis[0]], limit0)
        if beta == 0.0:
            upper[ch], upper[dis] = np.minimum(upper[ch], p * alpha), np.minimum(upper[dis], p * alpha)
            continue
        k = int(later.sum())
        for var in (ch, dis):
            rows.add(np.full(k, -np.inf), p * alpha, (var[later], 1.0), (prev[later], -p * beta * a / s.capacity))
    usable = b.usable_capacity
    upper[ch[0]] = min(upper[ch[0]], max(0.0, usable[0] - a * e0))
    rows.add(np.full(len(ch) - 1, -np.inf), usable[1:], (ch[later], 1.0), (prev[later], a))
    upper[en] = np.minimum(s.capacity, np.concatenate([usable[1:], usable[-1:]]) / a)
    rp = b.one_way_prev
    upper[dis[0]] = min(upper[dis[0]], max(0.0, rp[0] * (e0 - b.floor)))
    terms = [(dis[later], 1.0), (prev[later], -rp[1:])]
    if slack >= 0:
        v = slack + np.arange(len(ch))
        upper[v] = b.floor
        upper[v[0]] = 0.0
        terms.append((v[later], -rp[1:]))
    rows.add(np.full(len(ch) - 1, -np.inf), -rp[1:] * b.floor, *terms)


def _import_rows(rows: RowBuilder, plant: Plant, cols: Columns) -> None:
    """g_bi - sum_s k_si (c_si - d_si) >= base net_bi, where building b has an import column at i."""
    for b in range(len(plant.building_names)):
        mask = cols.imports[b] >= 0
        if not mask.any():
            continue
        steps = np.flatnonzero(mask)
        terms = [(cols.imports[b][mask], 1.0)]
        for s, storage in enumerate(plant.storages):
            if storage.building == b:
                k = storage.electricity[steps]
                terms += [(cols.charge[s] + steps, -k), (cols.discharge[s] + steps, k)]
        rows.add(plant.base_net[b, 1:][mask], np.inf, *terms)


def _outage_rows(rows: RowBuilder, plant: Plant, cols: Columns) -> None:
    """At a building's outage steps its storages charge only from the PV surplus: sum_s k_si c_si <= surplus."""
    for b in range(len(plant.building_names)):
        steps = np.flatnonzero(plant.outage[b, 1:])
        own = [(s, st) for s, st in enumerate(plant.storages) if st.building == b]
        if steps.size and own:
            rows.add(np.full(steps.size, -np.inf), plant.surplus[b, 1:][steps],
                     *[(cols.charge[s] + steps, st.electricity[steps]) for s, st in own])


def _peak_rows(rows: RowBuilder, plant: Plant, cols: Columns, lower: np.ndarray, cost: np.ndarray,
               weight: float) -> None:
    """p_day(t) - sum_s k_si (c_si - d_si) >= district base net_t; day 0 is at least step 0's net and the
    plant's ``peak_floor`` (the running peak of a day an MPC window starts inside)."""
    n = cols.n
    day = cols.peak + ((plant.day_offset + np.arange(1, n + 1)) // obj.DAY_STEPS)
    peaks = cols.peak + np.arange(cols.days)
    cost[peaks] = weight
    steps = np.arange(n)
    terms = [(day, 1.0)]
    floor = plant.base_net[:, 1:].sum(axis=0)  # district net if every storage discharged all it can
    for s, storage in enumerate(plant.storages):
        live = ~plant.outage[storage.building, 1:]
        k = storage.electricity
        terms += [(np.where(live, cols.charge[s] + steps, -1), -k), (np.where(live, cols.discharge[s] + steps, -1), k)]
        floor = floor - np.where(live, k * _most_discharge(storage), 0.0)
    rows.add(plant.base_net[:, 1:].sum(axis=0), np.inf, *terms)
    # a finite lower bound on each day's peak (a valid one: the peak is at least the lowest net any step of the
    # day can reach) keeps the dual simplex away from free columns
    bound = np.full(cols.days, -np.inf)
    np.maximum.at(bound, day - cols.peak, floor)
    bound[0] = max(bound[0], float(plant.base_net[:, 0].sum()), plant.peak_floor)
    lower[peaks] = bound


def _most_discharge(s: Storage) -> np.ndarray:
    """The most a storage can discharge at each step [kWh], regardless of its state (n,)."""
    if s.battery is None:
        return s.discharge_max
    soc = np.linspace(0.0, 1.0, 101)
    fraction = (s.battery.lines[:, :1] + s.battery.lines[:, 1:] * soc).min(axis=0).max()
    return np.minimum(s.discharge_max, s.battery.nominal_power * max(0.0, float(fraction)))
