"""The season a benchmark runs in, and what of the paper's set-up a district's test period cannot show.

The SimBuild 2024 paper ran in a cooling month: its heat-pump benchmark controls the cooling device and its
discomfort & consumption reward weighs the side below the set point ``m`` times (over-cooling). On a heating
district the same benchmark controls the heating device: the reward's formula is unchanged, so ``m`` then weighs
under-heating (below the heating set point), and the over/under statistics are named for heating.

The season of a building over a period is the larger of its ideal heating and cooling demand there (kWh, the
data set's ``heating_demand`` / ``cooling_demand``). :func:`notes` gives one line per part of a benchmark the
test period cannot exercise (a flat price for a cost objective, no PV for a battery-with-PV one, ...); the
runner prints them and writes them under the results, it does not refuse the run. A device a benchmark needs
and a role's building lacks is refused by :func:`pipeline.paper.benchmarks.check_devices`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from citylearn_env.config import BuildingConfig

Season = Literal["cooling", "heating"]

#: the heat-pump action and device slot of each season
DEVICE_OF: dict[str, str] = {"cooling": "cooling_device", "heating": "heating_device"}
#: names of the reward's two sides (below the set point, above it) in each season
SIDES_OF: dict[str, tuple[str, str]] = {"cooling": ("overcooling", "undercooling"),
                                        "heating": ("underheating", "overheating")}


def period(building: BuildingConfig, split: tuple[int, int], name: str) -> np.ndarray:
    """``building``'s data series ``name`` over the inclusive step range ``split`` (steps from the simulation
    start); an empty array when the data set has no such series."""
    values = building.series.get(name)
    if values is None:
        return np.zeros(0)
    return np.asarray(values, dtype=float)[split[0]:split[1] + 1]


def season(building: BuildingConfig, split: tuple[int, int]) -> Season:
    """``"heating"`` when the building's ideal heating demand over ``split`` exceeds its ideal cooling demand
    [kWh], else ``"cooling"`` (a period with neither: cooling, the paper's season)."""
    heating = period(building, split, "heating_demand").sum()
    cooling = period(building, split, "cooling_demand").sum()
    return "heating" if heating > cooling else "cooling"


def _flat(values: np.ndarray) -> bool:
    return values.size == 0 or float(np.ptp(values)) <= 1e-9


def notes(buildings: Sequence[BuildingConfig], split: tuple[int, int], *, objective: str, dhw: bool,
          bess_pv: bool, hp: bool) -> list[str]:
    """One line per part of a benchmark (its ``objective``: cost | emissions | peak | discomfort_consumption |
    none, and the devices it controls) that the test period ``split`` of its ``buildings`` (B1 first) cannot
    exercise; empty when every part applies."""
    b1 = buildings[0]
    out = []
    if objective == "cost" and _flat(period(b1, split, "electricity_pricing")):
        out.append(f"the electricity price of {b1.name} is flat over the test period: nothing to gain by shifting "
                   "load in time, the cost rule and reward can only match no control")
    if objective == "emissions" and _flat(period(b1, split, "carbon_intensity")):
        out.append(f"the carbon intensity of {b1.name} is flat over the test period: nothing to gain by shifting "
                   "load in time")
    if bess_pv and period(b1, split, "solar_generation").sum() <= 0.0:
        out.append(f"{b1.name} has no PV generation over the test period: the battery can only shift grid energy")
    if dhw and period(b1, split, "dhw_demand").sum() <= 0.0:
        out.append(f"{b1.name} has no DHW demand over the test period: the DHW tank has nothing to serve")
    if hp:
        kind = season(b1, split)
        below, _ = SIDES_OF[kind]
        if kind == "heating":
            out.append(f"{b1.name} is heated over the test period: the heat-pump benchmark controls its heating "
                       f"device and the multiplier weighs {below} (the paper's cooling month weighs over-cooling)")
    return out
