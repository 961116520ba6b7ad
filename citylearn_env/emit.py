"""The CityLearn schema writer: typed building entries -> the schema dict, and an atomic ``schema.json`` writer.

Kept apart from :mod:`citylearn_env.dataset` (which owns the data *files*): this module owns the schema
*document* that points at them. The pipeline's build and the synthetic example district both emit through
:func:`schema_document`, so the two produce the same keys for the same inputs.

Units of device attributes follow :mod:`citylearn_env.config`: powers in kW (electric input for heat pumps
and heaters), capacities in kWh, temperatures in degC, efficiencies and coefficients as fractions.
"""

from __future__ import annotations

import json
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from citylearn_env.config import ACTION_NAMES, ACTIONS_SINCE_2_2
from citylearn_env.dataset import DynamicsBlock, dynamics_entry, write_atomically

#: schema slots in the order they are written, with the upstream device type used when none is given
DEVICE_SLOTS: dict[str, str] = {
    "cooling_device": "citylearn.energy_model.HeatPump",
    "heating_device": "citylearn.energy_model.HeatPump",
    "dhw_device": "citylearn.energy_model.ElectricHeater",
    "cooling_storage": "citylearn.energy_model.StorageTank",
    "heating_storage": "citylearn.energy_model.StorageTank",
    "dhw_storage": "citylearn.energy_model.StorageTank",
    "electrical_storage": "citylearn.energy_model.Battery",
    "pv": "citylearn.energy_model.PV",
}
DEFAULT_REWARD: dict[str, Any] = {"type": "citylearn.reward_function.RewardFunction", "attributes": {}}


@dataclass(frozen=True)
class BuildingEntry:
    """One building of a schema.

    ``devices``: slot (a key of :data:`DEVICE_SLOTS`) -> plain attribute dict (e.g. the output of
    :func:`citylearn_env.sizing.size_devices`); ``device_types``: slot -> upstream type name where it is not
    the slot's default (e.g. ``{"dhw_device": "citylearn.energy_model.HeatPump"}``). File names are relative
    to the schema's folder; ``energy_simulation`` defaults to ``<name>.csv``; ``pricing`` /
    ``carbon_intensity`` may be None (no file: zeros). ``dynamics``: the LSTM model (one block serves both
    modes) or None for a plain building.
    """

    name: str
    devices: Mapping[str, Mapping[str, Any]]
    energy_simulation: str | None = None
    weather: str = "weather.csv"
    pricing: str | None = "pricing.csv"
    carbon_intensity: str | None = "carbon_intensity.csv"
    dynamics: DynamicsBlock | None = None
    device_types: Mapping[str, str] = field(default_factory=dict)
    inactive_observations: tuple[str, ...] = ()
    inactive_actions: tuple[str, ...] = ()


def building_spec(entry: BuildingEntry, layout: str = "v2.2") -> dict[str, Any]:
    """The schema ``buildings.<name>`` object of ``entry``; ``layout`` decides the ``dynamics`` form (v2.2: one
    object; v2.1: the ``{"cooling", "heating"}`` pair, same block twice)."""
    unknown = sorted(set(entry.devices) - set(DEVICE_SLOTS))
    if unknown:
        raise ValueError(f"building {entry.name!r}: unknown device slot(s) {unknown}; known: {list(DEVICE_SLOTS)}")
    spec: dict[str, Any] = {
        "type": "citylearn.building.LSTMDynamicsBuilding" if entry.dynamics else "citylearn.building.Building",
        "include": True,
        "energy_simulation": entry.energy_simulation or f"{entry.name}.csv",
        "weather": entry.weather,
    }
    if entry.pricing:
        spec["pricing"] = entry.pricing
    if entry.carbon_intensity:
        spec["carbon_intensity"] = entry.carbon_intensity
    spec["inactive_observations"] = list(entry.inactive_observations)
    spec["inactive_actions"] = list(entry.inactive_actions)
    for slot, default_type in DEVICE_SLOTS.items():
        if slot in entry.devices:
            spec[slot] = {"type": entry.device_types.get(slot, default_type), "autosize": False,
                          "attributes": _plain(entry.devices[slot])}
    spec["power_outage"] = {"simulate_power_outage": False, "stochastic_power_outage": False}
    if entry.dynamics is not None:
        spec["dynamics"] = dynamics_entry(entry.dynamics, layout)
    return spec


def schema_document(buildings: Sequence[BuildingEntry], *, hours: int, observations: Sequence[str],
                    shared_observations: Collection[str], active_actions: Collection[str],
                    active_observations: Collection[str] | None = None, layout: str = "v2.2",
                    central_agent: bool = True, random_seed: int | None = None,
                    reward_function: Mapping[str, Any] | None = None,
                    seconds_per_time_step: float = 3600.0) -> dict[str, Any]:
    """The whole CityLearn schema dict of a district (``root_directory`` null: files beside the schema).

    Parameters
    ----------
    buildings
        The building entries, in schema order.
    hours
        Simulation length in time steps: ``simulation_end_time_step = hours - 1``; one episode.
    observations
        Observation names in schema order; ``shared_observations`` are shared in the central agent;
        ``active_observations`` (default: all) are active.
    active_actions
        Names of :data:`citylearn_env.config.ACTION_NAMES` that are active (the rest are written inactive).
    layout
        ``"v2.2"`` or ``"v2.1"``: the form of each building's ``dynamics`` entry; v2.1 also leaves out the
        actions CityLearn 2.1 does not know (:data:`citylearn_env.config.ACTIONS_SINCE_2_2`).
    random_seed, reward_function, central_agent, seconds_per_time_step
        Written as given (reward default: the plain ``citylearn.reward_function.RewardFunction``).

    This is what ``pipeline.builder.steps.schema_dict`` produces for the same inputs.
    """
    unknown = sorted(set(active_actions) - set(ACTION_NAMES))
    if unknown:
        raise ValueError(f"unknown action(s) {unknown}; known: {', '.join(ACTION_NAMES)}")
    actions = [a for a in ACTION_NAMES if layout != "v2.1" or a not in ACTIONS_SINCE_2_2]
    newer = sorted(set(active_actions) - set(actions))
    if newer:
        raise ValueError(f"action(s) {newer} need the v2.2 layout (CityLearn 2.1 does not know them)")
    active = set(observations) if active_observations is None else set(active_observations)
    names = [b.name for b in buildings]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate building names in {names}")
    return {
        "root_directory": None, "central_agent": bool(central_agent),
        "simulation_start_time_step": 0, "simulation_end_time_step": int(hours) - 1,
        "episode_time_steps": None, "rolling_episode_split": False, "random_episode_split": False,
        "seconds_per_time_step": float(seconds_per_time_step), "random_seed": random_seed,
        "observations": {n: {"active": n in active, "shared_in_central_agent": n in shared_observations}
                         for n in observations},
        "actions": {a: {"active": a in active_actions} for a in actions},
        "reward_function": dict(reward_function) if reward_function is not None else dict(DEFAULT_REWARD),
        "buildings": {b.name: building_spec(b, layout) for b in buildings},
    }


def write_schema(path: str | Path, schema: Mapping[str, Any]) -> Path:
    """Write ``schema`` as indented JSON, atomically (:func:`citylearn_env.dataset.write_atomically`).
    Returns ``path``."""
    return write_atomically(path, lambda stream: json.dump(schema, stream, indent=2))


def _plain(attributes: Mapping[str, Any]) -> dict[str, Any]:
    """Attribute dict with numpy scalars/arrays turned into JSON types."""
    out: dict[str, Any] = {}
    for key, value in attributes.items():
        if hasattr(value, "tolist"):
            value = value.tolist()
        elif isinstance(value, tuple):
            value = [list(v) if isinstance(v, tuple) else v for v in value]
        out[key] = value
    return out
