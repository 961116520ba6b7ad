"""Electric vehicles and their chargers, as the CityLearn v2.2+ schema describes them (contract: docs/ev.md).

Typed parameters (frozen dataclasses of arrays), the charger CSV reader, the schema section parser and
pure per-step functions. Shapes: (C,) per charger, (V,) per EV, (C, T) charger data over the simulation
range. Units: energy kWh per step, power kW, SOC a fraction 0..1 of nominal capacity, times in steps.
Charger data keep upstream's placeholders: -1 for a missing time, -0.1 for a missing SOC, EV index -1 for
no EV.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env.dataset import first_non_number, read_frame, row_label
from citylearn_env.devices import BatteryParams, Curve, battery_charge
from citylearn_env.errors import SchemaError

PARKED, INCOMING, AWAY = 1, 2, 3
MISSING_TIME = -1
MISSING_SOC = -0.1
NO_EV = -1
#: the six fields CityLearn 2.5 reads, in its positional order; matched here by header name
CHARGER_COLUMNS = ("electric_vehicle_charger_state", "electric_vehicle_id", "electric_vehicle_departure_time",
                   "electric_vehicle_required_soc_departure", "electric_vehicle_estimated_arrival_time",
                   "electric_vehicle_estimated_soc_arrival")
#: columns of the v2.4 eight-column files that CityLearn 2.5 does not use (capacity kWh, generator energy kWh)
IGNORED_CHARGER_COLUMNS = ("electric_vehicle_battery_capacity_khw", "current_soc")
#: upstream defaults of a charger attribute that the schema leaves out [kW, or - for efficiency]
CHARGER_DEFAULTS = {"max_charging_power": 50.0, "min_charging_power": 0.0, "max_discharging_power": 50.0,
                    "min_discharging_power": 0.0, "efficiency": 1.0}
#: an EV battery's depth of discharge when ``electric_vehicles_def`` leaves it out (upstream 2.5)
EV_DEFAULT_DEPTH_OF_DISCHARGE = 0.10


@dataclass(frozen=True, eq=False)
class ChargerTable:
    """One charger CSV over T rows: ``state`` (1 parked, 2 incoming, 3 away), ``ev_id`` (str, "" for none),
    ``departure_time`` and ``estimated_arrival_time`` [steps, -1 missing], ``required_soc_departure`` and
    ``estimated_soc_arrival`` [0..1, converted from percent, -0.1 missing]."""

    state: np.ndarray
    ev_id: np.ndarray
    departure_time: np.ndarray
    required_soc_departure: np.ndarray
    estimated_arrival_time: np.ndarray
    estimated_soc_arrival: np.ndarray


@dataclass(frozen=True, eq=False)
class ChargerParams:
    """C chargers: ``names`` (charger ids), ``building`` (index of the owning building among the included
    ones), power limits [kW] ``max_charging_power``, ``min_charging_power``, ``max_discharging_power``,
    ``min_discharging_power`` and ``efficiency`` [-], all (C,); optional per-charger efficiency curves
    (``None`` or ((|action|, efficiency), ...)) that replace ``efficiency``."""

    names: tuple[str, ...]
    building: np.ndarray
    max_charging_power: np.ndarray
    min_charging_power: np.ndarray
    max_discharging_power: np.ndarray
    min_discharging_power: np.ndarray
    efficiency: np.ndarray
    charge_efficiency_curve: tuple[tuple[tuple[float, float], ...] | None, ...]
    discharge_efficiency_curve: tuple[tuple[tuple[float, float], ...] | None, ...]


@dataclass(frozen=True, eq=False)
class ChargerData:
    """Charger data over the simulation range, (C, T): ``state`` (int), ``ev`` (index into the EV list,
    -1 none), times [steps, -1 missing] and SOCs [0..1, -0.1 missing] as in :class:`ChargerTable`."""

    state: np.ndarray
    ev: np.ndarray
    departure_time: np.ndarray
    required_soc_departure: np.ndarray
    estimated_arrival_time: np.ndarray
    estimated_soc_arrival: np.ndarray

    @functools.cached_property
    def plugged(self) -> np.ndarray:
        """(C, T) index of the EV plugged into each charger, -1 where none (state not 1); computed once, read
        by every step (:func:`plugged_ev`)."""
        return np.where(self.state == PARKED, self.ev, NO_EV)


@dataclass(frozen=True, eq=False)
class ElectricVehicles:
    """V EVs: ``names`` in ``electric_vehicles_def`` order and their batteries, (V,) arrays."""

    names: tuple[str, ...]
    battery: BatteryParams


@dataclass(frozen=True, eq=False)
class EVSection:
    """Everything the schema says about EVs: vehicles, chargers and the chargers' data (C, T)."""

    vehicles: ElectricVehicles
    chargers: ChargerParams
    data: ChargerData


# ------------------------------------------------------------------------------------------------ reading
def read_charger_table(path: str | Path, n_rows: int) -> ChargerTable:
    """Read the first ``n_rows`` rows of a charger CSV, matching columns by header name.

    Both the six-column (CityLearn 2.5) and the eight-column (v2.4 datasets) files load; the extra columns
    are ignored. Checks: every required column present; ``n_rows`` rows; state in {1, 2, 3}; an EV id in
    state 1 and 2 rows; numbers (or empty) in the time and SOC columns, SOCs 0..100 %. Every problem is one
    :class:`SchemaError` naming the file, the column and the first bad row."""
    path = Path(path)
    frame = read_frame(path)
    missing = [c for c in CHARGER_COLUMNS if c not in frame.columns]
    if missing:
        raise SchemaError(f"missing charger column (has {list(frame.columns)})", file=path, column=missing[0])
    if len(frame) < n_rows:
        raise SchemaError(f"has {len(frame)} data rows; the simulation range needs {n_rows}", file=path,
                          row=len(frame))
    text = {c: np.char.strip(frame[c].to_numpy()[:n_rows].astype(str)) for c in CHARGER_COLUMNS}
    state = parse_number_column(text["electric_vehicle_charger_state"], path, "electric_vehicle_charger_state",
                                allow_empty=False)
    bad = ~np.isin(state, (PARKED, INCOMING, AWAY))
    if bad.any():
        i = int(bad.argmax())
        raise SchemaError(f"charger state {state[i]:g} is not 1, 2 or 3", file=path,
                          column="electric_vehicle_charger_state", row=row_label(i))
    ev_id = np.where(np.isin(text["electric_vehicle_id"], ("", "nan")), "", text["electric_vehicle_id"])
    no_id = (state != AWAY) & (ev_id == "")
    if no_id.any():
        i = int(no_id.argmax())
        raise SchemaError(f"state {int(state[i])} needs an EV id", file=path, column="electric_vehicle_id",
                          row=row_label(i))
    times = {c: parse_number_column(text[c], path, c, allow_empty=True)
             for c in ("electric_vehicle_departure_time", "electric_vehicle_estimated_arrival_time")}
    socs = {c: parse_number_column(text[c], path, c, allow_empty=True)
            for c in ("electric_vehicle_required_soc_departure", "electric_vehicle_estimated_soc_arrival")}
    for column, values in socs.items():
        outside = (values < 0) | (values > 100)
        if outside.any():
            i = int(outside.argmax())
            raise SchemaError(f"SOC {values[i]:g} % outside 0..100", file=path, column=column, row=row_label(i))
    return ChargerTable(
        state=state.astype(np.int8), ev_id=ev_id.astype(object),
        departure_time=time_steps(times["electric_vehicle_departure_time"]),
        required_soc_departure=soc_fraction(socs["electric_vehicle_required_soc_departure"]),
        estimated_arrival_time=time_steps(times["electric_vehicle_estimated_arrival_time"]),
        estimated_soc_arrival=soc_fraction(socs["electric_vehicle_estimated_soc_arrival"]))


def parse_number_column(text: np.ndarray, path: object, column: str, *, allow_empty: bool) -> np.ndarray:
    """Cells (stripped strings) as float64; empty cells are NaN when ``allow_empty``; SchemaError at the
    first cell that is not a number (or is empty when not allowed)."""
    cells = np.where(text == "", "nan", text) if allow_empty else text
    try:
        values = np.asarray(cells, dtype=np.float64)
    except ValueError:
        i = first_non_number(cells)
        raise SchemaError(f"not a number: {str(text[i])!r}", file=path, column=column, row=row_label(i)) from None
    if not allow_empty and np.isnan(values).any():
        raise SchemaError("missing value", file=path, column=column, row=row_label(int(np.isnan(values).argmax())))
    return values


def time_steps(values: np.ndarray) -> np.ndarray:
    """Times [steps] truncated to integers, -1 where missing (NaN)."""
    return np.where(np.isnan(values), MISSING_TIME, np.trunc(np.nan_to_num(values))).astype(np.int64)


def soc_fraction(percent: np.ndarray) -> np.ndarray:
    """SOC in percent -> fraction 0..1 (upstream without noise: value / 100, clipped), -0.1 where missing."""
    return np.where(np.isnan(percent), MISSING_SOC, np.clip(np.nan_to_num(percent) / 100.0, 0.0, 1.0))


# ------------------------------------------------------------------------------------------------ schema
def upstream_uniform(seed: int) -> float:
    """The one uniform number CityLearn 2.5 uses for every randomised device default: the first draw of a
    fresh ``numpy.random.RandomState(seed)`` (upstream builds a new one per draw)."""
    return float(np.random.RandomState(seed).uniform())


def upstream_battery_curves(efficiency: float, u: float) -> tuple[tuple[tuple[float, float], ...], ...]:
    """CityLearn 2.5's drawn default battery curves for round-trip ``efficiency`` e and its uniform number
    ``u``: (power-efficiency curve (x = |energy| / nominal power, y = efficiency), capacity-power curve (x =
    SOC, y = fraction of nominal power)), as ((x, y), ...) points (docs/ev.md section 1)."""
    e = efficiency
    power_efficiency = ((0.0, e * (0.85 + 0.05 * u)), (0.25 + 0.1 * u, e * (0.90 + 0.05 * u)),
                        (0.65 + 0.1 * u, e * (0.98 + 0.02 * u)), (0.75 + 0.1 * u, e),
                        (1.0, e * (0.95 + 0.03 * u)))
    capacity_power = ((0.0, 0.95 + 0.05 * u), (0.75 + 0.1 * u, 0.90 + 0.05 * u), (1.0, 0.20 + 0.10 * u))
    return power_efficiency, capacity_power


def upstream_device_seed(building: str, building_type: str, slot: str, device_type: str, random_seed: int) -> int:
    """The seed CityLearn 2.5 gives a building device for its drawn defaults: the sum of the running MD5
    digests (as integers) after each of the four names, times ``random_seed + 1``, cut to its first 9 digits."""
    md5, total = hashlib.md5(), 0
    for text in (building, building_type, slot, device_type):
        md5.update(text.encode())
        total += int(md5.hexdigest(), 16)
    return int(str(total * (random_seed + 1))[:9])


def default_ev_battery(capacity: Sequence[float], nominal_power: Sequence[float], initial_soc: Sequence[float],
                       depth_of_discharge: Sequence[float], u: float) -> BatteryParams:
    """EV batteries with CityLearn 2.5's defaults for everything the schema leaves out, drawn as
    ``low + (high - low) * u`` (see docs/ev.md section 1): round-trip efficiency 0.90..0.98, standby loss
    0.001..0.009 per step, capacity loss coefficient 1e-5..1e-4 and the two curves.
    ``capacity`` [kWh], ``nominal_power`` [kW], ``initial_soc`` and ``depth_of_discharge`` [-] per EV."""
    n = len(capacity)
    e = 0.90 + 0.08 * u
    power_efficiency, capacity_power = upstream_battery_curves(e, u)

    def column(value: float | Sequence[float]) -> np.ndarray:
        return np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)).copy()

    return BatteryParams(
        capacity=column(capacity), nominal_power=column(nominal_power), efficiency=column(e),
        loss_coefficient=column(0.001 + 0.008 * u), capacity_loss_coefficient=column(1e-5 + 9e-5 * u),
        depth_of_discharge=column(depth_of_discharge), initial_soc=column(initial_soc),
        power_efficiency=Curve.from_points([power_efficiency] * n),
        capacity_power=Curve.from_points([capacity_power] * n))


def parse_ev_section(raw_schema: Mapping[str, Any], root: str | Path, *,
                     initial_soc_draws: Sequence[float] | None = None) -> EVSection | None:
    """The typed EV section of a v2.2+ schema (``None`` when it has no chargers and no EVs).

    Reads ``electric_vehicles_def`` (included EVs, in order), the ``chargers`` of every included building
    (buildings in schema order, chargers in their order) and each charger's CSV under ``root`` over the
    simulation range. An EV without ``initial_soc`` takes the next value of ``initial_soc_draws`` (upstream
    draws it from Python's unseeded ``random``; pass the reference run's values for parity); without draws
    it is an error (one draw per included EV, in order, used or not). Unknown EV ids in a charger file and
    bad attributes are one SchemaError each."""
    start = int(raw_schema.get("simulation_start_time_step") or 0)
    end = raw_schema.get("simulation_end_time_step")
    buildings = [(name, spec) for name, spec in raw_schema.get("buildings", {}).items() if spec.get("include", True)]
    chargers = [(b, cid, spec) for b, (_, bspec) in enumerate(buildings)
                for cid, spec in (bspec.get("chargers") or {}).items()]
    included = [n for n, spec in (raw_schema.get("electric_vehicles_def") or {}).items() if spec.get("include", True)]
    if not chargers and not included:
        return None
    if not included:
        raise SchemaError("chargers need electric vehicles: no included EV", column="electric_vehicles_def")
    vehicles = parse_vehicles(raw_schema, initial_soc_draws)
    params = parse_charger_params([(b, cid, spec) for b, cid, spec in chargers])
    index = {name: i for i, name in enumerate(vehicles.names)}
    tables = []
    for b, cid, spec in chargers:
        key = f"buildings.{buildings[b][0]}.chargers.{cid}.charger_simulation"
        if not isinstance(spec.get("charger_simulation"), str):
            raise SchemaError("missing charger data file name", column=key)
        if end is None:
            raise SchemaError("needed to read charger files", column="simulation_end_time_step")
        path = Path(root) / spec["charger_simulation"]
        table = read_charger_table(path, int(end) + 1)
        unknown = [i for i, v in enumerate(table.ev_id) if v and v not in index]
        if unknown:
            raise SchemaError(f"EV {table.ev_id[unknown[0]]!r} is not in electric_vehicles_def", file=path,
                              column="electric_vehicle_id", row=row_label(unknown[0]))
        tables.append(table)
    data = stack_charger_tables(tables, index, start)
    return EVSection(vehicles=vehicles, chargers=params, data=data)


def seeded_initial_soc_draws(raw_schema: Mapping[str, Any]) -> list[float]:
    """One U(0, 1) number per included EV of ``electric_vehicles_def`` from ``random.Random(random_seed)``
    (the schema's seed, 0 when absent): the initial SOC of EVs whose battery leaves ``initial_soc`` out.
    Upstream draws these from Python's unseeded global ``random``, so no run can reproduce its values; give
    ``initial_soc`` in the schema or set them with ``DistrictConfig.with_ev_initial_soc``."""
    rng = random.Random(int(raw_schema.get("random_seed") or 0))
    defs = raw_schema.get("electric_vehicles_def") or {}
    return [rng.uniform(0.0, 1.0) for spec in defs.values() if spec.get("include", True)]


def with_initial_soc(section: EVSection, initial_soc: Mapping[str, float]) -> EVSection:
    """``section`` with the named EVs' initial SOC [0..1] replaced; SchemaError for an unknown EV or a value
    outside 0..1."""
    names = section.vehicles.names
    soc = section.vehicles.battery.initial_soc.copy()
    for name, value in initial_soc.items():
        if name not in names:
            raise SchemaError(f"unknown EV; the district has {', '.join(names)}", column=f"initial_soc.{name}")
        if not 0.0 <= float(value) <= 1.0:
            raise SchemaError(f"{value!r} is not within 0..1", column=f"initial_soc.{name}")
        soc[names.index(name)] = float(value)
    battery = dataclasses.replace(section.vehicles.battery, initial_soc=soc)
    return dataclasses.replace(section, vehicles=dataclasses.replace(section.vehicles, battery=battery))


def parse_vehicles(raw_schema: Mapping[str, Any], initial_soc_draws: Sequence[float] | None) -> ElectricVehicles:
    """The included EVs of ``electric_vehicles_def`` with their batteries (upstream 2.5 defaults)."""
    defs = raw_schema.get("electric_vehicles_def") or {}
    draws = list(initial_soc_draws or [])
    names, values = [], {k: [] for k in ("capacity", "nominal_power", "initial_soc", "depth_of_discharge")}
    for name, spec in defs.items():
        if not spec.get("include", True):
            continue
        draw = draws.pop(0) if draws else None  # upstream draws once per included EV, given or not
        attributes = (spec.get("battery") or {}).get("attributes") or {}
        where = f"electric_vehicles_def.{name}.battery.attributes"
        for key in ("capacity", "nominal_power"):
            if not isinstance(attributes.get(key), (int, float)) or attributes[key] < 0:
                raise SchemaError("needs a number >= 0", column=f"{where}.{key}")
        soc = attributes.get("initial_soc", draw)
        if soc is None:
            raise SchemaError("missing; upstream draws it unseeded, so give it (or initial_soc_draws)",
                              column=f"{where}.initial_soc")
        dod = attributes.get("depth_of_discharge", EV_DEFAULT_DEPTH_OF_DISCHARGE)
        for key, value in (("initial_soc", soc), ("depth_of_discharge", dod)):
            if not isinstance(value, (int, float)) or not 0.0 <= value <= 1.0:
                raise SchemaError(f"{value!r} is not within 0..1", column=f"{where}.{key}")
        names.append(name)
        for key, value in zip(values, (attributes["capacity"], attributes["nominal_power"], soc, dod), strict=True):
            values[key].append(float(value))
    seed = int(raw_schema.get("random_seed") or 0)
    return ElectricVehicles(names=tuple(names), battery=default_ev_battery(**values, u=upstream_uniform(seed)))


def parse_charger_params(chargers: Sequence[tuple[int, str, Mapping[str, Any]]]) -> ChargerParams:
    """(C,) charger parameters from (building index, charger id, schema entry) triples, with upstream's
    defaults for left-out attributes (:data:`CHARGER_DEFAULTS`)."""
    columns: dict[str, list[float]] = {k: [] for k in CHARGER_DEFAULTS}
    curves: dict[str, list] = {"charge_efficiency_curve": [], "discharge_efficiency_curve": []}
    for _, cid, spec in chargers:
        if spec.get("noise_std") not in (None, 0, 0.0):  # upstream: unseeded Gaussian noise on the SOC columns
            raise SchemaError("charger data noise (noise_std > 0) is not supported", column=f"chargers.{cid}.noise_std")
        attributes = spec.get("attributes") or {}
        for key, default in CHARGER_DEFAULTS.items():
            value = attributes.get(key)
            value = default if value is None else value
            if not isinstance(value, (int, float)) or value < 0 or (key == "efficiency" and not 0 < value <= 1):
                raise SchemaError(f"invalid value {value!r}", column=f"chargers.{cid}.attributes.{key}")
            columns[key].append(float(value))
        for key in curves:
            points = attributes.get(key)
            curves[key].append(None if points is None else tuple((float(x), float(y)) for x, y in points))
    return ChargerParams(names=tuple(cid for _, cid, _ in chargers),
                         building=np.array([b for b, _, _ in chargers], dtype=np.int64),
                         **{k: np.array(v, dtype=np.float64) for k, v in columns.items()},
                         charge_efficiency_curve=tuple(curves["charge_efficiency_curve"]),
                         discharge_efficiency_curve=tuple(curves["discharge_efficiency_curve"]))


def stack_charger_tables(tables: Sequence[ChargerTable], index: Mapping[str, int], start: int) -> ChargerData:
    """(C, T) charger data from rows ``start:`` of each table; EV ids become indices into the EV list."""
    def stack(field: str, dtype: type) -> np.ndarray:
        rows = [np.asarray(getattr(t, field)[start:], dtype=dtype) for t in tables]
        return np.stack(rows) if rows else np.zeros((0, 0), dtype=dtype)

    ev = [np.array([index.get(v, NO_EV) if v else NO_EV for v in t.ev_id[start:]], dtype=np.int64) for t in tables]
    return ChargerData(state=stack("state", np.int64), ev=np.stack(ev) if ev else np.zeros((0, 0), np.int64),
                       departure_time=stack("departure_time", np.int64),
                       required_soc_departure=stack("required_soc_departure", np.float64),
                       estimated_arrival_time=stack("estimated_arrival_time", np.int64),
                       estimated_soc_arrival=stack("estimated_soc_arrival", np.float64))


# ------------------------------------------------------------------------------------------------ physics
def charger_efficiency(action: np.ndarray, chargers: ChargerParams) -> np.ndarray:
    """Charger efficiency [-] per charger (C,): its curve for the action's sign interpolated at |action|
    (held flat beyond the curve's ends), or its constant ``efficiency``."""
    eta = chargers.efficiency.copy()
    for c, a in enumerate(action):
        curve = (chargers.charge_efficiency_curve if a > 0 else chargers.discharge_efficiency_curve)[c]
        if curve is not None and a != 0:
            xs, ys = zip(*curve, strict=True)
            eta[c] = np.interp(abs(a), xs, ys)
    return eta


def charger_energy(action: np.ndarray, chargers: ChargerParams, step_hours: float = 1.0) -> np.ndarray:
    """Charger-side energy of an action [kWh] (C,): ``action`` times the max charging (a > 0) or
    discharging (a < 0) power [kW] times ``step_hours``, then held within [min, max] charging power, or
    within [-max, -min] discharging power (upstream compares kWh with kW); 0 for a zero action."""
    charge = np.clip(action * chargers.max_charging_power * step_hours, None, chargers.max_charging_power)
    charge = np.maximum(charge, chargers.min_charging_power)
    discharge = np.minimum(action * chargers.max_discharging_power * step_hours, -chargers.min_discharging_power)
    discharge = np.maximum(discharge, -chargers.max_discharging_power)
    return np.where(action > 0, charge, np.where(action < 0, discharge, 0.0))


def battery_request(energy: np.ndarray, efficiency: np.ndarray) -> np.ndarray:
    """What the charger asks of the EV battery [kWh]: ``energy * efficiency`` when charging, ``energy /
    efficiency`` when discharging (the battery gives more than the grid receives)."""
    return np.where(energy >= 0, energy * efficiency, energy / efficiency)


def charger_consumption(balance: np.ndarray, efficiency: np.ndarray, active: np.ndarray) -> np.ndarray:
    """Grid-side charger consumption [kWh] (C,) from the battery's energy balance [kWh]: balance /
    efficiency when >= 0, balance * efficiency when < 0; 0 where ``active`` is False (no EV or zero action)."""
    grid = np.where(balance >= 0, balance / efficiency, balance * efficiency)
    return np.where(active, grid, 0.0)


def plugged_ev(data: ChargerData, t: int) -> np.ndarray:
    """Index of the EV plugged into each charger at step ``t`` (C,), -1 where none (state not 1)."""
    return data.plugged[:, t]


def charge_plugged_evs(action: np.ndarray, soc_prev: np.ndarray, efficiency_prev: np.ndarray,
                       capacity_prev: np.ndarray, data: ChargerData, t: int, chargers: ChargerParams,
                       vehicles: ElectricVehicles, step_hours: float = 1.0, *,
                       efficiency_from_request: bool = False
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Step t of every charger: the action's energy through the charger into the plugged EV's battery.

    ``action`` (C,) in -1..1; ``soc_prev`` [-], ``efficiency_prev`` [-] and ``capacity_prev`` [kWh] are the
    EVs' (V,) states before the step. EVs that no charger acts on (unplugged, or zero action) are returned
    unchanged (upstream does not step them). Returns (SOC, efficiency, degraded capacity) per EV (V,), the
    charger consumption [kWh] (C,) and which EVs were stepped (V,) bool. The battery is the building
    battery model (:func:`citylearn_env.devices.battery_charge`; CityLearn 2.5 reads the battery efficiency
    at the request, ``efficiency_from_request=True``); each EV is at one charger at most."""
    eta = charger_efficiency(action, chargers)
    request = battery_request(charger_energy(action, chargers, step_hours), eta)
    ev = plugged_ev(data, t)
    active = (ev != NO_EV) & (action != 0)
    energy = np.zeros(len(vehicles.names))
    energy[ev[active]] = request[active]
    stepped = np.zeros(len(vehicles.names), dtype=bool)
    stepped[ev[active]] = True
    soc, balance, efficiency, capacity = battery_charge(energy, soc_prev, np.zeros_like(energy), vehicles.battery,
                                                        efficiency_prev, capacity_prev,
                                                        efficiency_from_request=efficiency_from_request)
    consumption = charger_consumption(np.where(active, balance[np.maximum(ev, 0)], 0.0), eta, active)
    return (np.where(stepped, soc, soc_prev), np.where(stepped, efficiency, efficiency_prev),
            np.where(stepped, capacity, capacity_prev), consumption, stepped)


def connection_soc(data: ChargerData, t: int) -> np.ndarray:
    """The connection rule at step t (C,): the SOC an EV newly plugged in at t is set to, NaN where no new
    connection or no usable value. New: state 1 at t, and t = 0 or row t-1 not state 1 with the same EV.
    Value: the estimated arrival SOC of row t-1 when row t-1 is state 2 or 3 (t > 0), else of row t; if
    missing (< 0), the required departure SOC of row t; NaN if that is missing too."""
    state, ev = data.state[:, t], data.ev[:, t]
    if t == 0:
        new = state == PARKED
        candidate = data.estimated_soc_arrival[:, 0]
    else:
        new = (state == PARKED) & ((data.state[:, t - 1] != PARKED) | (data.ev[:, t - 1] != ev))
        from_previous = data.state[:, t - 1] != PARKED  # state 2 or 3
        candidate = np.where(from_previous, data.estimated_soc_arrival[:, t - 1], data.estimated_soc_arrival[:, t])
    required = data.required_soc_departure[:, t]
    value = np.where(candidate >= 0, candidate, np.where(required >= 0, required, np.nan))
    return np.where(new & (ev != NO_EV), value, np.nan)


def away_soc(data: ChargerData, t: int, n_ev: int) -> tuple[np.ndarray, np.ndarray]:
    """The away rule's scan at step t < T - 1: returns (found (V,) bool, forced SOC (V,), NaN = unchanged).

    An EV is found at the first charger (in charger order) where it is plugged in at t, or where it
    connects at t + 1 (state 1 at t + 1 with it, state at t not 1); in the latter case its SOC at t is the
    estimated arrival SOC of row t when row t is state 2 with it, else of row t + 1, if within 0..1. EVs not
    found drift (:func:`drift_soc`)."""
    found = np.zeros(n_ev, dtype=bool)
    soc = np.full(n_ev, np.nan)
    for c in range(data.state.shape[0]):
        now, nxt = data.state[c, t], data.state[c, t + 1]
        ev_now, ev_next = data.ev[c, t], data.ev[c, t + 1]
        if now == PARKED and ev_now != NO_EV and not found[ev_now]:
            found[ev_now] = True
        if nxt == PARKED and now != PARKED and ev_next != NO_EV and not found[ev_next]:
            found[ev_next] = True
            incoming = now == INCOMING and ev_now == ev_next
            value = data.estimated_soc_arrival[c, t if incoming else t + 1]
            soc[ev_next] = value if 0.0 <= value <= 1.0 else np.nan
    return found, soc


def advance_soc(soc_prev: np.ndarray, soc_now: np.ndarray, data: ChargerData, t: int,
                draw: Callable[[int], Sequence[float]] | None = None) -> np.ndarray:
    """The EVs' SOC at step t (V,) after the advance into t, before the actions (docs/ev.md section 3).

    ``soc_prev`` is SOC(t - 1) and ``soc_now`` the SOC(t) stored so far (upstream: 0 unless written);
    ``data`` covers the episode (its last column is the episode's last step).
    Away rule (0 < t < T - 1; not at reset): EVs connecting at t + 1 take their arrival SOC, EVs in no
    charger drift from SOC(t - 1) by ``draw(k)`` (k numbers of N(1, 0.2), one per drifting EV, in EV
    order; e.g. ``lambda k: rng.normal(1.0, 0.2, k)``, needed whenever an EV drifts); then the connection
    rule forces the SOC of EVs newly plugged in at t. At reset (t = 0) only the connection rule runs."""
    soc = soc_now.astype(np.float64, copy=True)
    if 0 < t < data.state.shape[1] - 1:
        found, forced = away_soc(data, t, len(soc))
        soc = np.where(np.isnan(forced), soc, forced)
        drifting = ~found
        if drifting.any():
            soc[drifting] = drift_soc(soc_prev[drifting], np.asarray(draw(int(drifting.sum())), dtype=np.float64))
    arrival = connection_soc(data, t)
    new = ~np.isnan(arrival)
    soc[data.ev[new, t]] = arrival[new]
    return soc


def drift_soc(soc_prev: np.ndarray, draws: np.ndarray) -> np.ndarray:
    """SOC of an away EV [-]: previous SOC times the draw of N(1, 0.2) clipped to 0.6..1.4, within 0..1."""
    return np.clip(soc_prev * np.clip(draws, 0.6, 1.4), 0.0, 1.0)


def energy_to_required_soc(soc: np.ndarray, required_soc: np.ndarray, capacity: np.ndarray) -> np.ndarray:
    """Battery-side energy still needed to reach the required departure SOC [kWh] (>= 0); 0 where the
    requirement is missing (< 0)."""
    return np.where(required_soc >= 0, np.maximum(required_soc - soc, 0.0) * capacity, 0.0)


def departure_shortfall(soc: np.ndarray, data: ChargerData, t: int) -> np.ndarray:
    """Per charger (C,): how far the plugged EV's SOC is below its required SOC [-] when it leaves at step
    t (departure time 0 in state 1); 0 for chargers without a departing EV. ``soc`` is per EV (V,)."""
    ev = plugged_ev(data, t)
    leaving = (ev != NO_EV) & (data.departure_time[:, t] == 0) & (data.required_soc_departure[:, t] >= 0)
    gap = data.required_soc_departure[:, t] - soc[np.maximum(ev, 0)]
    return np.where(leaving, np.maximum(gap, 0.0), 0.0)
