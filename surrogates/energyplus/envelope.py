"""Steady-state heat-loss coefficients of the project's house model, by component.

A climate-independent check of a house against its stock row: ResStock publishes each dwelling's Manual J
heating design loads by component (walls, windows, doors, ceilings and roofs, infiltration) at the row's own
design temperature, so the row's conductance of a component is its design load divided by the design
temperature difference (indoor 70 F, Manual J's heating design condition). The house model's conductances come
from the same constructions EnergyPlus is given (:func:`surrogates.energyplus.house.house_materials`): layer
resistances plus the surface films below, the simple-glazing U-factor (films included) and the constant
infiltration air change rate.

The slab, floors over unconditioned space and ducts are left out: their design loads depend on ground and
duct models that this comparison does not share.
"""

from __future__ import annotations

from dataclasses import dataclass

from surrogates.energyplus.house import footprint, house_materials
from surrogates.energyplus.metadata import HouseParameters

#: surface film resistances [m2 K/W], inside and outside (ASHRAE Fundamentals: still air on a wall and on a
#: ceiling with heat flowing up, 3.4 m/s wind outside)
WALL_FILMS_M2K_W = 0.12 + 0.03
ROOF_FILMS_M2K_W = 0.11 + 0.03
#: air density [kg/m3] and specific heat [J/(kg K)] for the infiltration conductance
AIR_DENSITY = 1.2
AIR_SPECIFIC_HEAT = 1005.0
#: Manual J's indoor heating design temperature [degF]
MANUAL_J_HEATING_INDOOR_F = 70.0
BTU_H_PER_W = 3.412142


@dataclass(frozen=True)
class HeatLoss:
    """Conductances [W/K] of the opaque walls, the windows, the roof (or top ceiling) and infiltration."""

    walls: float
    windows: float
    roof: float
    infiltration: float

    @property
    def total(self) -> float:
        """Sum of the components [W/K]."""
        return self.walls + self.windows + self.roof + self.infiltration


def construction_resistance(layers: list[str], materials: dict[str, dict[str, dict[str, object]]]) -> float:
    """Resistance [m2 K/W] of a construction's ``layers`` (names of ``Material`` / ``Material:NoMass``
    entries of the epJSON ``materials``), films excluded."""
    total = 0.0
    for name in layers:
        if name in materials.get("Material:NoMass", {}):
            total += float(materials["Material:NoMass"][name]["thermal_resistance"])
        else:
            layer = materials["Material"][name]
            total += float(layer["thickness"]) / float(layer["conductivity"])
    return total


def _layers(construction: dict[str, object]) -> list[str]:
    keys = ["outside_layer"] + [f"layer_{i}" for i in range(2, 11)]
    return [str(construction[k]) for k in keys if k in construction]


def house_heat_loss(house: HouseParameters) -> HeatLoss:
    """The house model's heat-loss coefficients [W/K] (geometry of :func:`surrogates.energyplus.house.footprint`,
    constructions of the epJSON model, infiltration ``house.ach_natural`` over the conditioned volume)."""
    materials = house_materials(house)
    constructions = materials["Construction"]
    width, depth = footprint(house)
    height = house.story_height_m * house.stories
    gross_wall = 2.0 * (width + depth) * height
    window_area = gross_wall * house.window_to_wall
    wall_r = construction_resistance(_layers(constructions["exterior_wall"]), materials) + WALL_FILMS_M2K_W
    roof_r = construction_resistance(_layers(constructions["roof"]), materials) + ROOF_FILMS_M2K_W
    volume = house.floor_area_m2 * house.story_height_m
    return HeatLoss(walls=(gross_wall - window_area) / wall_r, windows=window_area * house.window_u,
                    roof=width * depth / roof_r,
                    infiltration=AIR_DENSITY * AIR_SPECIFIC_HEAT * house.ach_natural * volume / 3600.0)


def stock_heat_loss(design_loads_btu_h: dict[str, float], design_temperature_f: float) -> HeatLoss:
    """A stock row's heat-loss coefficients [W/K] from its Manual J heating design loads [Btu/h] (keys
    ``walls``, ``doors``, ``windows``, ``ceilings``, ``roofs``, ``infiltration``; doors count as walls) at
    its heating design temperature [degF]. ValueError when the design temperature is not below 70 F."""
    delta_k = (MANUAL_J_HEATING_INDOOR_F - design_temperature_f) * 5.0 / 9.0
    if delta_k <= 0:
        raise ValueError(f"heating design temperature {design_temperature_f} F is not below "
                         f"{MANUAL_J_HEATING_INDOOR_F} F")

    def w_per_k(*keys: str) -> float:
        return sum(design_loads_btu_h.get(k, 0.0) for k in keys) / BTU_H_PER_W / delta_k

    return HeatLoss(walls=w_per_k("walls", "doors"), windows=w_per_k("windows"),
                    roof=w_per_k("ceilings", "roofs"), infiltration=w_per_k("infiltration"))
