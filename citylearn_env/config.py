"""Typed, frozen configuration of a district: what :func:`citylearn_env.schema.load_schema` returns.

Units: powers in kW (electric input for heat pumps and heaters), capacities in kWh, temperatures in degC,
efficiencies and coefficients as fractions. Time series are read-only float64 numpy arrays over the whole
simulation range (row ``simulation_start_time_step`` .. ``simulation_end_time_step`` of the files).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

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
)


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
class LSTMModel:
    """One LSTM temperature model: weights file, input names and min-max bounds, architecture."""

    filepath: str
    input_observation_names: tuple[str, ...]
    input_normalization_minimum: tuple[float, ...]
    input_normalization_maximum: tuple[float, ...]
    hidden_size: int
    num_layers: int
    lookback: int


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
    """One building: devices, the LSTM models (cooling, heating) if any, and its time series."""

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
    cooling_model: LSTMModel | None = None
    heating_model: LSTMModel | None = None
    active_observations: tuple[str, ...] = ()
    active_actions: tuple[str, ...] = ()

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

    @property
    def building_names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.buildings)

    @property
    def shared_observations(self) -> tuple[str, ...]:
        return tuple(name for name, shared in self.observations if shared)


def frozen_series(series: Mapping[str, np.ndarray]) -> Mapping[str, np.ndarray]:
    """Make every array read-only and wrap the mapping so the configuration cannot be changed."""
    for value in series.values():
        value.flags.writeable = False
    return MappingProxyType(dict(series))
