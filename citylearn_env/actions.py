"""The action layout of a district: which entry of the Box action vector drives which building's storage,
device, EV charger or washing machine, the bounds of each entry, and the vector -> typed :class:`Actions`
translation the district steps with.

Storage actions are fractions of the storage's capacity (charge > 0, discharge < 0); device actions
fractions of the device's nominal power. Entry bounds (CityLearn 2.1 unless ``settings`` says otherwise):

* a thermal storage: +-min(peak demand [kWh] / capacity [kWh], 1) over the simulation range (+-1 without a
  tank), or with ``settings.thermal_storage_bounds_from_device_power`` (CityLearn 2.5) +-min(device nominal
  power [kW] / capacity [kWh], 1);
* ``electrical_storage``: +-nominal power [kW] / capacity [kWh] (1 h steps), or +-1 without a battery or with
  ``settings.battery_action_fraction_of_nominal_power`` (CityLearn 2.5: a fraction of the nominal power);
* ``cooling_device`` / ``heating_device``: 0..1; the combined ``cooling_or_heating_device``: -1..1;
* an EV charger: -1..1 when it can discharge, else 0..1; a washing machine: 0..1.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from citylearn_env.config import device_actions
from citylearn_env.devices import BatteryParams
from citylearn_env.errors import SchemaError
from citylearn_env.ev import EVSection
from citylearn_env.settings import Behaviour
from citylearn_env.state import END_USE_SLOTS, EndUseParams
from citylearn_env.washing_machine import WashingMachines

#: capacity [kWh] CityLearn 2.5 divides by in place of 0 (its ZERO_DIVISION_PLACEHOLDER)
ZERO_CAPACITY_KWH = 1e-6
#: storage actions, one per building: fractions of the storage's capacity
STORAGE_ACTIONS = ("cooling_storage", "heating_storage", "dhw_storage", "electrical_storage")
#: device actions, one per building: fractions of the device's nominal power
DEVICE_ACTIONS = ("cooling_device", "heating_device")
#: the v2.2+ combined heat-pump action in [-1, 1]: a < 0 is a cooling action of -a, a > 0 a heating action of a
COMBINED_DEVICE_ACTION = "cooling_or_heating_device"
#: the rows of the per-building action table, in :class:`Actions` field order
_TABLE_ROWS = (*STORAGE_ACTIONS, *DEVICE_ACTIONS)
#: per-device action kinds of :func:`citylearn_env.config.device_actions`: EV chargers, washing machines
_DEVICE_KINDS = ("ev", "wm")


@dataclass(slots=True, eq=False)
class Actions:
    """One step's actions of every building, (B,): storage actions as fractions of capacity (0 where
    inactive), device actions as fractions of nominal power (NaN where inactive)."""

    cooling_storage: np.ndarray
    heating_storage: np.ndarray
    dhw_storage: np.ndarray
    electrical_storage: np.ndarray
    cooling_device: np.ndarray
    heating_device: np.ndarray
    #: (C,) charger actions in -1..1 (fraction of max charging / discharging power), 0 where inactive
    electric_vehicle_storage: np.ndarray | None = None
    #: (M,) washing-machine start requests (> 0 asks to start), 0 where inactive
    washing_machine: np.ndarray | None = None

    def storage(self, end_use: str) -> np.ndarray:
        """The storage action of ``end_use`` (cooling, heating or dhw)."""
        return getattr(self, END_USE_SLOTS[end_use].action)


def _positions(pairs: Sequence[tuple[str, int]], keep: Callable[[str], bool]) -> np.ndarray:
    """Indices of the ``pairs`` whose action name ``keep(name)`` accepts."""
    return np.array([i for i, (name, _) in enumerate(pairs) if keep(name)], dtype=np.intp)


class ActionLayout:
    """The action vector of a district: ``pairs`` (action name, building index) per entry, in building then
    schema order; ``low`` / ``high`` the entry bounds (float64, see the module docstring).

    ``active``: the schema's active action names of each building (per-device names already expanded by
    :func:`citylearn_env.config.expand_actions`); ``end_uses`` give the tanks and demands, ``ev`` and
    ``machines`` the devices (None: none)."""

    def __init__(self, active: Sequence[Sequence[str]], building_names: Sequence[str], *,
                 battery: BatteryParams, end_uses: Sequence[EndUseParams], ev: EVSection | None,
                 machines: WashingMachines | None, settings: Behaviour) -> None:
        self.n_buildings = len(building_names)
        self.pairs: list[tuple[str, int]] = [(name, b) for b, names in enumerate(active) for name in names]
        devices = device_actions(ev, machines)
        for name, b in self.pairs:
            owner = devices[name][2] if name in devices else b
            if owner != b:  # e.g. copies of a district (vector env): devices index the original buildings
                raise SchemaError(f"{building_names[b]} has no device {name!r} (it belongs to "
                                  f"{building_names[owner]})", column=f"actions.{name}")
        self._battery, self._ev, self._settings = battery, ev, settings
        self._tanks = {END_USE_SLOTS[p.name].action: p for p in end_uses}
        bounds = [self._bounds(name, b, devices) for name, b in self.pairs]
        self.low = np.array([lo for lo, _ in bounds])
        self.high = np.array([hi for _, hi in bounds])
        self._setup_table(devices)
        self._setup_devices(devices, ev, machines)

    def _bounds(self, name: str, b: int, devices: Mapping[str, tuple[str, int, int]]) -> tuple[float, float]:
        """(low, high) of action ``name`` of building ``b``."""
        kind = devices.get(name)
        if kind is not None:  # a charger: -1 only if it can discharge; a washing machine: 0..1
            can_discharge = kind[0] == "ev" and self._ev.chargers.max_discharging_power[kind[1]] > 0
            return (-1.0 if can_discharge else 0.0), 1.0
        if name in DEVICE_ACTIONS:
            return 0.0, 1.0
        if name == COMBINED_DEVICE_ACTION:
            return -1.0, 1.0
        if name == "electrical_storage":
            cap, power = self._battery.capacity[b], self._battery.nominal_power[b]
            bound = 1.0 if self._settings.battery_action_fraction_of_nominal_power or cap <= 0 else power / cap
        else:
            bound = self._tank_bound(self._tanks[name], b)
        return -bound, bound

    def _tank_bound(self, params: EndUseParams, b: int) -> float:
        """The bound of building ``b``'s storage action of ``params``' end use: min(peak demand [kWh] / capacity
        [kWh], 1) (1 without a tank), or with ``settings.thermal_storage_bounds_from_device_power`` (CityLearn
        2.5) min(device nominal power [kW] / max(capacity, 1e-6), 1)."""
        cap = float(params.tank.capacity[b])
        if self._settings.thermal_storage_bounds_from_device_power:
            return min(float(params.nominal_power[b]) / max(cap, ZERO_CAPACITY_KWH), 1.0)
        return min(float(params.demand[b].max()) / cap, 1.0) if cap > 0 else 1.0

    def _setup_table(self, devices: Mapping[str, tuple[str, int, int]]) -> None:
        """Index arrays from the action vector into the (6, B) table of storage and device actions."""
        pairs = self.pairs
        self._template = np.zeros((len(_TABLE_ROWS), self.n_buildings))
        self._template[len(STORAGE_ACTIONS):] = np.nan  # inactive device actions: NaN
        self._plain = _positions(pairs, lambda n: n != COMBINED_DEVICE_ACTION and n not in devices)
        self._rows = np.array([_TABLE_ROWS.index(pairs[i][0]) for i in self._plain], dtype=np.intp)
        self._cols = np.array([pairs[i][1] for i in self._plain], dtype=np.intp)
        combined = _positions(pairs, lambda n: n == COMBINED_DEVICE_ACTION)
        self._combined = combined if combined.size else None
        self._combined_cols = np.array([pairs[i][1] for i in combined], dtype=np.intp)
        self._device_rows = (_TABLE_ROWS.index("cooling_device"), _TABLE_ROWS.index("heating_device"))
        self._buildings = {name: np.array([b for n, b in pairs if n == name], dtype=np.intp)
                           for name in (*_TABLE_ROWS, COMBINED_DEVICE_ACTION)}

    def _setup_devices(self, devices: Mapping[str, tuple[str, int, int]], ev: EVSection | None,
                       machines: WashingMachines | None) -> None:
        """Per device kind: (action positions, device indices) and the device count (None: no such device)."""
        #: kind -> (positions in the action vector, device indices); None in a district without devices
        self.device_index: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
        if devices:
            self.device_index = {kind: (_positions(self.pairs, lambda n, k=kind: devices.get(n, ("",))[0] == k),
                                        np.array([devices[n][1] for n, _ in self.pairs
                                                  if devices.get(n, ("",))[0] == kind], dtype=np.intp))
                                 for kind in _DEVICE_KINDS}
        self._device_counts = {"ev": len(ev.chargers.names) if ev is not None else None,
                               "wm": len(machines.names) if machines is not None else None}

    def active(self, name: str) -> np.ndarray:
        """(B,) bool: the building has action ``name`` (a storage or device action) in the vector."""
        return np.isin(np.arange(self.n_buildings), self._buildings[name])

    def actions(self, a: np.ndarray) -> Actions:
        """Action vector ``a`` (float64, validated) -> typed per-building actions: inactive storage actions 0,
        inactive device actions NaN; a combined ``cooling_or_heating_device`` action becomes a cooling and a
        heating action (one of them 0)."""
        table = self._template.copy()
        if self._combined is None and self.device_index is None:
            table[self._rows, self._cols] = a
        else:
            table[self._rows, self._cols] = a[self._plain]
            if self._combined is not None:
                both = a[self._combined]
                cooling, heating = self._device_rows
                table[cooling, self._combined_cols] = np.maximum(-both, 0.0)
                table[heating, self._combined_cols] = np.maximum(both, 0.0)
        if self.device_index is None:
            return Actions(*table)
        return Actions(*table, *(self._device_vector(kind, a) for kind in _DEVICE_KINDS))

    def _device_vector(self, kind: str, a: np.ndarray) -> np.ndarray | None:
        """The (C,) charger or (M,) washing-machine actions of ``a`` (0 where inactive; None: no such device)."""
        count = self._device_counts[kind]
        if count is None:
            return None
        out = np.zeros(count)
        index, device = self.device_index[kind]
        out[device] = a[index]
        return out
