"""Device sizing for the pipeline: the pure rules live in :mod:`citylearn_env.sizing` (re-exported here, so
``pipeline.sizing.SizingRules``, ``heat_pump_power``, ``dhw_heater_power``, ``dhw_tank``, ``battery``,
``pv_power`` and ``BATTERIES`` keep working); this module adds the DataFrame entry point."""

from __future__ import annotations

import numpy as np

from citylearn_env.sizing import (
    BATTERIES,
    SizingRules,
    battery,
    dhw_heater_power,
    dhw_tank,
    heat_pump_power,
    pv_power,
    size_devices,
)

__all__ = ["BATTERIES", "SizingRules", "battery", "dhw_heater_power", "dhw_tank", "heat_pump_power", "pv_power",
           "size_building", "size_devices"]


def size_building(frame, outdoor_c: np.ndarray, rules: SizingRules) -> dict[str, dict]:
    """All device attributes of one building from its CityLearn frame (cooling/dhw/NSL/solar columns);
    see :func:`citylearn_env.sizing.size_devices`."""
    return size_devices({c: frame[c].to_numpy(dtype=float) for c in
                         ("cooling_demand", "dhw_demand", "non_shiftable_load", "solar_generation")},
                        outdoor_c, rules)
