"""The storage problem of one episode, read from a reset :class:`citylearn_env.CityLearnEnv` (its own typed
parameters and episode series, never the JSON), as plain arrays the linear program is built from.

Time: an episode has T steps; step 0 is never controlled (the env books the data-set loads at reset), the
n = T - 1 controlled steps are indexed i = 0 .. n - 1 for episode step t = i + 1. Energies are kWh per step,
"device-side" storage energy is what the storage exchanges with its device (thermal kWh for a tank, AC kWh for
a battery): a positive value charges, a negative one discharges (the env's ``energy_balance``).

What the env does that is not linear, and what the plant keeps of it (see also :mod:`pipeline.optimal.lp`):

* an undersized heat pump or heater (demand above nominal power x COP) leaves demand unmet; a tank discharge
  there first covers the unmet part, which saves nothing -- the plant forbids discharging at those steps;
* during a power outage a building's net consumption is 0 and its draws are capped by the PV left over: the
  plant lets its storages charge only from the PV surplus after every load (a restriction, never violated);
* the battery's round-trip efficiency depends on its power and its usable capacity fades with throughput:
  the plant holds them as per-step arrays that :mod:`pipeline.optimal.oracle` refreshes from the schedule.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from citylearn_env import devices
from citylearn_env.state import END_USE_SLOTS, EndUseParams, TankParams
from pipeline.errors import InputError

BATTERY_SLOT = "electrical_storage"
#: a demand above nominal power x COP by more than this [kWh] counts as an undersized device
UNDERSIZED_TOLERANCE = 1e-9
#: behaviour fields (citylearn_env.settings) whose physics the plant does not follow (CityLearn 2.5's step
#: timing, its row-0 bookkeeping and its tank-scaling mix-up): an env with one of them on is refused
UNSUPPORTED_SETTINGS = ("act_then_advance", "first_step_booked_three_times", "storage_action_scaled_by_other_tank")


@dataclass(frozen=True, eq=False)
class BatteryTerms:
    """What only a battery has. ``nominal_power`` [kW]; ``lines`` (K, 2): (alpha, beta) of each segment of the
    capacity-power curve, power limit = nominal x min_k(alpha + beta x SOC); ``floor`` [kWh]: the depth-of-
    discharge floor (1 - DoD) x capacity; ``efficiency``: the power-efficiency curve (x = |energy| / nominal
    power, y = round trip); ``one_way_prev`` (n,): sqrt of the previous step's round-trip efficiency (the env's
    depth-of-discharge limit uses it); ``usable_capacity`` (n,) [kWh]: the faded capacity at the start of step
    i; ``capacity_loss`` [-]: the capacity-fade coefficient; ``extrapolate``: the 2.1 curve quirk;
    ``power_points`` (2, K): the capacity-power curve's points (x = SOC, y = fraction of nominal power; the
    relaxation of :mod:`pipeline.optimal.relax` takes their concave majorant; None: ``lines`` are exact)."""

    nominal_power: float
    lines: np.ndarray
    floor: float
    efficiency: devices.Curve
    one_way_prev: np.ndarray
    usable_capacity: np.ndarray
    capacity_loss: float
    initial_efficiency: float
    extrapolate: bool
    power_points: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Storage:
    """One controllable storage of building ``building`` (index) in ``slot`` over the n controlled steps.

    ``capacity`` [kWh]; ``retention`` = 1 - standing loss per step; ``initial_energy`` [kWh] at t = 0;
    ``one_way`` (n,) [-]: sqrt of the round-trip efficiency; ``electricity`` (n,) [kWh electric per kWh
    device-side]: 1 / COP for a tank, 1 for a battery; ``charge_max`` / ``discharge_max`` (n,) [kWh per step]:
    the limits that do not depend on the state of charge; ``action_scale`` [kWh per unit of action];
    ``low`` / ``high`` (n,) [kWh]: a window the device-side energy must stay in (None: none; the oracle's
    trust region around its last plan, see :func:`trust`); ``relaxed_discharge`` (n,) [kWh per step]: a tank's
    discharge limit with the undersized-device restriction lifted (the relaxation's; None: ``discharge_max``);
    ``tangent``: (gain, cost, offset) (n,) each, the balance linearised around a plan (the oracle's polish,
    :mod:`pipeline.optimal.polish`): E_i = a E_(i-1) + offset_i + gain_i c_i - cost_i d_i (None: ``one_way``);
    ``end_use``: a tank's end use (None: the battery)."""

    building: int
    slot: str
    capacity: float
    retention: float
    initial_energy: float
    one_way: np.ndarray
    electricity: np.ndarray
    charge_max: np.ndarray
    discharge_max: np.ndarray
    action_scale: float
    battery: BatteryTerms | None = None
    low: np.ndarray | None = None
    high: np.ndarray | None = None
    relaxed_discharge: np.ndarray | None = None
    tangent: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    end_use: str | None = None

    def window(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) [kWh] of the device-side energy per step, (n,) each."""
        n = self.one_way.size
        return (np.full(n, -np.inf) if self.low is None else self.low,
                np.full(n, np.inf) if self.high is None else self.high)


@dataclass(frozen=True, eq=False)
class Plant:
    """A district's storage problem over one episode. ``base_net`` (B, T) [kWh]: each building's net consumption
    with every storage idle (0 during its outages); ``price`` [$ / kWh] and ``carbon`` [kg / kWh] (B, T);
    ``outage`` (B, T) bool; ``surplus`` (B, T) [kWh]: PV left after every load at an outage step (0 elsewhere);
    ``storages``: the controllable ones (capacity > 0 and an active action). For a window of an episode (MPC,
    :mod:`pipeline.optimal.window`): ``day_offset`` [steps] of the first day already run before step 0 (days are
    blocks of 24 steps from the episode start), ``peak_floor`` [kW] that day's running district peak so far,
    and ``episode_steps`` the episode's T that scales the peak's weight (0: this plant's own T). ``end_uses``:
    the env's parameters of each end use (devices and tanks; what :func:`base_net` and :func:`tank_storage`
    rebuild a window from) and ``pv_nominal_power`` (B,) [kW]."""

    building_names: tuple[str, ...]
    base_net: np.ndarray
    price: np.ndarray
    carbon: np.ndarray
    outage: np.ndarray
    surplus: np.ndarray
    storages: tuple[Storage, ...]
    end_uses: tuple[EndUseParams, ...] = ()
    pv_nominal_power: np.ndarray | None = None
    day_offset: int = 0
    peak_floor: float = -np.inf
    episode_steps: int = 0

    @property
    def steps(self) -> int:
        """T, the episode length (the n = T - 1 controlled steps come after step 0)."""
        return self.base_net.shape[1]

    def only(self, buildings: Sequence[int]) -> Plant:
        """The plant restricted to ``buildings`` (indices; storages renumbered to the new order)."""
        keep = list(buildings)
        index = {b: i for i, b in enumerate(keep)}
        return dataclasses.replace(
            self, building_names=tuple(self.building_names[b] for b in keep), base_net=self.base_net[keep],
            price=self.price[keep], carbon=self.carbon[keep], outage=self.outage[keep], surplus=self.surplus[keep],
            storages=tuple(dataclasses.replace(s, building=index[s.building]) for s in self.storages
                           if s.building in index),
            end_uses=tuple(_params_of(p, keep) for p in self.end_uses),
            pv_nominal_power=None if self.pv_nominal_power is None else self.pv_nominal_power[keep])


def _params_of(p: EndUseParams, keep: list[int]) -> EndUseParams:
    """End use ``p``'s parameters of the buildings ``keep`` (indices), in that order."""
    tank = TankParams(*(getattr(p.tank, f.name)[keep] for f in dataclasses.fields(TankParams)))
    return dataclasses.replace(p, nominal_power=p.nominal_power[keep], cop=p.cop[keep], demand=p.demand[keep],
                               tank=tank)


def base_net(non_shiftable: np.ndarray, end_uses: Sequence[EndUseParams], demands: Mapping[str, np.ndarray],
             cops: Mapping[str, np.ndarray], pv: np.ndarray, outage: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each building's net consumption with every storage idle and the PV surplus at its outage steps, (B, T)
    each [kWh per step]: the ``non_shiftable`` load [kWh] plus the electricity of the devices serving the
    thermal ``demands`` [kWh] at their ``cops`` [-] (per end use name; the env's device model, demand above
    nominal power x COP unmet; an end use no building can ever use skipped, as the env skips it), less the
    ``pv`` generation [kWh]; the net is 0 where ``outage`` (bool), the surplus max(0, pv - loads) there and
    0 elsewhere."""
    loads = np.array(non_shiftable, dtype=float)
    for p in end_uses:
        if p.live:
            loads += devices.device_output(demands[p.name], p.nominal_power[:, None], cops[p.name], np.inf)[1]
    return np.where(outage, 0.0, loads - pv), np.where(outage, np.maximum(0.0, pv - loads), 0.0)


def plant_from_env(env) -> Plant:
    """The storage problem of ``env``'s current episode (call after ``env.reset``). Reads the district's
    parameters, COPs, demands, PV, prices, carbon intensity and outage signal; storages whose action is not in
    the action vector are left out (they only lose their initial charge)."""
    _check_supported(env)
    d = env.district
    e = d.episode
    outage = e.outage > 0
    params = tuple(u.params for u in d.end_uses)
    base, surplus = base_net(e["non_shiftable_load"], params, {u.params.name: u.demand_data for u in d.end_uses},
                             {u.params.name: u.cop for u in d.end_uses}, e.pv_generation, outage)
    base[:, 0] = d.building_record.net_electricity_consumption[:, 0]
    active = set(env.action_pairs)
    storages = [_tank(u, b, d) for u in d.end_uses for b in range(d.n)
                if u.params.tank.capacity[b] > 0 and (END_USE_SLOTS[u.params.name].action, b) in active]
    storages += [_battery(d, env.settings, b) for b in range(d.n) if (BATTERY_SLOT, b) in active
                 and d.battery.capacity[b] > 0 and d.battery.nominal_power[b] > 0]
    return Plant(building_names=tuple(env.building_names), base_net=base,
                 price=np.asarray(e["electricity_pricing"], dtype=float),
                 carbon=np.asarray(e["carbon_intensity"], dtype=float), outage=outage, surplus=surplus,
                 storages=tuple(storages), end_uses=params, pv_nominal_power=d.pv_nominal_power)


def _check_supported(env) -> None:
    """Refuse (one clear error) what the plant does not model: the settings of :data:`UNSUPPORTED_SETTINGS`,
    EV chargers and washing machines."""
    on = [f for f in UNSUPPORTED_SETTINGS if getattr(env.settings, f, False)]
    if on:
        raise InputError(f"the oracle follows CityLearn 2.1's step timing and tank scaling; these behaviour "
                         f"settings are on: {', '.join(on)} (use the default or the citylearn-2.1 preset)",
                         column="settings")
    if env.district.ev is not None or env.district.machines is not None:
        raise InputError("the oracle plans building storage; districts with EV chargers or washing machines are "
                         "not supported yet", column="electric_vehicles_def")


def _tank(u, b: int, d) -> Storage:
    """Tank of end use ``u`` (an EndUseState) in building ``b`` over the episode's controlled steps."""
    return tank_storage(u.params, b, u.cop[b, 1:], u.demand_data[b, 1:])


def tank_storage(p: EndUseParams, b: int, cop: np.ndarray, demand: np.ndarray) -> Storage:
    """Tank of end use ``p`` (its parameters) in building ``b`` at the device ``cop`` [-] and thermal ``demand``
    [kWh] (n,) of the steps planned: charge up to the device's headroom nominal x COP - demand, discharge up to
    the demand (none where the device is undersized); starting from the tank's initial state."""
    tank = p.tank
    reach = p.nominal_power[b] * cop
    undersized = demand > reach + UNDERSIZED_TOLERANCE
    n = cop.size
    return Storage(
        building=b, slot=END_USE_SLOTS[p.name].storage, capacity=float(tank.capacity[b]),
        retention=1.0 - float(tank.loss_coefficient[b]), initial_energy=float(tank.initial_soc[b] * tank.capacity[b]),
        one_way=np.full(n, float(tank.one_way_efficiency[b])), electricity=1.0 / cop,
        charge_max=np.minimum(np.maximum(0.0, reach - demand), tank.max_input_power[b]),
        discharge_max=np.where(undersized, 0.0, np.minimum(demand, tank.max_output_power[b])),
        action_scale=float(tank.capacity[b]), relaxed_discharge=np.minimum(demand, tank.max_output_power[b]),
        end_use=p.name)


def curve_lines(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(alpha, beta) of every segment of a piecewise-linear curve (zero-width segments dropped), (K, 2):
    y = alpha + beta x on the segment. For a concave curve min_k(alpha_k + beta_k x) equals the curve; for any
    other it is below it (a restriction)."""
    dx, dy = np.diff(xs), np.diff(ys)
    keep = dx > 0
    beta = dy[keep] / dx[keep]
    alpha = ys[:-1][keep] - beta * xs[:-1][keep]
    if not keep.any():  # a single point: a constant
        return np.array([[float(ys[0]), 0.0]])
    return np.unique(np.stack([alpha, beta], axis=1), axis=0)


def _battery(d, settings, b: int) -> Storage:
    """Battery of building ``b``: its curves, floor and initial state; efficiency and usable capacity start at
    the schema's efficiency and the nominal capacity (the oracle refreshes them from its schedule)."""
    bat = d.battery
    n = d.length - 1
    capacity, nominal = float(bat.capacity[b]), float(bat.nominal_power[b])
    curve = bat.power_efficiency
    efficiency = devices.Curve.from_points([tuple(zip(curve.xs[b], curve.ys[b], strict=True))])
    scale = nominal * d.step_hours if settings.battery_action_fraction_of_nominal_power else capacity
    one_way = np.full(n, float(np.sqrt(bat.efficiency[b])))
    terms = BatteryTerms(
        nominal_power=nominal, lines=curve_lines(bat.capacity_power.xs[b], bat.capacity_power.ys[b]),
        floor=max(0.0, (1.0 - float(bat.depth_of_discharge[b])) * capacity), efficiency=efficiency,
        one_way_prev=one_way.copy(), usable_capacity=np.full(n, capacity),
        capacity_loss=float(bat.capacity_loss_coefficient[b]), initial_efficiency=float(bat.efficiency[b]),
        extrapolate=bool(settings.battery_curve_extrapolates_first_segment),
        power_points=np.stack([bat.capacity_power.xs[b], bat.capacity_power.ys[b]]))
    return Storage(
        building=b, slot=BATTERY_SLOT, capacity=capacity, retention=1.0 - float(bat.loss_coefficient[b]),
        initial_energy=float(bat.initial_soc[b] * capacity), one_way=one_way, electricity=np.ones(n),
        charge_max=np.full(n, nominal), discharge_max=np.full(n, np.inf), action_scale=scale, battery=terms)


def battery_path(storage: Storage, energy: np.ndarray) -> Storage:
    """``storage`` (a battery) with its per-step efficiencies and usable capacity as the env computes them for
    the device-side ``energy`` (n,) [kWh]: round trip from the power-efficiency curve at |energy| / nominal
    power, capacity fading by capacity_loss x C x |energy| / (2 x usable capacity) from the usable capacity at
    the start of step 0 (which no schedule changes)."""
    terms = storage.battery
    x = np.abs(energy) / terms.nominal_power
    rows = np.zeros(x.size, dtype=np.intp)
    efficiency = devices.interpolate_curve(x, _rows(terms.efficiency, rows), extrapolate_first_segment=terms.extrapolate)
    one_way = np.sqrt(efficiency)
    start = float(terms.usable_capacity[0]) if terms.usable_capacity.size else storage.capacity
    usable = faded(start, terms.capacity_loss * storage.capacity / 2.0, np.abs(energy))
    prev = np.concatenate([[np.sqrt(terms.initial_efficiency)], one_way[:-1]])
    return dataclasses.replace(storage, one_way=one_way, battery=dataclasses.replace(
        terms, one_way_prev=prev, usable_capacity=usable))


def trust(storage: Storage, energy: np.ndarray, radius: float) -> Storage:
    """``storage`` with its device-side energy held within ``radius`` [kWh] of ``energy`` (n,) at every step:
    a trust region around the last plan, so that the efficiencies read from it stay right (nearly) whatever the
    next solve does."""
    return dataclasses.replace(storage, low=energy - radius, high=energy + radius)


def path_error(storage: Storage, energy: np.ndarray, held: np.ndarray) -> float:
    """How far a planned battery path is from the env's physics [kWh]: the largest of |E_env - E_plan| when the
    device-side ``energy`` (n,) runs through ``storage``'s (refreshed) efficiencies, the largest discharge beyond
    the env's depth-of-discharge limit, and the largest charge beyond its free faded capacity."""
    terms, a = storage.battery, storage.retention
    stored = np.where(energy >= 0, energy * storage.one_way, energy / storage.one_way)
    path = levels(storage.initial_energy, a, stored)
    before = np.concatenate([[storage.initial_energy], held[:-1]])
    floor = terms.one_way_prev * np.maximum(before - terms.floor, 0.0)
    room = terms.usable_capacity - a * before
    beyond = np.maximum(np.maximum(-energy - floor, energy - room), 0.0)
    return float(max(np.abs(path - held).max(initial=0.0), beyond.max(initial=0.0)))


def faded(start: float, k: float, throughput: np.ndarray) -> np.ndarray:
    """Usable capacity [kWh] at the start of each step when it fades as u_(i+1) = u_i - k x throughput_i / u_i
    (the env's fade; ``k`` = capacity_loss x C / 2 [kWh], ``throughput`` [kWh] per step): the recursion's fixed
    point u_i = start - k x sum_(j<i) throughput_j / u_j, iterated from u = start (the fade is tiny, each round
    cuts the error ~50-fold: six rounds match the step-by-step recursion to ~1e-12 kWh over a year), floored
    at 0."""
    usable = np.full(throughput.size, start)
    for _ in range(6):
        spent = np.concatenate([[0.0], np.cumsum(throughput / np.maximum(usable, 1e-12))[:-1]])
        usable = np.maximum(start - k * spent, 0.0)
    return usable


def levels(start: float, retention: float, stored: np.ndarray) -> np.ndarray:
    """Energy held after each step [kWh], E_i = retention x E_(i-1) + stored_i from E_(-1) = ``start``."""
    if retention == 1.0:
        return start + np.cumsum(stored)
    out = np.empty_like(stored)
    level = start
    for i, value in enumerate(stored):  # sequential; only batteries with a standing loss come here
        level = retention * level + value
        out[i] = level
    return out


def _rows(curve: devices.Curve, rows: np.ndarray) -> devices.Curve:
    """One building's curve repeated for ``rows.size`` evaluations (interpolate_curve works per row)."""
    return devices.Curve(curve.xs[rows], curve.ys[rows], curve.slopes[rows])
