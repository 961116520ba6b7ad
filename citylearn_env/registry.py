"""One explicit table from schema ``type`` strings to what they mean here.

Upstream CityLearn imports whatever dotted path a schema names. We never import from a schema: every accepted
name is listed below, and an unknown one is a :class:`~citylearn_env.errors.SchemaError` that lists the known
names. Bare class names (``"Battery"``) are accepted as well as the upstream dotted paths.
"""

from __future__ import annotations

from citylearn_env.errors import SchemaError

_UPSTREAM = {
    # building classes (those with LSTM temperature dynamics: DYNAMICS_BUILDINGS)
    "building": {
        "citylearn.building.Building": "Building",
        "citylearn.building.DynamicsBuilding": "LSTMDynamicsBuilding",
        "citylearn.building.LSTMDynamicsBuilding": "LSTMDynamicsBuilding",
        # CityLearn 2.4+: an LSTM building whose occupant overrides its set points (citylearn_env.occupant)
        "citylearn.building.LogisticRegressionOccupantInteractionBuilding":
            "LogisticRegressionOccupantInteractionBuilding",
    },
    "device": {
        "citylearn.energy_model.HeatPump": "HeatPump",
        "citylearn.energy_model.ElectricHeater": "ElectricHeater",
        "citylearn.energy_model.StorageTank": "StorageTank",
        "citylearn.energy_model.Battery": "Battery",
        "citylearn.energy_model.PV": "PV",
    },
    "dynamics": {
        "citylearn.dynamics.LSTMDynamics": "LSTMDynamics",
    },
    "power_outage": {
        "citylearn.power_outage.ReliabilityMetricsPowerOutage": "ReliabilityMetricsPowerOutage",
    },
    "occupant": {
        "citylearn.occupant.LogisticRegressionOccupant": "LogisticRegressionOccupant",
    },
}

#: the building class whose occupant overrides its set points (it runs LSTM dynamics too)
OCCUPANT_BUILDING = "LogisticRegressionOccupantInteractionBuilding"
#: building classes that run LSTM temperature dynamics
DYNAMICS_BUILDINGS = ("LSTMDynamicsBuilding", OCCUPANT_BUILDING)

#: which device classes may sit in which building slot
SLOT_CLASSES: dict[str, tuple[str, ...]] = {
    "cooling_device": ("HeatPump", "ElectricHeater"),
    "heating_device": ("HeatPump", "ElectricHeater"),
    "dhw_device": ("HeatPump", "ElectricHeater"),
    "cooling_storage": ("StorageTank",),
    "heating_storage": ("StorageTank",),
    "dhw_storage": ("StorageTank",),
    "electrical_storage": ("Battery",),
    "pv": ("PV",),
}


def known_types(kind: str) -> list[str]:
    """All accepted ``type`` strings of ``kind`` (building, device, dynamics, power_outage, occupant)."""
    table = _UPSTREAM[kind]
    return sorted(set(table) | set(table.values()))


def resolve_type(kind: str, name: object, *, where: str) -> str:
    """Map a schema ``type`` string of ``kind`` to our class name, or raise a SchemaError listing known ones."""
    table = _UPSTREAM[kind]
    if isinstance(name, str):
        if name in table:
            return table[name]
        if name in table.values():
            return name
    raise SchemaError(
        f"unknown {kind} type {name!r}; known types: {', '.join(known_types(kind))}", column=where
    )
