"""The observations of a district: the flat vector's layout, the values at a time step and their bounds
(CityLearn 2.1 conventions).

Values are raw (un-normalised). A *static* observation depends only on data (calendar, weather, prices,
carbon intensity, loads, PV yield, COPs, outage signal); a *dynamic* one on the simulation state. The names
of both kinds are in :mod:`citylearn_env.state`; the district reads their values
(:meth:`~citylearn_env.district.District.static_series`, :meth:`~citylearn_env.district.District.dynamic_value`).
Static columns of the observation vector are laid out once per episode; each step only fills the dynamic ones.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence

import numpy as np

from citylearn_env.district import District
from citylearn_env.errors import SchemaError
from citylearn_env.occupant import OccupantModel
from citylearn_env.state import (
    COP_OBSERVATIONS,
    DELIVERED_OBSERVATIONS,
    DYNAMIC,
    OCCUPANT_DELTA,
    SET_POINT_DELTAS,
    STATIC_ALIASES,
)

#: per-charger observations (docs/ev.md section 5): generic schema key -> (name pattern with the charger id,
#: bounds); in this order after a building's other observations, charger by charger
CHARGER_OBSERVATIONS = {
    "electric_vehicle_charger_connected_state": ("electric_vehicle_charger_{}_connected_state", (0.0, 1.0)),
    "connected_electric_vehicle_at_charger_departure_time":
        ("connected_electric_vehicle_at_charger_{}_departure_time", (-1.0, 24.0)),
    "connected_electric_vehicle_at_charger_required_soc_departure":
        ("connected_electric_vehicle_at_charger_{}_required_soc_departure", (-0.1, 1.0)),
    "connected_electric_vehicle_at_charger_soc": ("connected_electric_vehicle_at_charger_{}_soc", (-0.1, 1.0)),
    "connected_electric_vehicle_at_charger_battery_capacity":
        ("connected_electric_vehicle_at_charger_{}_battery_capacity", (-1.0, 100.0)),
    "electric_vehicle_charger_incoming_state": ("electric_vehicle_charger_{}_incoming_state", (0.0, 1.0)),
    "incoming_electric_vehicle_at_charger_estimated_arrival_time":
        ("incoming_electric_vehicle_at_charger_{}_estimated_arrival_time", (-1.0, 24.0)),
    "incoming_electric_vehicle_at_charger_estimated_soc_arrival":
        ("incoming_electric_vehicle_at_charger_{}_estimated_soc_arrival", (-0.1, 1.0)),
}
#: per-machine observations: generic key -> (name pattern with the machine name, bounds); the schema key
#: ``washing_machine_load_profile`` is accepted and gives no observation (a list, not a number)
MACHINE_OBSERVATIONS = {
    "washing_machine_start_time_step": ("{}_start_time_step", (-1.0, 24.0)),
    "washing_machine_end_time_step": ("{}_end_time_step", (-1.0, 24.0)),
}
SILENT_OBSERVATIONS = ("washing_machine_load_profile",)


def charger_observations(district: District, t: int) -> dict[str, np.ndarray]:
    """Every per-charger observation at step ``t``: generic key (:data:`CHARGER_OBSERVATIONS`) -> (C,) values,
    the plugged-in (state 1) or incoming (state 2) EV's data, else upstream's placeholder (-1 for times and
    the capacity, -0.1 for SOCs, 0 for the states)."""
    data, ev = district.ev_data, district.ev
    state, vehicle = data.state[:, t], data.ev[:, t]
    plugged, incoming = (state == 1) & (vehicle >= 0), (state == 2) & (vehicle >= 0)
    v = np.maximum(vehicle, 0)
    keys = list(CHARGER_OBSERVATIONS)
    values = (plugged.astype(np.float64), np.where(plugged, data.departure_time[:, t], -1.0),
              np.where(plugged, data.required_soc_departure[:, t], -0.1),
              np.where(plugged, district.ev_record.soc[v, t], -0.1),
              np.where(plugged, ev.vehicles.battery.capacity[v], -1.0), incoming.astype(np.float64),
              np.where(incoming, data.estimated_arrival_time[:, t], -1.0),
              np.where(incoming, data.estimated_soc_arrival[:, t], -0.1))
    return dict(zip(keys, values, strict=True))


def machine_observations(district: District, t: int) -> dict[str, np.ndarray]:
    """Start and end of every washing machine's window at step ``t`` (M,) [absolute time step, -1 none]."""
    row = district.ev_first_row + t
    machines = district.machines
    return {"washing_machine_start_time_step": machines.start[:, row],
            "washing_machine_end_time_step": machines.end[:, row]}


def _device_bound(district: District, key: str, kind: str, index: int) -> tuple[float, float]:
    """Bounds of a charger or washing-machine observation: the fixed ones of docs/ev.md section 5, except a
    machine window's upper bound, which is the largest window step in its data (upstream's 24 is below the
    absolute time steps the windows hold)."""
    if kind == "ev":
        return CHARGER_OBSERVATIONS[key][1]
    machines = district.machines
    column = machines.start if key.endswith("start_time_step") else machines.end
    return -1.0, max(24.0, float(column[index].max()))


def device_observation_pairs(district: District, building: int, active: Sequence[str]
                             ) -> list[tuple[str, str, str, int]]:
    """Building ``building``'s charger and washing-machine observations from the active generic keys:
    (name, generic key, "ev" or "wm", device index), chargers then machines, each in schema order."""
    out = []
    if district.ev is not None:
        for c, (cid, b) in enumerate(zip(district.ev.chargers.names, district.ev.chargers.building, strict=True)):
            if b == building:
                out.extend((pattern.format(cid), key, "ev", c) for key, (pattern, _) in CHARGER_OBSERVATIONS.items()
                           if key in active)
    if district.machines is not None:
        for m, (name, b) in enumerate(zip(district.machines.names, district.machines.building, strict=True)):
            if b == building:
                out.extend((pattern.format(name), key, "wm", m) for key, (pattern, _) in MACHINE_OBSERVATIONS.items()
                           if key in active)
    return out


DEVICE_KEYS = (*CHARGER_OBSERVATIONS, *MACHINE_OBSERVATIONS, *SILENT_OBSERVATIONS)


def is_known(district: District, name: str) -> bool:
    """Observation ``name`` can be produced: a dynamic one, a device key or a data series of the district."""
    return name in DYNAMIC or name in DEVICE_KEYS or district.static_series(name, full_range=True) is not None


_DYNAMIC_NAMES = frozenset(DYNAMIC)


class StepObservations(Mapping):
    """All observations of every building at step ``t`` as name -> (B,) arrays, computed on access.

    This is what reward functions receive (CityLearn passes each building's full observation dict).
    """

    def __init__(self, district: District, t: int):
        self._d, self._t = district, t
        self._cache: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        value = self._cache.get(name)
        if value is not None:
            return value
        d = self._d
        if name in _DYNAMIC_NAMES:
            value = d.dynamic_value(name, self._t)
        else:
            series = d.static_series(name)
            if series is None:
                raise KeyError(name)
            value = series[:, self._t]
        self._cache[name] = value
        return value

    def __iter__(self) -> Iterator[str]:
        d = self._d
        names = set(DYNAMIC) | set(STATIC_ALIASES) | set(COP_OBSERVATIONS) | {"solar_generation"}
        return iter(sorted(names | set(d.episode.columns)))

    def __len__(self) -> int:
        return sum(1 for _ in self)


class ObservationLayout:
    """Where each (name, building) pair sits in the flat vector of all buildings' active observations.

    ``central_index`` picks the central-agent vector from it (shared names once, from the first building
    that has them); ``building_slices`` the per-building vectors.
    """

    def __init__(self, district: District):
        self.district = district
        self.pairs: list[tuple[str, int]] = []
        self.building_slices: list[slice] = []
        #: (position, generic key, "ev"/"wm", device index) of each charger and washing-machine observation
        self.device_pairs: list[tuple[int, str, str, int]] = []
        self.device_bounds: list[tuple[float, float]] = []
        order = [name for name, _ in district.config.observations]
        for b, building in enumerate(district.config.buildings):
            self._add_building(b, [n for n in order if n in building.active_observations])
        self.central_index = self._central(set(district.config.shared_observations))
        device_positions = {pos for pos, *_ in self.device_pairs}
        groups: dict[str, list[int]] = {}
        for i, (name, _) in enumerate(self.pairs):
            if i not in device_positions:
                groups.setdefault(name, []).append(i)
        self.groups = {n: (np.array(ix), np.array([self.pairs[i][1] for i in ix])) for n, ix in groups.items()}
        # set points are data, except where occupants override them during the episode
        changing = (*DYNAMIC, *(OccupantModel.SET_POINTS if district.occupants is not None else ()))
        everyone = np.arange(district.n)
        #: (name, positions, buildings) of the dynamic observations, filled each step; positions a slice when
        #: evenly spaced, buildings None when they are every building in order (views and plain copies)
        self.dynamic = [(n, _as_slice(pos), None if np.array_equal(bidx, everyone) else bidx)
                        for n, (pos, bidx) in self.groups.items() if n in changing]
        by_key: dict[str, list[tuple[int, int]]] = {}
        for pos, key, _, index in self.device_pairs:
            by_key.setdefault(key, []).append((pos, index))
        #: generic device key -> (positions, device indices) in the flat vector
        self.device_groups = {k: (np.array([p for p, _ in v], dtype=np.intp), np.array([i for _, i in v], dtype=np.intp))
                              for k, v in by_key.items()}

    def _add_building(self, b: int, names: list[str]) -> None:
        """Lay out building ``b``'s active observations ``names``: its plain ones, then its devices' ones."""
        for name in names:
            if not is_known(self.district, name):
                raise SchemaError(f"observation {name!r} is active but cannot be produced",
                                  column=f"observations.{name}")
        start = len(self.pairs)
        self.pairs.extend((n, b) for n in names if n not in DEVICE_KEYS)
        for name, key, kind, index in device_observation_pairs(self.district, b, names):
            self.device_pairs.append((len(self.pairs), key, kind, index))
            self.device_bounds.append(_device_bound(self.district, key, kind, index))
            self.pairs.append((name, b))
        self.building_slices.append(slice(start, len(self.pairs)))

    def _central(self, shared: set[str]) -> np.ndarray:
        """Positions of the central-agent vector: every pair, a ``shared`` name only at its first position."""
        seen: set[str] = set()
        central = []
        for i, (name, _) in enumerate(self.pairs):
            if name in shared:
                if name in seen:
                    continue
                seen.add(name)
            central.append(i)
        return np.array(central, dtype=np.intp)

    def names(self, central: bool = True) -> list[str]:
        index = self.central_index if central else range(len(self.pairs))
        return [self.pairs[i][0] for i in index]

    def episode_matrix(self) -> EpisodeRows:
        """The static observations over the current episode, row t = (n_pairs,) (dynamic columns 0), made on
        demand a chunk of steps at a time (:class:`EpisodeRows`)."""
        return EpisodeRows(self)

    def vector(self, static_row: np.ndarray, t: int) -> np.ndarray:
        """The flat vector of all active observations at ``t`` (static row plus dynamic values)."""
        out = static_row.copy()
        value = self.district.dynamic_value
        for name, pos, bidx in self.dynamic:
            out[pos] = value(name, t) if bidx is None else value(name, t)[bidx]
        if self.device_groups:
            values = {**(charger_observations(self.district, t) if self.district.ev is not None else {}),
                      **(machine_observations(self.district, t) if self.district.machines is not None else {})}
            for key, (pos, index) in self.device_groups.items():
                out[pos] = values[key][index]
        return out

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of every (name, building) pair, estimated over the simulation range."""
        lo, hi = np.zeros(len(self.pairs)), np.zeros(len(self.pairs))
        device = dict(zip((pos for pos, *_ in self.device_pairs), self.device_bounds, strict=True))
        ranges: dict[tuple, tuple[float, float]] = {}  # one range per distinct row (a broadcast one: once)
        for i, (name, b) in enumerate(self.pairs):
            lo[i], hi[i] = device[i] if i in device else _bound(self.district, name, b, ranges)
        # an observation that never varies over the range (e.g. month in a one-month run) gets a unit-wide
        # box centred on its value, so spaces are never degenerate and normalise it to 0.5
        flat = hi <= lo
        lo[flat], hi[flat] = lo[flat] - 0.5, hi[flat] + 0.5
        return lo, hi


def _as_slice(positions: np.ndarray) -> slice | np.ndarray:
    """``positions`` (increasing) as a slice when evenly spaced, else the array itself."""
    if len(positions) == 1:
        return slice(int(positions[0]), int(positions[0]) + 1)
    step = positions[1] - positions[0] if len(positions) > 1 else 0
    if step > 0 and np.array_equal(np.diff(positions), np.full(len(positions) - 1, step)):
        return slice(int(positions[0]), int(positions[-1]) + 1, int(step))
    return positions


class EpisodeRows:
    """Rows of the (T, n_pairs) matrix of static observations of the current episode, filled a chunk of steps
    at a time when first asked for. A chunk holds about :data:`CHUNK_VALUES` values (2 MB, so it is written in
    cache): a small district's whole episode at once, as one matrix; 1,000 buildings x 28 observations about 9
    steps (the whole (T, n_pairs) matrix would be 2 GB and take 20 s to fill)."""

    #: values per chunk (chunk steps = this // n_pairs, at least 1)
    CHUNK_VALUES = 1 << 18

    def __init__(self, layout: ObservationLayout):
        d = layout.district
        everyone = np.arange(d.n)
        self._series = []
        for name, (pos, bidx) in layout.groups.items():
            if name in DYNAMIC:
                continue
            series = d.static_series(name)
            if series.strides[0] == 0:    # one row every building shares (broadcast): read it once
                self._series.append((pos, None, series[0]))
            else:
                self._series.append((pos, slice(None) if np.array_equal(bidx, everyone) else bidx, series))
        self._width, self._length = len(layout.pairs), d.length
        self._steps = max(1, min(self._length, self.CHUNK_VALUES // max(self._width, 1)))
        self._first, self._rows = -1, np.zeros((0, self._width))

    def __len__(self) -> int:
        return self._length

    def __getitem__(self, t: int) -> np.ndarray:
        """Row ``t`` (read-only, float64; dynamic positions 0)."""
        t = int(t)
        if not 0 <= t < self._length:
            raise IndexError(f"time step {t} outside the episode (0 .. {self._length - 1})")
        first = t - t % self._steps
        if first != self._first:
            stop = min(first + self._steps, self._length)
            rows = np.zeros((stop - first, self._width))
            for pos, buildings, series in self._series:
                if buildings is None:
                    rows[:, pos] = series[first:stop, None]
                else:
                    rows[:, pos] = series[buildings, first:stop].T
            rows.flags.writeable = False
            self._rows, self._first = rows, first
        return self._rows[t - first]


def _bound(d: District, name: str, b: int, ranges: dict | None = None) -> tuple[float, float]:
    """(low, high) of observation ``name`` of building ``b`` over the simulation range, in its own units
    (``ranges``: the ranges of data rows found so far, :func:`_finite_range`)."""
    if name == "net_electricity_consumption":
        return _net_bound(d, b)
    if name.endswith("_soc") or name == "power_outage":
        return 0.0, 1.0
    if name == "indoor_dry_bulb_temperature":
        low, high = _finite_range(d.signals["indoor_dry_bulb_temperature"][b], ranges)
        return low - 10.0, high + 10.0
    if name == "indoor_dry_bulb_temperature_delta":
        return 0.0, 10.0
    if name in SET_POINT_DELTAS:
        return -10.0, 10.0
    if name == OCCUPANT_DELTA:
        occupant = d.config.buildings[b].occupant
        largest = occupant.largest_delta if occupant is not None else 0.0
        return -largest, largest
    bound = _energy_bound(d, name, b)
    if bound is not None:
        return bound
    return _finite_range(d.static_series(name, full_range=True)[b], ranges)


def _net_bound(d: District, b: int) -> tuple[float, float]:
    """Net consumption [kWh]: from everything discharging into the building and full PV (at most 0) to every
    device at nominal power, the battery charging and no PV."""
    s = d.signals
    pv = s.pv_generation[b]
    p_batt = d.battery.nominal_power[b]
    nsl = s["non_shiftable_load"][b]
    charge, discharge = _charger_power(d, b)
    low = min(float(np.min(nsl - p_batt - discharge - pv)), 0.0)
    devices_power = sum(p.nominal_power[b] for p in d.end_use_params) + charge + _machine_peak(d, b)
    return low, float(np.max(nsl + devices_power + p_batt - pv))


def _energy_bound(d: District, name: str, b: int) -> tuple[float, float] | None:
    """Bounds [kWh] of a delivered-energy or an electricity-consumption observation (None for any other)."""
    p_batt = d.battery.nominal_power[b]
    if name in DELIVERED_OBSERVATIONS:
        uses = {p.name: p for p in d.end_use_params}
        return 0.0, 1.15 * float(uses[DELIVERED_OBSERVATIONS[name]].demand[b].max())
    if name == "electrical_storage_electricity_consumption":
        return -float(p_batt), float(p_batt)
    for p in d.end_use_params:
        if name == ELECTRICITY_NAMES[p.name]:
            return 0.0, float(p.nominal_power[b])
        if name == STORAGE_ELECTRICITY_NAMES[p.name]:
            return -float(np.max(p.demand[b] / p.cop[b])), float(p.nominal_power[b])
    return None


def _charger_power(d: District, b: int) -> tuple[float, float]:
    """Building ``b``'s total max charging and max discharging power of its EV chargers [kW] (0 without)."""
    if d.ev is None:
        return 0.0, 0.0
    mine = d.ev.chargers.building == b
    return float(d.ev.chargers.max_charging_power[mine].sum()), float(d.ev.chargers.max_discharging_power[mine].sum())


def _machine_peak(d: District, b: int) -> float:
    """The largest step of any washing-machine cycle in building ``b`` [kWh] times its machine count (0 without)."""
    if d.machines is None:
        return 0.0
    peaks = [max((max(p) for p in d.machines.profile[m] if p), default=0.0)
             for m in np.flatnonzero(d.machines.building == b)]
    return float(len(peaks) * max(peaks, default=0.0))


def _finite_range(values: np.ndarray, ranges: dict | None = None) -> tuple[float, float]:
    """(min, max) of the finite values; (0, 0) when there is none (an empty optional column held as NaN).
    ``ranges`` remembers each row's by its memory, so a row all buildings share is reduced once."""
    key = (values.__array_interface__["data"][0], values.shape, values.strides, values.dtype.str)
    if ranges is not None and key in ranges:
        return ranges[key]
    finite = values[np.isfinite(values)]
    found = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    if ranges is not None:
        ranges[key] = found
    return found


#: end use -> its electricity-consumption observation names
ELECTRICITY_NAMES = {"cooling": "cooling_electricity_consumption", "heating": "heating_electricity_consumption",
                     "dhw": "dhw_electricity_consumption"}
STORAGE_ELECTRICITY_NAMES = {"cooling": "cooling_storage_electricity_consumption",
                             "heating": "heating_storage_electricity_consumption",
                             "dhw": "dhw_storage_electricity_consumption"}
