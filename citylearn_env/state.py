"""The typed running state of a district: parameters (B,), data series (B, N) and the episode record (B, T).

B buildings, N time steps of the simulation range, T time steps of the current episode. Parameters and data are
read-only after construction; records are written by :class:`citylearn_env.district.District` one step at a time.
The flat CityLearn names of recorded quantities (``cooling_storage_soc``, ``energy_from_dhw_device`` ...) are
generated in one place, :func:`recorded_names`, from the field names here; the observation names the state
answers (:data:`DYNAMIC`, the static aliases and COP names) are listed at the end. Units: energies kWh per step,
powers kW, temperatures degC, states of charge and efficiencies as fractions.
"""

from __future__ import annotations

import mmap
from collections.abc import Mapping
from dataclasses import dataclass, fields
from types import MappingProxyType
from typing import Self

import numpy as np

END_USES = ("cooling", "heating", "dhw")


@dataclass(frozen=True)
class EndUseSlots:
    """Where one end use lives in the schema and the data sets: its ``device`` slot (``cooling_device`` ...),
    its ``storage`` slot (``cooling_storage`` ...), the data set's ``demand`` column [kWh thermal per step] and
    the name of its storage ``action``."""

    device: str
    storage: str
    demand: str
    action: str


#: end use -> its :class:`EndUseSlots`
END_USE_SLOTS: Mapping[str, EndUseSlots] = MappingProxyType({
    k: EndUseSlots(device=f"{k}_device", storage=f"{k}_storage", demand=f"{k}_demand", action=f"{k}_storage")
    for k in END_USES})


#: records at least this large [bytes] are held in anonymous memory maps (:func:`lazy_zeros`)
LAZY_BYTES = 1 << 22


def lazy_zeros(count: int, n: int, length: int) -> np.ndarray:
    """``count`` float64 arrays of (n, length) zeros, as one (count, n, length) block.

    A large block is an anonymous memory map advised against transparent huge pages: the OS gives a page of
    memory only when it is first written, 4 KiB at a time. numpy's own large allocations ask for 2 MiB huge
    pages, so writing one column of a (B, T) record (the step's values, one per building) would make the whole
    record resident at once; a field the run never writes (the end uses a district does not have) would cost
    B x T x 8 bytes all the same."""
    nbytes = count * n * length * 8
    if nbytes < LAZY_BYTES:
        return np.zeros((count, n, length))
    block = mmap.mmap(-1, nbytes)
    if hasattr(mmap, "MADV_NOHUGEPAGE"):
        block.madvise(mmap.MADV_NOHUGEPAGE)
    return np.frombuffer(block, dtype=np.float64).reshape(count, n, length)


class Record:
    """Base of the episode records: every field a (B, T) float array."""

    @classmethod
    def zeros(cls, n: int, length: int) -> Self:
        """A record of ``n`` buildings and ``length`` time steps, all zeros (memory taken when written,
        :func:`lazy_zeros`)."""
        return cls(*lazy_zeros(len(fields(cls)), n, length))


@dataclass(frozen=True, eq=False)
class TankParams:
    """Thermal storage tanks of one end use, (B,): ``capacity`` [kWh thermal], standby ``loss_coefficient``
    [fraction per step], ``one_way_efficiency`` [-] (sqrt of round trip), ``initial_soc`` [-], charge and
    discharge limits ``max_input_power`` / ``max_output_power`` [kWh per step]."""

    capacity: np.ndarray
    loss_coefficient: np.ndarray
    one_way_efficiency: np.ndarray
    initial_soc: np.ndarray
    max_input_power: np.ndarray
    max_output_power: np.ndarray


@dataclass(frozen=True, eq=False)
class EndUseParams:
    """One end use (cooling, heating or DHW) of every building: its device's ``nominal_power`` (B,) [kW
    electric] and ``cop`` (B, N) [-] (Carnot heat pump or heater efficiency), the data set's ``demand`` (B, N)
    [kWh thermal] and the storage ``tank``. ``live``: some building can ever use it (otherwise the step skips
    it); ``has_storage``: some building has a tank."""

    name: str
    nominal_power: np.ndarray
    cop: np.ndarray
    demand: np.ndarray
    tank: TankParams
    live: bool
    has_storage: bool


@dataclass(eq=False)
class EndUseRecord(Record):
    """What one end use did over an episode, (B, T) each. ``demand`` is the demand served (the data set's,
    or for LSTM buildings the heat pump's output chosen by the device action)."""

    demand: np.ndarray
    electricity_consumption: np.ndarray
    storage_electricity_consumption: np.ndarray
    energy_from_device: np.ndarray
    energy_from_storage: np.ndarray
    energy_from_device_to_storage: np.ndarray
    storage_soc: np.ndarray
    storage_energy_balance: np.ndarray


@dataclass(eq=False)
class EndUseState:
    """One end use during an episode: its parameters, the episode's COP and data demand (B, T) and record."""

    params: EndUseParams
    cop: np.ndarray
    demand_data: np.ndarray
    record: EndUseRecord


@dataclass(eq=False)
class BatteryRecord(Record):
    """The batteries over an episode, (B, T): ``soc`` [-], ``energy_balance`` [kWh, > 0 charging],
    round-trip ``efficiency`` [-] of the step and degraded ``capacity`` [kWh]."""

    soc: np.ndarray
    energy_balance: np.ndarray
    efficiency: np.ndarray
    capacity: np.ndarray


@dataclass(eq=False)
class BuildingRecord(Record):
    """Whole-building quantities over an episode, (B, T): ``net_electricity_consumption`` [kWh, 0 during an
    outage], ``non_shiftable_load_served`` [kWh], ``indoor_dry_bulb_temperature`` [degC] and the sums over the
    building's EV chargers and washing machines, ``chargers_electricity_consumption`` and
    ``washing_machines_electricity_consumption`` [kWh] (0 in a building without them)."""

    net_electricity_consumption: np.ndarray
    non_shiftable_load_served: np.ndarray
    indoor_dry_bulb_temperature: np.ndarray
    chargers_electricity_consumption: np.ndarray
    washing_machines_electricity_consumption: np.ndarray


@dataclass(eq=False)
class ChargerRecord(Record):
    """The EV chargers over an episode, (C, T): grid-side ``electricity_consumption`` [kWh, < 0 when an EV
    discharges into the building] and ``action_energy`` [kWh]: the charger-side energy the action asked for
    (action x max power, held within the charger's limits; 0 for a zero action), recorded whether or not an
    EV is plugged in (CityLearn 2.5's ``past_charging_action_values_kwh``, read by the EV reward)."""

    electricity_consumption: np.ndarray
    action_energy: np.ndarray


@dataclass(eq=False)
class ElectricVehicleRecord(Record):
    """The EV batteries over an episode, (V, T): ``soc`` [-] (docs/ev.md section 4), the round-trip
    ``efficiency`` [-] of the last battery step and the degraded ``capacity`` [kWh] after it."""

    soc: np.ndarray
    efficiency: np.ndarray
    capacity: np.ndarray


@dataclass(eq=False)
class WashingMachineRecord(Record):
    """The washing machines over an episode, (M, T): ``electricity_consumption`` [kWh] of started cycles
    (booked ahead: a cycle started at t fills t, t + 1, ...) and ``running`` [0/1]: a cycle was started in the
    current start window (set when it starts, cleared when the window changes)."""

    electricity_consumption: np.ndarray
    running: np.ndarray


@dataclass(frozen=True, eq=False)
class Signals:
    """Data series of every building, (B, N) or an episode's (B, T) window of them.

    ``columns`` holds every data-set column by its v2.2 name (calendar, weather, prices, carbon intensity, loads,
    set points ...); ``pv_generation`` [kWh per step] is derived from ``solar_generation`` and the PV size;
    ``outage`` [0/1] is the outage signal of the episode (the data set's column, or drawn at reset).
    Every column is read-only float64; one that all buildings share (one weather file, equal calendars, an unused
    all-zero column) is a single row broadcast to (B, N) (``strides[0] == 0``, N values in memory), the others
    are (B, N) copies (:func:`citylearn_env.district.shared_rows`).
    """

    columns: Mapping[str, np.ndarray]
    pv_generation: np.ndarray
    outage: np.ndarray

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def window(self, start: int, length: int, outage: np.ndarray) -> Signals:
        """Views of time steps ``start .. start + length - 1`` with the episode's ``outage`` signal."""
        stop = start + length
        return Signals(MappingProxyType({k: v[:, start:stop] for k, v in self.columns.items()}),
                       self.pv_generation[:, start:stop], outage)


#: recorded end-use fields and their CityLearn name patterns ("{}" = cooling, heating or dhw)
END_USE_NAMES = (
    ("{}_demand", "demand"),
    ("{}_electricity_consumption", "electricity_consumption"),
    ("{}_storage_electricity_consumption", "storage_electricity_consumption"),
    ("energy_from_{}_device", "energy_from_device"),
    ("energy_from_{}_storage", "energy_from_storage"),
    ("energy_from_{0}_device_to_{0}_storage", "energy_from_device_to_storage"),
    ("{}_storage_soc", "storage_soc"),
    ("{}_storage_energy_balance", "storage_energy_balance"),
)
#: recorded battery fields and their CityLearn names
BATTERY_NAMES = (
    ("electrical_storage_soc", "soc"),
    ("electrical_storage_energy_balance", "energy_balance"),
    ("electrical_storage_electricity_consumption", "energy_balance"),
    ("electrical_storage_efficiency", "efficiency"),
    ("electrical_storage_capacity", "capacity"),
)
#: recorded whole-building fields and their CityLearn names
BUILDING_NAMES = (
    ("net_electricity_consumption", "net_electricity_consumption"),
    ("non_shiftable_load_electricity_consumption", "non_shiftable_load_served"),
    ("energy_to_non_shiftable_load", "non_shiftable_load_served"),
    ("indoor_dry_bulb_temperature", "indoor_dry_bulb_temperature"),
    ("chargers_electricity_consumption", "chargers_electricity_consumption"),
    ("washing_machines_electricity_consumption", "washing_machines_electricity_consumption"),
)


#: BUILDING_NAMES entries recorded only in a district with EV chargers or washing machines
EV_BUILDING_NAMES = ("chargers_electricity_consumption", "washing_machines_electricity_consumption")


def recorded_names(end_uses: Mapping[str, EndUseRecord], battery: BatteryRecord,
                   building: BuildingRecord, *, with_ev: bool = False) -> dict[str, np.ndarray]:
    """Every recorded (B, T) array under its CityLearn building-property name (arrays shared, not copied);
    the charger and washing-machine sums only ``with_ev`` (a district that has chargers or machines)."""
    out: dict[str, np.ndarray] = {}
    for end_use, record in end_uses.items():
        for pattern, attr in END_USE_NAMES:
            if attr == "demand" and end_use == "dhw":
                continue  # the DHW demand is never changed by control: it stays a data column
            out[pattern.format(end_use)] = getattr(record, attr)
    for name, attr in BATTERY_NAMES:
        out[name] = getattr(battery, attr)
    for name, attr in BUILDING_NAMES:
        if with_ev or name not in EV_BUILDING_NAMES:
            out[name] = getattr(building, attr)
    return out


# ------------------------------------------------------------------------ observation names
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
#: the set-point change an occupant made at the step [K] (0 where none; CityLearn 2.4+'s occupant buildings)
OCCUPANT_DELTA = "occupant_interaction_indoor_dry_bulb_temperature_set_point_delta"
#: observations of the simulation state (recorded or derived each step); every other one is data
DYNAMIC = (
    OCCUPANT_DELTA,
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
