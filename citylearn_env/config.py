"""Typed, frozen configuration of a district: what :func:`citylearn_env.schema.load_schema` returns.

Units: powers in kW (electric input for heat pumps and heaters), capacities in kWh, temperatures in degC,
efficiencies and coefficients as fractions. Time series are read-only float64 numpy arrays over the whole
simulation range (row ``simulation_start_time_step`` .. ``simulation_end_time_step`` of the files).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from citylearn_env.dataset import DynamicsBlock
from citylearn_env.errors import SchemaError
from citylearn_env.ev import EVSection, with_initial_soc
from citylearn_env.occupant import OccupantConfig
from citylearn_env.washing_machine import WashingMachines

#: CityLearn v2.1 battery curves used when a schema gives none: [[x, y], ...]
DEFAULT_POWER_EFFICIENCY_CURVE = ((0.0, 0.83), (0.3, 0.83), (0.7, 0.9), (0.8, 0.9), (1.0, 0.85))
DEFAULT_CAPACITY_POWER_CURVE = ((0.0, 1.0), (0.8, 1.0), (1.0, 0.2))

ACTION_NAMES = (
    "cooling_storage",
    "heating_storage",
    "dhw_storage",
    "electrical_storage",
    "cooling_device",
    "heating_device",
    "cooling_or_heating_device",
    "electric_vehicle_storage",
    "washing_machine",
)
#: actions CityLearn 2.1 does not know: a v2.1-layout schema leaves them out (CityLearn 2.1.2 passes every
#: schema action to its buildings, active or not, and fails on these names)
ACTIONS_SINCE_2_2 = ("cooling_or_heating_device", "electric_vehicle_storage", "washing_machine")
#: generic schema actions that become one action per device: ``electric_vehicle_storage_<charger id>`` per
#: charger and the machine's own name per washing machine (docs/ev.md section 6)
EV_ACTION = "electric_vehicle_storage"
WASHING_MACHINE_ACTION = "washing_machine"


def device_actions(ev: EVSection | None, machines: WashingMachines | None) -> dict[str, tuple[str, int, int]]:
    """The per-device action names, in device order: ``electric_vehicle_storage_<charger id>`` per charger
    and the machine's own name per washing machine, each -> (kind ``"ev"`` or ``"wm"``, device index,
    owning building index)."""
    out: dict[str, tuple[str, int, int]] = {}
    if ev is not None:
        out.update({f"{EV_ACTION}_{c}": ("ev", i, int(b))
                    for i, (c, b) in enumerate(zip(ev.chargers.names, ev.chargers.building, strict=True))})
    if machines is not None:
        out.update({m: ("wm", i, int(b)) for i, (m, b) in enumerate(zip(machines.names, machines.building,
                                                                        strict=True))})
    return out


def expand_actions(active: Iterable[str], building: int, ev: EVSection | None,
                   machines: WashingMachines | None) -> tuple[str, ...]:
    """Building ``building``'s action names from the generic ``active`` ones (in that order): the EV action
    becomes one name per charger of the building, the washing-machine action one per machine
    (:func:`device_actions`)."""
    generic = {EV_ACTION: "ev", WASHING_MACHINE_ACTION: "wm"}
    devices = device_actions(ev, machines)
    out: list[str] = []
    for name in active:
        if name in generic:
            out.extend(n for n, (kind, _, b) in devices.items() if kind == generic[name] and b == building)
        else:
            out.append(name)
    return tuple(out)


@dataclass(frozen=True)
class ConversionDevice:
    """A heat pump (Carnot-fraction COP) or an electric heater (constant efficiency).

    ``nominal_power`` [kW electric]; ``efficiency`` is the Carnot fraction for a heat pump, the thermal
    efficiency for a heater; target supply temperatures [degC] apply to heat pumps only.
    """

    kind: str = "HeatPump"
    nominal_power: float = 0.0
    efficiency: float = 0.2
    target_cooling_temperature: float = 8.0
    target_heating_temperature: float = 45.0


@dataclass(frozen=True)
class Tank:
    """A thermal storage tank. ``capacity`` [kWh thermal]; ``loss_coefficient`` = fraction lost per step."""

    capacity: float = 0.0
    efficiency: float = 1.0
    loss_coefficient: float = 0.006
    initial_soc: float = 0.0
    max_input_power: float = float("inf")
    max_output_power: float = float("inf")


@dataclass(frozen=True)
class Battery:
    """A battery. ``capacity`` [kWh], ``nominal_power`` [kW]; curves are ((x, y), ...) point tuples.

    ``power_efficiency_curve``: x = |energy| / nominal_power, y = round-trip efficiency;
    ``capacity_power_curve``: x = state of charge, y = fraction of nominal power available.
    """

    capacity: float = 0.0
    nominal_power: float = 0.0
    efficiency: float = 0.9
    loss_coefficient: float = 0.006
    capacity_loss_coefficient: float = 1e-5
    depth_of_discharge: float = 1.0
    initial_soc: float = 0.0
    power_efficiency_curve: tuple[tuple[float, float], ...] = DEFAULT_POWER_EFFICIENCY_CURVE
    capacity_power_curve: tuple[tuple[float, float], ...] = DEFAULT_CAPACITY_POWER_CURVE


@dataclass(frozen=True)
class Outage:
    """Power-outage settings. ``stochastic``: SAIFI/CAIDI model; otherwise the CSV ``power_outage`` column."""

    simulate: bool = False
    stochastic: bool = False
    saifi: float = 1.436
    caidi: float = 331.2
    random_seed: int | None = None
    start_time_steps: tuple[int, ...] | None = None


@dataclass(frozen=True)
class BuildingConfig:
    """One building: devices, the LSTM models (cooling, heating) if any, its occupant model if any, and its
    time series."""

    name: str
    series: Mapping[str, np.ndarray]
    cooling_device: ConversionDevice = field(default_factory=ConversionDevice)
    heating_device: ConversionDevice = field(default_factory=ConversionDevice)
    dhw_device: ConversionDevice = field(default_factory=ConversionDevice)
    cooling_storage: Tank = field(default_factory=Tank)
    heating_storage: Tank = field(default_factory=Tank)
    dhw_storage: Tank = field(default_factory=Tank)
    electrical_storage: Battery = field(default_factory=Battery)
    pv_nominal_power: float = 0.0
    outage: Outage = field(default_factory=Outage)
    cooling_model: DynamicsBlock | None = None
    heating_model: DynamicsBlock | None = None
    active_observations: tuple[str, ...] = ()
    active_actions: tuple[str, ...] = ()
    #: the occupant who overrides the set points (CityLearn 2.4+'s occupant interaction building), if any
    occupant: OccupantConfig | None = None

    @property
    def has_dynamics(self) -> bool:
        return self.cooling_model is not None or self.heating_model is not None


@dataclass(frozen=True)
class DistrictConfig:
    """A whole schema, validated. ``observations`` holds (name, shared_in_central_agent) in schema order."""

    buildings: tuple[BuildingConfig, ...]
    observations: tuple[tuple[str, bool], ...]
    central_agent: bool
    simulation_start_time_step: int
    simulation_end_time_step: int
    episode_time_steps: int | tuple[tuple[int, int], ...] | None
    rolling_episode_split: bool
    random_episode_split: bool
    seconds_per_time_step: float
    reward_function: Mapping[str, object] | None
    random_seed: int | None
    source: str
    #: EVs, chargers and their data (None: the schema has none); docs/ev.md
    electric_vehicles: EVSection | None = None
    #: washing machines and their data (None: the schema has none)
    washing_machines: WashingMachines | None = None

    @property
    def building_names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.buildings)

    @property
    def shared_observations(self) -> tuple[str, ...]:
        return tuple(name for name, shared in self.observations if shared)

    # ------------------------------------------------------------------ typed edits (never the raw JSON)
    def replace(self, **changes: Any) -> DistrictConfig:
        """A copy with top-level fields changed (e.g. ``central_agent=True``, ``random_seed=1``)."""
        return dataclasses.replace(self, **changes)

    def with_buildings(self, names: Sequence[str]) -> DistrictConfig:
        """Only the buildings ``names``, in that order."""
        by_name = {b.name: b for b in self.buildings}
        unknown = [n for n in names if n not in by_name]
        if unknown or not names:
            raise SchemaError(f"unknown building(s) {unknown}; the district has {', '.join(by_name)}"
                              if unknown else "at least one building is needed", column="buildings")
        if (self.electric_vehicles or self.washing_machines) and tuple(names) != self.building_names:
            raise SchemaError("choosing buildings of a district with EV chargers or washing machines is not "
                              "supported (their building indices would change)", column="buildings")
        return dataclasses.replace(self, buildings=tuple(by_name[n] for n in names))

    def with_observations(self, active: Sequence[str], shared: Iterable[str] = ()) -> DistrictConfig:
        """Exactly ``active`` observations (in this order) for every building; ``shared`` ones appear once in
        the central agent's vector."""
        shared = set(shared)
        observations = tuple((name, name in shared) for name in active)
        buildings = tuple(dataclasses.replace(b, active_observations=tuple(active)) for b in self.buildings)
        return dataclasses.replace(self, observations=observations, buildings=buildings)

    def with_actions(self, active: Iterable[str]) -> DistrictConfig:
        """Exactly the ``active`` actions (schema order) for every building."""
        active = tuple(active)
        unknown = [a for a in active if a not in ACTION_NAMES]
        if unknown:
            raise SchemaError(f"unknown action(s) {unknown}; known: {', '.join(ACTION_NAMES)}", column="actions")
        ordered = tuple(a for a in ACTION_NAMES if a in active)
        return dataclasses.replace(self, buildings=tuple(
            dataclasses.replace(b, active_actions=expand_actions(ordered, i, self.electric_vehicles,
                                                                 self.washing_machines))
            for i, b in enumerate(self.buildings)))

    def with_ev_initial_soc(self, initial_soc: Mapping[str, float]) -> DistrictConfig:
        """EVs (by name) starting the episode at these SOCs [0..1] (e.g. an upstream run's realised values)."""
        if self.electric_vehicles is None:
            raise SchemaError("the district has no electric vehicles", column="electric_vehicles_def")
        return dataclasses.replace(self, electric_vehicles=with_initial_soc(self.electric_vehicles, initial_soc))

    def with_episode(self, splits: Sequence[tuple[int, int]] | int | None) -> DistrictConfig:
        """``episode_time_steps``: None (the whole range), a length, or inclusive (start, end) time steps."""
        if splits is not None and not isinstance(splits, int):
            splits = tuple((int(a), int(b)) for a, b in splits)
        return dataclasses.replace(self, episode_time_steps=splits)

    def with_reward(self, spec: Mapping[str, Any] | str | None) -> DistrictConfig:
        """The reward function spec (``{"type": ..., "attributes": {...}}``, a registered name or None)."""
        if isinstance(spec, str):
            spec = {"type": spec, "attributes": {}}
        return dataclasses.replace(self, reward_function=None if spec is None else MappingProxyType(dict(spec)))

    def without_devices(self, *slots: str) -> DistrictConfig:
        """Every building without the devices in ``slots`` (storages, "pv"): as if the schema had none."""
        empty = {"cooling_storage": Tank(), "heating_storage": Tank(), "dhw_storage": Tank(),
                 "electrical_storage": Battery()}
        unknown = [s for s in slots if s not in empty and s != "pv"]
        if unknown:
            raise SchemaError(f"cannot remove {unknown}; removable: {', '.join([*empty, 'pv'])}", column="buildings")
        changes = {s: empty[s] for s in slots if s in empty}
        if "pv" in slots:
            changes["pv_nominal_power"] = 0.0
        return dataclasses.replace(
            self, buildings=tuple(dataclasses.replace(b, **changes) for b in self.buildings))

    def without_outages(self) -> DistrictConfig:
        """No power outages in any building."""
        return dataclasses.replace(
            self, buildings=tuple(dataclasses.replace(b, outage=Outage()) for b in self.buildings))

    def with_device(self, building: str, slot: str, **attributes: Any) -> DistrictConfig:
        """Building ``building``'s device ``slot`` with ``attributes`` changed (units as in the schema)."""
        names = self.building_names
        if building not in names:
            raise SchemaError(f"unknown building {building!r}; the district has {', '.join(names)}",
                              column="buildings")
        b = self.buildings[names.index(building)]
        if slot == "pv":
            new = dataclasses.replace(b, pv_nominal_power=float(attributes.pop("nominal_power", b.pv_nominal_power)))
        else:
            current = getattr(b, slot, None)
            if not dataclasses.is_dataclass(current):
                raise SchemaError(f"unknown device slot {slot!r}", column=f"buildings.{building}")
            try:
                new = dataclasses.replace(b, **{slot: dataclasses.replace(current, **attributes)})
            except TypeError as error:
                raise SchemaError(str(error), column=f"buildings.{building}.{slot}.attributes") from None
            attributes = {}
        if attributes:
            raise SchemaError(f"unknown attribute(s) {sorted(attributes)}", column=f"buildings.{building}.{slot}")
        return dataclasses.replace(self, buildings=tuple(new if x is b else x for x in self.buildings))


def frozen_series(series: Mapping[str, np.ndarray]) -> Mapping[str, np.ndarray]:
    """Make every array read-only and wrap the mapping so the configuration cannot be changed."""
    for value in series.values():
        value.flags.writeable = False
    return MappingProxyType(dict(series))
