"""``env.buildings[i]``: read-only building views with upstream's attribute names (mirrors ``citylearn.building``).

A view holds only its environment and index. Every attribute is read from the native environment when it is
asked for: time series are the building's row of the native (B, T) arrays over time steps 0 .. t of the current
episode (``b.net_electricity_consumption`` [kWh], ``b.indoor_dry_bulb_temperature`` [degC],
``b.electrical_storage.soc`` [-] ...), data series (``b.energy_simulation.<column>``, ``b.weather.<column>``,
``b.pricing.<column>``, ``b.carbon_intensity.<column>``) the whole episode; so an unused view costs nothing per
step. Views are read only: setting an attribute raises, except ``ignore_dynamics`` of an LSTM building (upstream's
switch that turns its temperature model off), which rebuilds the environment between episodes.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.base import CompatEnv
from citylearn_env.compat.energy_model import SLOTS, Device, device_view

#: periodic observations and their values (upstream's ``Building.get_periodic_observation_metadata``)
PERIODIC = {"hour": range(1, 25), "day_type": range(1, 9), "month": range(1, 13)}


class BuildingObservations(Mapping[str, float]):
    """Every observation of one building at the current step, name -> value, read on access (what upstream's
    reward functions receive as one element of ``observations``)."""

    def __init__(self, view: Mapping[str, np.ndarray], index: int, names: Sequence[str]) -> None:
        self._view, self._index, self._names = view, index, names

    def __getitem__(self, name: str) -> float:
        if name not in self._names:
            raise KeyError(name)
        return float(self._view[name][self._index])

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: object) -> bool:
        return name in self._names


class DataView:
    """A building's data-set columns over the whole current episode, as attributes (``.hour``,
    ``.outdoor_dry_bulb_temperature`` [degC], ``.electricity_pricing`` [$/kWh], ``.carbon_intensity``
    [kg/kWh] ...)."""

    def __init__(self, env: CompatEnv, index: int) -> None:
        self._env, self._index = env, index

    def __getattr__(self, name: str) -> np.ndarray:
        if name.startswith("_"):
            raise AttributeError(name)
        district = self._env.native.district
        if name == "solar_generation":  # upstream's data column [W/kW], not the building's generation [kWh]
            series = district.episode.columns.get("solar_generation")
        else:
            series = district.static_series(name)
        if series is None:
            raise AttributeError(f"no data column {name!r}")
        return series[self._index]


class Building:
    """Building ``index`` of a compat environment (see the module docstring)."""

    def __init__(self, env: CompatEnv, index: int) -> None:
        object.__setattr__(self, "_env", env)
        object.__setattr__(self, "_index", index)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__}.{name} is read only in citylearn_env.compat: change the "
                             "schema or the CompatEnv keywords instead")

    def __getattr__(self, name: str) -> Any:
        if not name.startswith("_"):
            env = object.__getattribute__(self, "_env")
            if name in env.series_names:
                return env.building_series(name, self._index)
            if name in SLOTS:
                return device_view(env, self._index, name)
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")

    # ------------------------------------------------------------------ identity and spaces
    @property
    def name(self) -> str:
        return self._env.config.buildings[self._index].name

    @property
    def time_step(self) -> int:
        return self._env.time_step

    @property
    def episode_tracker(self) -> Any:
        return self._env.episode_tracker

    @property
    def seconds_per_time_step(self) -> float:
        return self._env.seconds_per_time_step

    @property
    def active_observations(self) -> list[str]:
        """Names of the building's active observations, in vector order."""
        return self._env.observation_names_of(self._index)

    @property
    def active_actions(self) -> list[str]:
        """Names of the building's active actions, in vector order."""
        return self._env.action_names_of(self._index)

    @property
    def observation_metadata(self) -> dict[str, bool]:
        """Every schema observation -> whether it is active for this building."""
        active = set(self._env.config.buildings[self._index].active_observations)
        return {n: n in active for n, _ in self._env.config.observations}

    @property
    def action_metadata(self) -> dict[str, bool]:
        """Every action of the building -> whether it is active."""
        active = set(self._env.config.buildings[self._index].active_actions)
        names = ("cooling_storage", "heating_storage", "dhw_storage", "electrical_storage", "cooling_device",
                 "heating_device")
        return {n: n in active for n in (*names, *[a for a in active if a not in names])}

    @property
    def observation_space(self) -> gym.spaces.Box:
        return self._env.building_observation_space(self._index)

    @property
    def action_space(self) -> gym.spaces.Box:
        return self._env.building_action_space(self._index)

    # ------------------------------------------------------------------ data
    @property
    def energy_simulation(self) -> DataView:
        """The building's data columns (one view serves upstream's four data objects)."""
        return DataView(self._env, self._index)

    weather = pricing = carbon_intensity = energy_simulation

    @property
    def power_outage_signal(self) -> np.ndarray:
        """The outage signal of the whole episode (1 = outage)."""
        return self._env.native.district.episode.outage[self._index]

    # ------------------------------------------------------------------ observations and metadata
    def observations(self, include_all: bool = False, normalize: bool = False, periodic_normalization: bool = False,
                     check_limits: bool = False) -> Mapping[str, float]:
        """The building's observations at the current step: the active ones (a dict, in vector order), or with
        ``include_all`` every observation (read on access). Raw values only."""
        if normalize or periodic_normalization:
            raise NotImplementedError("normalised building observations are not provided; wrap the environment "
                                      "in citylearn_env.compat.wrappers.NormalizedObservationWrapper")
        if include_all:
            return self._env.building_observations(self._index)
        values = self._env.observations_of(self._index)
        return dict(zip(self.active_observations, values, strict=True))

    def get_metadata(self) -> dict[str, Any]:
        """Static facts of the building: name, observation and action metadata, every device's parameters."""
        return {**self._env.base_metadata(), "name": self.name, "observation_metadata": self.observation_metadata,
                "action_metadata": self.action_metadata, "maximum_temperature_delta": 10.0,
                **{slot: device_view(self._env, self._index, slot).get_metadata() for slot in SLOTS}}

    @staticmethod
    def get_periodic_observation_metadata() -> dict[str, range]:
        """Values of the periodic observations: hour 1..24, day_type 1..8, month 1..12."""
        return dict(PERIODIC)

    def device(self, slot: str) -> Device:
        """The view of device ``slot`` (same as the attribute of that name)."""
        return device_view(self._env, self._index, slot)


class DynamicsBuilding(Building):
    """A building whose indoor temperature a model predicts (upstream's ``DynamicsBuilding``)."""

    @property
    def ignore_dynamics(self) -> bool:
        """Whether the temperature model is switched off (temperatures and loads are the data set's)."""
        return self._env.ignores_dynamics(self._index)

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "ignore_dynamics":
            self._env.set_ignore_dynamics(self._index, bool(value))
        else:
            super().__setattr__(name, value)


class LSTMDynamicsBuilding(DynamicsBuilding):
    """A building with an LSTM indoor-temperature model (upstream's ``LSTMDynamicsBuilding``)."""


def building_view(env: CompatEnv, index: int, dynamics: bool) -> Building:
    """The view of building ``index``: an :class:`LSTMDynamicsBuilding` when it has (or had) a temperature model."""
    return LSTMDynamicsBuilding(env, index) if dynamics else Building(env, index)


__all__ = ["Building", "BuildingObservations", "DataView", "DynamicsBuilding", "LSTMDynamicsBuilding",
           "building_view"]
