"""Observation names, their values at a time step, and their bounds (CityLearn 2.1 conventions).

Values are raw (un-normalised). A *static* observation depends only on data (calendar, weather, prices,
carbon intensity, loads, PV yield, COPs, outage signal); a *dynamic* one on the simulation state. Static
columns of the observation vector are laid out once per episode; each step only fills the dynamic ones.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence

import numpy as np

from citylearn_env.dataset import NAME_ALIASES
from citylearn_env.district import District
from citylearn_env.errors import SchemaError
from citylearn_env.state import END_USES

#: observation name -> data column, for observations that are plain data
STATIC_ALIASES = {
    "indoor_dry_bulb_temperature_without_control": "indoor_dry_bulb_temperature",
    "cooling_demand_without_control": "cooling_demand",
    "heating_demand_without_control": "heating_demand",
    "dhw_demand_without_control": "dhw_demand",
    "non_shiftable_load_without_control": "non_shiftable_load",
    "indoor_relative_humidity_without_control": "indoor_relative_humidity",
    "indoor_dry_bulb_temperature_set_point_without_control": "indoor_dry_bulb_temperature_set_point",
}
#: observation name -> end use, for the device COP observations (derived from weather and the device); the
#: v2.2+ names ``*_device_efficiency`` mean the same (a heater's efficiency is its "COP")
COP_OBSERVATIONS = {"cooling_device_cop": "cooling", "heating_device_cop": "heating", "dhw_device_cop": "dhw",
                    "cooling_device_efficiency": "cooling", "heating_device_efficiency": "heating",
                    "dhw_device_efficiency": "dhw"}
#: signed set-point deviations (v2.2+): observation -> the set-point column; value T_indoor - T_set [degC]
SET_POINT_DELTAS = {"indoor_dry_bulb_temperature_cooling_delta": "indoor_dry_bulb_temperature_cooling_set_point",
                    "indoor_dry_bulb_temperature_heating_delta": "indoor_dry_bulb_temperature_heating_set_point"}
#: thermal energy delivered (device + storage) observed as a demand
DELIVERED_OBSERVATIONS = {"cooling_demand": "cooling", "heating_demand": "heating", "dhw_demand": "dhw"}

DYNAMIC = (
    "indoor_dry_bulb_temperature",
    "indoor_dry_bulb_temperature_delta",
    *SET_POINT_DELTAS,
    "net_electricity_consumption",
    *DELIVERED_OBSERVATIONS,
    "cooling_storage_soc", "heating_storage_soc", "dhw_storage_soc", "electrical_storage_soc",
    "cooling_electricity_consumption", "heating_electricity_consumption", "dhw_electricity_consumption",
    "cooling_storage_electricity_consumption", "heating_storage_electricity_consumption",
    "dhw_storage_electricity_consumption", "electrical_storage_electricity_consumption",
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


def dynamic_value(district: District, name: str, t: int) -> np.ndarray:
    """The (B,) value of dynamic observation ``name`` at episode step ``t``."""
    end_use = DELIVERED_OBSERVATIONS.get(name)
    if end_use is not None:
        r = district.end_use(end_use).record
        return r.energy_from_device[:, t] + r.energy_from_storage[:, t]
    if name == "indoor_dry_bulb_temperature_delta":
        setpoint = district.episode["indoor_dry_bulb_temperature_set_point"][:, t]
        return np.abs(district.building_record.indoor_dry_bulb_temperature[:, t] - setpoint)
    column = SET_POINT_DELTAS.get(name)
    if column is not None:
        return district.building_record.indoor_dry_bulb_temperature[:, t] - district.episode[column][:, t]
    return district.recorded[name][:, t]


def static_series(district: District, name: str, *, full_range: bool = False) -> np.ndarray | None:
    """The (B, T) episode series (or (B, N) over the simulation range) of a data observation; None if unknown."""
    if name == "solar_generation":
        return district.signals.pv_generation if full_range else district.episode.pv_generation
    end_use = COP_OBSERVATIONS.get(name)
    if end_use is not None:
        params = district.end_use_params[END_USES.index(end_use)]
        return params.cop if full_range else district.end_use(end_use).cop
    columns = (district.signals if full_range else district.episode).columns
    if name in columns:
        return columns[name]
    return columns.get(STATIC_ALIASES.get(name) or NAME_ALIASES.get(name, name))


DEVICE_KEYS = (*CHARGER_OBSERVATIONS, *MACHINE_OBSERVATIONS, *SILENT_OBSERVATIONS)


def is_known(district: District, name: str) -> bool:
    return name in DYNAMIC or name in DEVICE_KEYS or static_series(district, name, full_range=True) is not None


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
        if name in DYNAMIC:
            value = dynamic_value(d, name, self._t)
        else:
            series = static_series(d, name)
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
        config = district.config
        self.pairs: list[tuple[str, int]] = []
        self.building_slices: list[slice] = []
        order = [name for name, _ in config.observations]
        #: (position, generic key, "ev"/"wm", device index) of each charger and washing-machine observation
        self.device_pairs: list[tuple[int, str, str, int]] = []
        self.device_bounds: list[tuple[float, float]] = []
        for b, building in enumerate(config.buildings):
            names = [n for n in order if n in building.active_observations]
            for name in names:
                if not is_known(district, name):
                    raise SchemaError(f"observation {name!r} is active but cannot be produced",
                                      column=f"observations.{name}")
            start = len(self.pairs)
            self.pairs.extend((n, b) for n in names if n not in DEVICE_KEYS)
            for name, key, kind, index in device_observation_pairs(district, b, names):
                self.device_pairs.append((len(self.pairs), key, kind, index))
                self.device_bounds.append(_device_bound(district, key, kind, index))
                self.pairs.append((name, b))
            self.building_slices.append(slice(start, len(self.pairs)))
        device_positions = {pos for pos, *_ in self.device_pairs}
        shared = set(config.shared_observations)
        seen: set[str] = set()
        central = []
        for i, (name, _) in enumerate(self.pairs):
            if name in shared:
                if name in seen:
                    continue
                seen.add(name)
            central.append(i)
        self.central_index = np.array(central, dtype=np.intp)
        self.district = district
        groups: dict[str, list[int]] = {}
        for i, (name, _) in enumerate(self.pairs):
            if i not in device_positions:
                groups.setdefault(name, []).append(i)
        self.groups = {n: (np.array(ix), np.array([self.pairs[i][1] for i in ix])) for n, ix in groups.items()}
        self.dynamic = [(n, pos, bidx) for n, (pos, bidx) in self.groups.items() if n in DYNAMIC]
        by_key: dict[str, list[tuple[int, int]]] = {}
        for pos, key, _, index in self.device_pairs:
            by_key.setdefault(key, []).append((pos, index))
        #: generic device key -> (positions, device indices) in the flat vector
        self.device_groups = {k: (np.array([p for p, _ in v], dtype=np.intp), np.array([i for _, i in v], dtype=np.intp))
                              for k, v in by_key.items()}

    def names(self, central: bool = True) -> list[str]:
        index = self.central_index if central else range(len(self.pairs))
        return [self.pairs[i][0] for i in index]

    def episode_matrix(self) -> np.ndarray:
        """(T, n_pairs) matrix of the static observations over the current episode (dynamic columns 0)."""
        d = self.district
        matrix = np.zeros((d.length, len(self.pairs)))
        for name, (pos, bidx) in self.groups.items():
            if name not in DYNAMIC:
                matrix[:, pos] = static_series(d, name)[bidx].T
        return matrix

    def vector(self, static_row: np.ndarray, t: int) -> np.ndarray:
        """The flat vector of all active observations at ``t`` (static row plus dynamic values)."""
        out = static_row.copy()
        for name, pos, bidx in self.dynamic:
            out[pos] = dynamic_value(self.district, name, t)[bidx]
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
        for i, (name, b) in enumerate(self.pairs):
            lo[i], hi[i] = device[i] if i in device else _bound(self.district, name, b)
        # an observation that never varies over the range (e.g. month in a one-month run) gets a unit-wide
        # box centred on its value, so spaces are never degenerate and normalise it to 0.5
        flat = hi <= lo
        lo[flat], hi[flat] = lo[flat] - 0.5, hi[flat] + 0.5
        return lo, hi


def _bound(d: District, name: str, b: int) -> tuple[float, float]:
    s = d.signals
    uses = {p.name: p for p in d.end_use_params}
    pv = s.pv_generation[b]
    p_batt = d.battery.nominal_power[b]
    if name == "net_electricity_consumption":
        nsl = s["non_shiftable_load"][b]
        charge, discharge = _charger_power(d, b)
        low = min(float(np.min(nsl - p_batt - discharge - pv)), 0.0)
        devices_power = sum(p.nominal_power[b] for p in d.end_use_params) + charge + _machine_peak(d, b)
        return low, float(np.max(nsl + devices_power + p_batt - pv))
    if name.endswith("_soc") or name == "power_outage":
        return 0.0, 1.0
    if name == "indoor_dry_bulb_temperature":
        low, high = _finite_range(s["indoor_dry_bulb_temperature"][b])
        return low - 10.0, high + 10.0
    if name == "indoor_dry_bulb_temperature_delta":
        return 0.0, 10.0
    if name in SET_POINT_DELTAS:
        return -10.0, 10.0
    if name in DELIVERED_OBSERVATIONS:
        return 0.0, 1.15 * float(uses[DELIVERED_OBSERVATIONS[name]].demand[b].max())
    if name == "electrical_storage_electricity_consumption":
        return -float(p_batt), float(p_batt)
    for p in d.end_use_params:
        if name == ELECTRICITY_NAMES[p.name]:
            return 0.0, float(p.nominal_power[b])
        if name == STORAGE_ELECTRICITY_NAMES[p.name]:
            return -float(np.max(p.demand[b] / p.cop[b])), float(p.nominal_power[b])
    return _finite_range(static_series(d, name, full_range=True)[b])


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


def _finite_range(values: np.ndarray) -> tuple[float, float]:
    """(min, max) of the finite values; (0, 0) when there is none (an empty optional column held as NaN)."""
    finite = values[np.isfinite(values)]
    return (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)


#: end use -> its electricity-consumption observation names
ELECTRICITY_NAMES = {"cooling": "cooling_electricity_consumption", "heating": "heating_electricity_consumption",
                     "dhw": "dhw_electricity_consumption"}
STORAGE_ELECTRICITY_NAMES = {"cooling": "cooling_storage_electricity_consumption",
                             "heating": "heating_storage_electricity_consumption",
                             "dhw": "dhw_storage_electricity_consumption"}
