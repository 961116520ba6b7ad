"""Read-only device views with upstream's names (mirrors ``citylearn.energy_model``: ``HeatPump``,
``ElectricHeater``, ``StorageTank``, ``Battery``, ``PV``).

A view reads the typed config of its building's device slot (parameters) and the native environment's recorded
arrays (time series, time steps 0 .. t of the current episode), when an attribute is read: nothing is copied or
computed per step. Units: powers kW (electric input for heat pumps and heaters), capacities and energies kWh,
temperatures degC, states of charge and efficiencies as fractions.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from citylearn_env import devices
from citylearn_env.compat.base import CompatEnv


class Device:
    """A device in slot ``slot`` (``cooling_device``, ``dhw_storage``, ``electrical_storage`` ...) of building
    ``index``; its config fields (``nominal_power``, ``efficiency``, ``capacity`` ...) read as attributes."""

    def __init__(self, env: CompatEnv, index: int, slot: str) -> None:
        self._env, self._index, self._slot = env, index, slot

    @property
    def spec(self) -> Any:
        """The typed config of this device (a frozen dataclass)."""
        return getattr(self._env.config.buildings[self._index], self._slot)

    def __getattr__(self, name: str) -> Any:
        if not name.startswith("_"):
            spec = self.spec
            if dataclasses.is_dataclass(spec) and name in {f.name for f in dataclasses.fields(spec)}:
                return getattr(spec, name)
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")

    def _series(self, name: str) -> np.ndarray:
        return self._env.building_series(name, self._index)

    def get_metadata(self) -> dict[str, Any]:
        """The device's type and config fields, as plain numbers and lists."""
        spec = self.spec
        fields = {f.name: getattr(spec, f.name) for f in dataclasses.fields(spec) if f.name != "kind"}
        fields = {k: [list(p) for p in v] if isinstance(v, tuple) else float(v) for k, v in fields.items()}
        return {"type": type(self).__name__, **fields}


class ElectricDevice(Device):
    """A device that books electricity: ``electricity_consumption`` [kWh per step] of its end use."""

    @property
    def electricity_consumption(self) -> np.ndarray:
        """Electricity booked on the device at time steps 0 .. t [kWh]."""
        return self._series(f"{self._slot.removesuffix('_device')}_electricity_consumption")


class HeatPump(ElectricDevice):
    """A heat pump: ``nominal_power`` [kW electric], Carnot ``efficiency`` [-], target supply temperatures [degC]."""

    def get_cop(self, outdoor_dry_bulb_temperature: Any, heating: bool) -> np.ndarray:
        """COP [-] at each outdoor temperature [degC] (heating or cooling), replaced by 20 outside (0, 20]."""
        spec, t_out = self.spec, np.asarray(outdoor_dry_bulb_temperature, dtype=np.float64)
        if heating:
            return devices.carnot_cop_heating(t_out, spec.target_heating_temperature, spec.efficiency)
        return devices.carnot_cop_cooling(t_out, spec.target_cooling_temperature, spec.efficiency)


class ElectricHeater(ElectricDevice):
    """An electric heater: ``nominal_power`` [kW], thermal ``efficiency`` [-] (also its "COP")."""

    def get_cop(self, outdoor_dry_bulb_temperature: Any = None, heating: bool = True) -> np.ndarray | float:
        """The heater's efficiency [-] (per outdoor temperature when one is given)."""
        if outdoor_dry_bulb_temperature is None:
            return float(self.spec.efficiency)
        return np.full(np.shape(outdoor_dry_bulb_temperature), float(self.spec.efficiency))


class StorageTank(Device):
    """A thermal storage: ``capacity`` [kWh thermal], ``efficiency``, ``loss_coefficient`` [fraction per step],
    ``initial_soc`` [-], ``max_input_power`` / ``max_output_power`` [kWh per step]."""

    @property
    def soc(self) -> np.ndarray:
        """State of charge at time steps 0 .. t [-], relative to the nominal capacity."""
        return self._series(f"{self._slot}_soc")

    @property
    def energy_balance(self) -> np.ndarray:
        """Energy into (+) or out of (-) the storage at time steps 0 .. t [kWh, device side]."""
        return self._series(f"{self._slot}_energy_balance")

    @property
    def electricity_consumption(self) -> np.ndarray:
        """The storage's electricity at time steps 0 .. t [kWh] (negative: avoided consumption)."""
        return self._series(f"{self._slot}_electricity_consumption")


class Battery(StorageTank):
    """A battery: ``capacity`` [kWh], ``nominal_power`` [kW], round-trip ``efficiency``, ``depth_of_discharge``,
    ``capacity_loss_coefficient``, curves as [[x, y], ...]."""

    @property
    def efficiency_history(self) -> np.ndarray:
        """Round-trip efficiency of each step 0 .. t [-]."""
        return self._series("electrical_storage_efficiency")

    @property
    def capacity_history(self) -> np.ndarray:
        """Degraded capacity after each step 0 .. t [kWh]."""
        return self._series("electrical_storage_capacity")

    @property
    def degraded_capacity(self) -> float:
        """The capacity after the current step [kWh]."""
        return float(self.capacity_history[-1])

    @property
    def efficiency(self) -> float:
        """The current round-trip efficiency [-] (upstream's ``efficiency``: the last entry of
        :attr:`efficiency_history`, set by the power-efficiency curve each step); the nominal one is
        ``spec.efficiency``."""
        return float(self.efficiency_history[-1])

    @property
    def round_trip_efficiency(self) -> float:
        """``sqrt(efficiency)`` [-], the one-way efficiency applied to each charge and discharge (upstream's name
        for it)."""
        return float(np.sqrt(self.efficiency))

    def get_max_input_power(self) -> float:
        """The largest charge of the next step [kWh per step]: nominal power times the capacity-power curve at the
        state of charge after standby losses (CityLearn 2.1 extrapolates its first segment past the last point
        when its preset says so)."""
        spec, soc = self.spec, float(self.soc[-1])
        e0 = max(0.0, soc * spec.capacity * (1.0 - spec.loss_coefficient))
        curve = devices.Curve.from_points([spec.capacity_power_curve])
        fraction = devices.interpolate_curve(np.array([e0 / max(spec.capacity, 1e-6)]), curve,
                                             extrapolate_first_segment=self._env.settings.battery_curve_extrapolates_first_segment)
        return float(spec.nominal_power * fraction[0])

    def get_max_output_power(self) -> float:
        """The largest discharge of the next step [kWh per step]: the same curve limit as
        :meth:`get_max_input_power` (as upstream)."""
        return self.get_max_input_power()


class PV(Device):
    """Photovoltaics: ``nominal_power`` [kW peak]."""

    @property
    def spec(self) -> None:
        """PV has no device config of its own (its nominal power is a building field)."""
        return None

    @property
    def nominal_power(self) -> float:
        """Nominal power [kW peak]."""
        return float(self._env.config.buildings[self._index].pv_nominal_power)

    def get_generation(self, inverter_ac_power_per_kw: Any) -> np.ndarray:
        """PV output [kWh per step] of this system for a yield ``inverter_ac_power_per_kw`` [W of AC per kW of
        PV]: ``nominal_power * yield / 1000``."""
        return devices.pv_generation(np.float64(self.nominal_power), np.asarray(inverter_ac_power_per_kw,
                                                                                dtype=np.float64))

    def get_metadata(self) -> dict[str, Any]:
        """``{"type": "PV", "nominal_power": kW}``."""
        return {"type": "PV", "nominal_power": self.nominal_power}


#: device slot -> view class for a config device kind
SLOTS = ("cooling_device", "heating_device", "dhw_device", "cooling_storage", "heating_storage", "dhw_storage",
         "electrical_storage", "pv")


def device_view(env: CompatEnv, index: int, slot: str) -> Device:
    """The view of device ``slot`` of building ``index``."""
    if slot == "pv":
        return PV(env, index, slot)
    if slot == "electrical_storage":
        return Battery(env, index, slot)
    if slot.endswith("_storage"):
        return StorageTank(env, index, slot)
    kind = getattr(env.config.buildings[index], slot).kind
    return ElectricHeater(env, index, slot) if kind == "ElectricHeater" else HeatPump(env, index, slot)


__all__ = ["PV", "SLOTS", "Battery", "Device", "ElectricHeater", "HeatPump", "StorageTank", "device_view"]
