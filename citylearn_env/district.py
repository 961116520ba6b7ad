"""The district: typed state of all buildings and the per-step order of operations (CityLearn 2.1).

:meth:`District.step` advances to t + 1 and acts there (CityLearn 2.1's timing); with ``settings.act_then_advance``
the env calls :meth:`District.act` at t and then :meth:`District.advance` (CityLearn 2.5's), and row 0, acted on
then, starts from the reset's state.

Every quantity is a numpy array with one element per building; a step advances all buildings together.
Order inside a step (per building, expressed with masks): the thermal model turns device actions into demands
(LSTM buildings) -> battery if it discharges -> for cooling, heating, DHW: device then storage (storage first if
it discharges) -> non-shiftable load -> battery if it charges -> EV chargers -> washing machines (CityLearn
2.5's order; docs/ev.md section 3) -> the thermal model predicts the indoor temperature. Before the actions
the EVs' away and connection rules run at the new step (docs/ev.md section 10: this env's 2.1 step timing).
During a power outage every draw is capped by the building's remaining supply (PV minus what was already
booked this step; EV chargers and washing machines are not capped) and net consumption is 0. Energies are kWh
per step.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import fields, replace
from functools import partial
from types import MappingProxyType

import numpy as np

from citylearn_env import backends, device_kernels, devices, ev, washing_machine
from citylearn_env.actions import Actions
from citylearn_env.config import DistrictConfig
from citylearn_env.dataset import NAME_ALIASES
from citylearn_env.occupant import OccupantModel
from citylearn_env.settings import CORRECTED, Behaviour
from citylearn_env.state import (
    COP_OBSERVATIONS,
    DELIVERED_OBSERVATIONS,
    END_USE_SLOTS,
    END_USES,
    OCCUPANT_DELTA,
    SET_POINT_DELTAS,
    STATIC_ALIASES,
    BatteryRecord,
    BuildingRecord,
    ChargerRecord,
    ElectricVehicleRecord,
    EndUseParams,
    EndUseRecord,
    EndUseState,
    Signals,
    TankParams,
    WashingMachineRecord,
    recorded_names,
)
from citylearn_env.thermal import ThermalModel

#: draws k numbers of N(1, 0.2) for the SOC drift of away EVs (docs/ev.md section 3)
DriftDraw = Callable[[int], Sequence[float]]


def _stack(values) -> np.ndarray:
    return np.asarray(list(values), dtype=np.float64)


def _same_memory(a: np.ndarray, b: np.ndarray) -> bool:
    """``a`` and ``b`` are the same values in the same memory (one array, or equal views of one buffer)."""
    return a is b or (a.__array_interface__["data"][0] == b.__array_interface__["data"][0]
                      and a.shape == b.shape and a.strides == b.strides and a.dtype == b.dtype)


def shared_rows(rows: Sequence[np.ndarray]) -> np.ndarray:
    """The buildings' series ``rows`` (each (N,)) as one read-only (B, N) array. Where every building's row is
    the same memory (a file all buildings name, or a column the schema loader found identical and stored
    once) the result is that row broadcast (stride 0: N values held, not B x N); otherwise a stacked copy."""
    first = rows[0]
    if all(_same_memory(r, first) for r in rows[1:]):
        return np.broadcast_to(first, (len(rows), *first.shape))
    out = np.stack(rows)
    out.flags.writeable = False
    return out


def _previous(t: int) -> int:
    """The column holding the state before step ``t``: t - 1, or the reset's column 0 when t = 0 is acted on
    (``settings.act_then_advance``)."""
    return t - 1 if t > 0 else 0


class District:
    """Parameters, data series and the recorded episode of a district; :meth:`step` advances it.

    ``settings`` chooses upstream behaviour (:mod:`citylearn_env.settings`). Buildings with LSTM dynamics get
    a :class:`citylearn_env.thermal.ThermalModel`, owned and stepped here. ``backend``: "auto" (the compiled
    battery and storage kernels of :mod:`citylearn_env.device_kernels` when numba is installed, else the numpy
    functions of :mod:`citylearn_env.devices`; the same numbers either way), "numba" or "numpy".
    """

    def __init__(self, config: DistrictConfig, *, settings: Behaviour = CORRECTED, backend: str = "auto"):
        self.config, self.settings = config, settings
        self.use_backend(backend)
        b = config.buildings
        self.n = len(b)
        self.names = config.building_names
        columns = {k: shared_rows([x.series[k] for x in b]) for k in b[0].series}
        self.pv_nominal_power = _stack(x.pv_nominal_power for x in b)
        pv = devices.pv_generation(self.pv_nominal_power[:, None], columns["solar_generation"])
        self.signals = Signals(MappingProxyType(columns), pv, columns["power_outage"])
        self.end_use_params = tuple(self._end_use_params(k) for k in END_USES)
        self.battery = self._battery_params()
        self.step_hours = config.seconds_per_time_step / 3600.0
        #: kWh per unit of battery action: capacity (CityLearn 2.1) or nominal power x step hours (2.5)
        self._battery_scale = self.battery.nominal_power * self.step_hours \
            if settings.battery_action_fraction_of_nominal_power else self.battery.capacity
        #: kWh per unit of each end use's storage action: its own tank's capacity, or CityLearn 2.5's mix-up
        #: (``settings.storage_action_scaled_by_other_tank``: DHW by the heating tank, heating by the cooling tank)
        self._storage_scale = self._storage_scales(settings.storage_action_scaled_by_other_tank)
        self.dynamics = np.array([x.has_dynamics for x in b])
        self.thermal = ThermalModel(b, self.dynamics, settings, backend) if self.dynamics.any() else None
        self.inf = np.full(self.n, np.inf)
        self.zeros = np.zeros(self.n)  # read-only stand-in: nothing booked on a battery before it runs
        self.zeros.flags.writeable = False
        self._scratch = np.zeros((4, self.n))  # outputs a step does not keep (B,) x 4
        self.t, self.length = 0, 0
        self.ev = config.electric_vehicles if config.electric_vehicles is not None and \
            config.electric_vehicles.chargers.names else None
        self.machines = config.washing_machines
        occupants = [(i, x.occupant) for i, x in enumerate(b) if x.occupant is not None]
        #: the occupants' set-point overrides (None: no occupant building, nothing runs per step)
        self.occupants = OccupantModel(occupants, self.n) if occupants else None

    # ------------------------------------------------------------------ construction
    def use_backend(self, backend: str) -> None:
        """Step the end uses and batteries with the compiled kernels ("numba", or "auto" with numba installed)
        or the numpy reference functions ("numpy"); the numbers are the same."""
        kernels = backends.compiled(backend, device_kernels.get_kernels)
        self.backend = "numba" if kernels is not None else "numpy"
        self._serve_end_use = partial(device_kernels.serve_end_use_into, kernels=kernels)
        self._battery_charge = partial(device_kernels.battery_charge_into, kernels=kernels)
        if getattr(self, "thermal", None) is not None:
            self.thermal.use_backend(backend)

    def _end_use_params(self, k: str) -> EndUseParams:
        b = self.config.buildings
        slots = END_USE_SLOTS[k]
        devs = [getattr(x, slots.device) for x in b]
        tanks = [getattr(x, slots.storage) for x in b]
        tank = TankParams(
            capacity=_stack(t.capacity for t in tanks), loss_coefficient=_stack(t.loss_coefficient for t in tanks),
            one_way_efficiency=np.sqrt(_stack(t.efficiency for t in tanks)),
            initial_soc=_stack(t.initial_soc for t in tanks), max_input_power=_stack(t.max_input_power for t in tanks),
            max_output_power=_stack(t.max_output_power for t in tanks))
        nominal = _stack(d.nominal_power for d in devs)
        demand = self.signals[slots.demand]
        return EndUseParams(
            name=k, nominal_power=nominal, cop=self._conversion(devs, k), demand=demand, tank=tank,
            live=bool((nominal > 0).any() or (tank.capacity > 0).any() or (demand > 0).any()),
            has_storage=bool((tank.capacity > 0).any()))

    def _conversion(self, devs, end_use: str) -> np.ndarray:
        """COP (heat pump) or efficiency (heater) of each building's device for ``end_use``, (B, N), read-only.

        Computed once per distinct (device kind, efficiency, target temperature, outdoor temperature row):
        one distinct row (the same device everywhere under one weather file) is held once and broadcast."""
        cooling = end_use == "cooling"
        outdoor = self.signals["outdoor_dry_bulb_temperature"]
        shared_weather = outdoor.strides[0] == 0
        keys = [(d.kind, d.efficiency, d.target_cooling_temperature if cooling else d.target_heating_temperature,
                 0 if shared_weather else b) for b, d in enumerate(devs)]
        first: dict[tuple, int] = {}
        inverse = np.array([first.setdefault(k, len(first)) for k in keys], dtype=np.intp)
        distinct = list(first)
        table = devices.conversion_table([k[0] for k in distinct], [k[1] for k in distinct],
                                         [k[2] for k in distinct], outdoor[[k[3] for k in distinct]],
                                         cooling=cooling)
        cop = np.broadcast_to(table[0], (self.n, table.shape[1])) if len(distinct) == 1 else table[inverse]
        cop.flags.writeable = False
        return cop

    def _battery_params(self) -> devices.BatteryParams:
        bat = [x.electrical_storage for x in self.config.buildings]
        return devices.BatteryParams(
            capacity=_stack(x.capacity for x in bat), nominal_power=_stack(x.nominal_power for x in bat),
            efficiency=_stack(x.efficiency for x in bat), loss_coefficient=_stack(x.loss_coefficient for x in bat),
            capacity_loss_coefficient=_stack(x.capacity_loss_coefficient for x in bat),
            depth_of_discharge=_stack(x.depth_of_discharge for x in bat),
            initial_soc=_stack(x.initial_soc for x in bat),
            power_efficiency=devices.Curve.from_points([x.power_efficiency_curve for x in bat]),
            capacity_power=devices.Curve.from_points([x.capacity_power_curve for x in bat]))

    def _storage_scales(self, other_tank: bool) -> dict[str, np.ndarray]:
        """End use -> (B,) kWh per unit of its storage action: its tank's capacity [kWh], or with ``other_tank``
        CityLearn 2.5's: cooling by the cooling tank, heating by the cooling tank, DHW by the heating tank."""
        capacity = {p.name: p.tank.capacity for p in self.end_use_params}
        if not other_tank:
            return capacity
        return {"cooling": capacity["cooling"], "heating": capacity["cooling"], "dhw": capacity["heating"]}

    def end_use(self, name: str) -> EndUseState:
        """The episode state of end use ``name`` (cooling, heating or dhw)."""
        return self.end_uses[END_USES.index(name)]

    def _resolve_dynamic(self) -> None:
        """Per episode, where :meth:`dynamic_value` reads its answers: the (B, T) record of each recorded
        observation that no derived one shadows, and the (device, storage) records of each delivered energy."""
        derived = {*DELIVERED_OBSERVATIONS, "indoor_dry_bulb_temperature_delta", *SET_POINT_DELTAS, OCCUPANT_DELTA,
                   *OccupantModel.SET_POINTS}
        self._recorded_series = {k: v for k, v in self.recorded.items() if k not in derived}
        self._delivered = {name: (self.end_use(u).record.energy_from_device, self.end_use(u).record.energy_from_storage)
                           for name, u in DELIVERED_OBSERVATIONS.items()}

    def dynamic_value(self, name: str, t: int) -> np.ndarray:
        """The (B,) value of dynamic observation ``name`` (:data:`citylearn_env.state.DYNAMIC`) at episode
        step ``t``: delivered energy [kWh], |T - T_set| or T - T_set [degC], or a recorded quantity."""
        series = self._recorded_series.get(name)
        if series is not None:
            return series[:, t]
        records = self._delivered.get(name)
        if records is not None:
            return records[0][:, t] + records[1][:, t]
        if name == "indoor_dry_bulb_temperature_delta":
            setpoint = self.episode["indoor_dry_bulb_temperature_set_point"][:, t]
            return np.abs(self.building_record.indoor_dry_bulb_temperature[:, t] - setpoint)
        column = SET_POINT_DELTAS.get(name)
        if column is not None:
            return self.building_record.indoor_dry_bulb_temperature[:, t] - self.episode[column][:, t]
        if name == OCCUPANT_DELTA:
            return self.occupants.delta[:, t] if self.occupants is not None else self.zeros
        if name in OccupantModel.SET_POINTS:  # dynamic only where occupants override them
            return self.episode[name][:, t]
        return self.recorded[name][:, t]

    def static_series(self, name: str, *, full_range: bool = False) -> np.ndarray | None:
        """The (B, T) episode series (or (B, N) over the simulation range) of a data observation (a data
        column, an alias of one, a device COP, the PV generation [kWh]); None if unknown."""
        if name == "solar_generation":
            return self.signals.pv_generation if full_range else self.episode.pv_generation
        end_use = COP_OBSERVATIONS.get(name)
        if end_use is not None:
            params = self.end_use_params[END_USES.index(end_use)]
            return params.cop if full_range else self.end_use(end_use).cop
        columns = (self.signals if full_range else self.episode).columns
        if name in columns:
            return columns[name]
        return columns.get(STATIC_ALIASES.get(name) or NAME_ALIASES.get(name, name))

    # ------------------------------------------------------------------ episode
    def reset(self, start: int, length: int, outage: np.ndarray, drift: DriftDraw | None = None,
              occupant_seed: int = 0) -> None:
        """Start an episode over simulation rows ``start .. start+length-1``; ``outage`` is (B, length) 0/1;
        ``drift`` draws the SOC drift of away EVs (needed when the district has EVs); ``occupant_seed`` seeds the
        occupants' draws (:mod:`citylearn_env.occupant`).

        At t = 0 nothing is controlled: devices serve the data-set demands and storages hold their initial SOC;
        EVs hold their initial SOC, or their arrival SOC when plugged in at t = 0.
        """
        n = self.n
        self.t, self.length = 0, length
        self.episode = self.signals.window(start, length, outage.astype(np.float64))
        if self.occupants is not None:  # set points the occupants override: writable copies
            columns = self.occupants.reset(self.episode.columns, start, length, occupant_seed)
            self.episode = Signals(MappingProxyType({**self.episode.columns, **columns}),
                                   self.episode.pv_generation, self.episode.outage)
        e = self.episode
        self._outage_steps = (outage > 0).any(axis=0)  # (T,): some building is out at that step
        self.end_uses = tuple(
            EndUseState(p, p.cop[:, start:start + length], p.demand[:, start:start + length],
                        EndUseRecord.zeros(n, length)) for p in self.end_use_params)
        self.battery_record = BatteryRecord.zeros(n, length)
        self.building_record = BuildingRecord.zeros(n, length)
        self.building_record.indoor_dry_bulb_temperature[:] = e["indoor_dry_bulb_temperature"]
        if self.settings.act_then_advance:  # a row not acted on yet serves its ideal load (CityLearn 2.5)
            self.building_record.non_shiftable_load_served[:] = e["non_shiftable_load"]
        total = e["non_shiftable_load"][:, 0].copy()
        for u in self.end_uses:
            r = u.record
            r.demand[:] = u.demand_data
            if self.settings.act_then_advance:  # a row not acted on yet delivers its ideal load (CityLearn 2.5)
                r.energy_from_device[:] = u.demand_data
            r.storage_soc[:, 0] = u.params.tank.initial_soc
            r.energy_from_device[:, 0] = u.demand_data[:, 0]
            r.electricity_consumption[:, 0] = u.demand_data[:, 0] / u.cop[:, 0]
            total += r.electricity_consumption[:, 0]
        bat = self.battery_record
        bat.soc[:, 0] = self.battery.initial_soc
        bat.efficiency[:, 0] = self.battery.efficiency
        bat.capacity[:, 0] = self.battery.capacity
        self.building_record.non_shiftable_load_served[:, 0] = e["non_shiftable_load"][:, 0]
        net = total - e.pv_generation[:, 0]
        self.building_record.net_electricity_consumption[:, 0] = np.where(outage[:, 0] > 0, 0.0, net)
        with_ev = self.ev is not None or self.machines is not None
        self.recorded = recorded_names({u.params.name: u.record for u in self.end_uses}, bat, self.building_record,
                                       with_ev=with_ev)
        self._resolve_dynamic()
        if with_ev:
            self._reset_ev(start, length, drift)
        if self.thermal is not None:
            self.thermal.reset(e["hvac_mode"], self.static_series,
                               OccupantModel.SET_POINTS if self.occupants is not None else ())

    def _reset_ev(self, start: int, length: int, drift: DriftDraw | None) -> None:
        """Episode state of chargers, EVs and washing machines. Their rows start at the episode's first
        simulation row, or at the range start when ``settings.ev_data_from_range_start`` (CityLearn 2.5)."""
        first = 0 if self.settings.ev_data_from_range_start else start
        self.ev_first_row, self._drift = first, drift
        if self.ev is not None:
            data = self.ev.data
            self.ev_data = ev.ChargerData(**{f.name: getattr(data, f.name)[:, first:first + length]
                                             for f in fields(ev.ChargerData)})
            battery = self.ev.vehicles.battery
            self.charger_record = ChargerRecord.zeros(len(self.ev.chargers.names), length)
            r = self.ev_record = ElectricVehicleRecord.zeros(len(self.ev.vehicles.names), length)
            r.soc[:, 0] = ev.advance_soc(battery.initial_soc, battery.initial_soc, self.ev_data, 0)
            r.efficiency[:, 0], r.capacity[:, 0] = battery.efficiency, battery.capacity
        if self.machines is not None:
            self.machine_record = WashingMachineRecord.zeros(len(self.machines.names), length)
            # CityLearn 2.5 compares the (absolute) start windows with the episode step; corrected: the row
            self._machine_offset = 0 if self.settings.ev_data_from_range_start else \
                self.config.simulation_start_time_step + start

    def use_outage(self, outage: np.ndarray) -> None:
        """Replace the episode's drawn outage signal by ``outage`` (B, T) 0/1 (after :meth:`reset`)."""
        outage = np.asarray(outage, dtype=np.float64)
        if outage.shape != self.episode.outage.shape:
            raise ValueError(f"outage must be {self.episode.outage.shape}, not {outage.shape}")
        self.episode = replace(self.episode, outage=outage)
        self._outage_steps = (outage > 0).any(axis=0)

    def records(self) -> tuple:
        """The episode records, (B, T) arrays per field: every end use's, then the batteries' and the
        buildings'."""
        return (*(u.record for u in self.end_uses), self.battery_record, self.building_record)

    def load_tiled(self, src: District, copies: int, steps: int) -> None:
        """Put ``copies`` copies of ``src``'s state at its step t into this district, which holds ``copies`` x
        ``src``'s buildings with the same devices (building b of copy c is building c x B + b), for a rollout of
        ``steps`` steps: the record columns t .. t + steps (later columns keep what they hold), the LSTM bank,
        the step counter. EV chargers, washing machines and occupant models are not copied."""
        t = src.t
        cut = slice(t, min(t + steps + 1, src.length))
        for a, b in zip(src.records(), self.records(), strict=True):
            for f in fields(a):
                getattr(b, f.name)[:, cut] = np.tile(getattr(a, f.name)[:, cut], (copies, 1))
        if src.thermal is not None:
            self.thermal.bank.load_tiled(src.thermal.bank, copies)
        self.t = t

    def step(self, actions: Actions) -> None:
        """CityLearn 2.1's step: advance to t + 1 and apply ``actions`` there."""
        self.t += 1
        self.act(actions)

    def advance(self) -> None:
        """Move to the next time step without acting (``settings.act_then_advance``: after :meth:`act`)."""
        self.t += 1

    def act(self, actions: Actions) -> None:
        """Apply ``actions`` at the current step t: devices, storages and loads book their consumption, then the
        thermal model predicts the indoor temperature. At t = 0 (only with ``settings.act_then_advance``) the
        previous state is the reset's, and ``settings.first_step_booked_three_times`` adds the reset's and
        update's bookings."""
        t, e = self.t, self.episode
        in_outage = bool(self._outage_steps[t])
        total = np.zeros(self.n)  # electricity booked so far this step [kWh]; updated in place only
        supply = self._supply(t, total)
        overrides = self.thermal.demands(t, actions, self.end_use) if self.thermal is not None else None
        battery_action = actions.electrical_storage
        first = battery_action < 0 if in_outage else None  # during an outage a discharging battery runs first
        if in_outage and first.any():
            total += self._battery(t, battery_action, supply(), first)
        for u in self.end_uses:
            if u.params.live:
                total += self._end_use(u, t, self._demand(u, t, overrides), actions.storage(u.params.name), supply)
        record = self.building_record
        total += np.minimum(e["non_shiftable_load"][:, t], supply(), out=record.non_shiftable_load_served[:, t])
        if in_outage:
            total += self._battery(t, battery_action, supply(), ~first)
        else:
            total += self._battery(t, battery_action, self.inf, None)
        self._book_devices(t, actions, total)
        if t == 0 and self.settings.first_step_booked_three_times:
            total += self._first_row_again()
        net = record.net_electricity_consumption[:, t]
        if in_outage:
            net[:] = np.where(e.outage[:, t] > 0, 0.0, total - e.pv_generation[:, t])
        else:
            np.subtract(total, e.pv_generation[:, t], out=net)
        if self.thermal is not None:
            self.thermal.update(t, self.dynamic_value, self.building_record.indoor_dry_bulb_temperature)
        if self.occupants is not None:
            self.occupants.update(t, self.building_record.indoor_dry_bulb_temperature, self.thermal.warm_now())

    def _first_row_again(self) -> np.ndarray:
        """What CityLearn 2.5 books on row 0 besides its devices' own draw (``settings.first_step_booked_three_times``;
        the end uses add theirs in :meth:`_end_use`): the non-shiftable load at reset and once more at the update,
        and the battery's balance once more [kWh], (B,)."""
        served = self.building_record.non_shiftable_load_served[:, 0]
        again = self.episode["non_shiftable_load"][:, 0] + served
        return again + self.battery_record.energy_balance[:, 0]

    def _supply(self, t: int, total: np.ndarray) -> Callable[[], np.ndarray]:
        """Electricity each building may still draw at step ``t`` [kWh], evaluated when called: inf, or during
        an outage the PV left after ``total`` (the electricity booked so far this step, updated in place)."""
        if not self._outage_steps[t]:
            return lambda: self.inf
        outage, pv = self.episode.outage[:, t] > 0, self.episode.pv_generation[:, t]
        return lambda: np.where(outage, np.maximum(0.0, pv - total), np.inf)

    def _demand(self, u: EndUseState, t: int, overrides: dict[str, np.ndarray] | None) -> np.ndarray:
        """The thermal demand end use ``u`` serves at ``t`` [kWh]: the data set's, or where the thermal model
        overrides it (an LSTM building's device action) the override, which is recorded."""
        demand = u.demand_data[:, t]
        override = overrides.get(u.params.name) if overrides is not None else None
        if override is not None:
            demand = np.where(np.isnan(override), demand, override)
            u.record.demand[:, t] = demand
        return demand

    def _book_devices(self, t: int, actions: Actions, total: np.ndarray) -> None:
        """Add the EV chargers' and then the washing machines' consumption at ``t`` [kWh] to ``total``."""
        if self.ev is not None:
            total += self._chargers(t, actions.electric_vehicle_storage)
        if self.machines is not None:
            total += self._washing_machines(t, actions.washing_machine)

    def _end_use(self, u: EndUseState, t: int, demand: np.ndarray, action: np.ndarray,
                 supply: Callable[[], np.ndarray]) -> np.ndarray:
        """Serve one end use with its device and storage (:func:`citylearn_env.devices.serve_end_use`) into its
        record at ``t``; return the electricity booked (B,) (a view of the record)."""
        p, r = u.params, u.record
        cop = u.cop[:, t]
        again = t == 0 and self.settings.first_step_booked_three_times
        reset_booked = r.electricity_consumption[:, 0].copy() if again else None
        nominal = p.nominal_power - reset_booked if again else p.nominal_power
        tank = p.tank if p.has_storage else None
        booked = r.electricity_consumption[:, t]
        tank_out = (r.storage_soc[:, t], r.storage_energy_balance[:, t], r.energy_from_storage[:, t],
                    r.energy_from_device_to_storage[:, t]) if tank is not None else tuple(self._scratch)
        self._serve_end_use((r.energy_from_device[:, t], booked, *tank_out), demand, nominal, cop, supply(),
                            action, self._storage_scale[p.name], r.storage_soc[:, _previous(t)], tank)
        if tank is not None:
            np.divide(r.storage_energy_balance[:, t], cop, out=r.storage_electricity_consumption[:, t])
        if again:  # CityLearn 2.5 books row 0 at reset, at the first call and once more at its update
            booked[:] = reset_booked + booked + (r.energy_from_device[:, 0] + r.storage_energy_balance[:, 0]) / cop
        return booked

    def _battery(self, t: int, action: np.ndarray, supply: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
        """Charge/discharge the batteries (only where ``mask``) into the record at ``t``; return the electricity
        booked (B,)."""
        r = self.battery_record
        p = _previous(t)
        request = np.minimum(action * self._battery_scale, supply)
        columns = (r.soc[:, t], r.energy_balance[:, t], r.efficiency[:, t], r.capacity[:, t])
        out = columns if mask is None else tuple(self._scratch)
        self._battery_charge(out, request, r.soc[:, p], self.zeros, self.battery, r.efficiency[:, p],
                             r.capacity[:, p],
                             extrapolate_first_segment=self.settings.battery_curve_extrapolates_first_segment,
                             efficiency_from_request=self.settings.battery_efficiency_from_request)
        if mask is None:
            return columns[1]
        for column, value in zip(columns, out, strict=True):
            column[:] = np.where(mask, value, column)
        return np.where(mask, out[1], 0.0)

    def _chargers(self, t: int, action: np.ndarray | None) -> np.ndarray:
        """EVs at step t: the away and connection rules, then each charger's action; returns the chargers'
        consumption summed per building (B,) [kWh]. SOC bookkeeping per docs/ev.md section 4 and the settings
        ``ev_unwritten_soc_is_zero`` / ``ev_step_starts_from_previous_soc``. Not capped during an outage."""
        s, section, data, r = self.settings, self.ev, self.ev_data, self.ev_record
        battery = section.vehicles.battery
        if t == 0:  # acted on only with act_then_advance: the reset applied row 0's rules
            prev = now = r.soc[:, 0].copy()
        else:
            prev = r.soc[:, t - 1]
            now = ev.advance_soc(prev, r.soc[:, t] if s.ev_unwritten_soc_is_zero else prev, data, t, self._drift)
        start = prev if s.ev_step_starts_from_previous_soc else now
        action = np.zeros(len(section.chargers.names)) if action is None else action
        p = _previous(t)
        soc, eff, cap, consumption, stepped = ev.charge_plugged_evs(
            action, start, r.efficiency[:, p], r.capacity[:, p], data, t, section.chargers, section.vehicles,
            self.step_hours, efficiency_from_request=s.battery_efficiency_from_request)
        if not s.ev_unwritten_soc_is_zero:  # an idle plugged EV keeps its SOC less the standby loss
            idle = np.zeros_like(stepped)
            plugged = ev.plugged_ev(data, t)
            idle[plugged[plugged != ev.NO_EV]] = True
            now = np.where(idle & ~stepped, now * (1.0 - battery.loss_coefficient), now)
        r.soc[:, t] = np.where(stepped, soc, now)
        r.efficiency[:, t], r.capacity[:, t] = eff, cap
        self.charger_record.electricity_consumption[:, t] = consumption
        self.charger_record.action_energy[:, t] = ev.charger_energy(action, section.chargers, self.step_hours)
        per_building = np.bincount(section.chargers.building, weights=consumption, minlength=self.n)
        self.building_record.chargers_electricity_consumption[:, t] = per_building
        return per_building

    def _washing_machines(self, t: int, action: np.ndarray | None) -> np.ndarray:
        """Washing machines at step t: clear the running flag where the start window changed, start the
        requested cycles inside their window (booking the whole profile ahead); returns the machines'
        consumption at t summed per building (B,) [kWh]."""
        m, r = self.machines, self.machine_record
        row = self.ev_first_row + t
        running = r.running[:, t - 1] > 0 if t > 0 else np.zeros(len(m.names), dtype=bool)
        if row > 0:
            running &= ~washing_machine.window_changed(m.start, m.end, row)
        if action is not None:
            profiles = [p[row] for p in m.profile]
            has_profile = np.array([len(p) > 0 for p in profiles])
            started = washing_machine.cycle_starts(action, running, m.start[:, row], m.end[:, row], has_profile,
                                                   t + self._machine_offset)
            if started.any():
                r.electricity_consumption[:] = washing_machine.add_cycle_load(r.electricity_consumption, started,
                                                                               profiles, t)
                running |= started
        r.running[:, t] = running
        per_building = np.bincount(m.building, weights=r.electricity_consumption[:, t], minlength=self.n)
        self.building_record.washing_machines_electricity_consumption[:, t] = per_building
        return per_building
