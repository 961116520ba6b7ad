"""EnergyPlus house models and ideal-load-variation generation (optional extra ``energyplus``).

Modules: :mod:`.metadata` (EULP ``in.*`` fields -> :class:`HouseParameters`), :mod:`.house` (the epJSON
house model), :mod:`.engine` (engine lookup, runs, ``.err`` excerpts), :mod:`.sqlite` (SQLite output),
:mod:`.ilv_runs` (ideal pass + replays -> ILV table), :mod:`.occupant_schedules` (seeded occupant schedules),
:mod:`.schedule_file` (a house's schedules as EnergyPlus reads them), :mod:`.setpoints`. The scripts that regenerate raw/ live in the top-level
``tools`` package (``python -m tools.make_raw``).
"""

from surrogates.energyplus.engine import EnergyPlusError, EnergyPlusNotInstalledError, find_energyplus
from surrogates.energyplus.ilv_runs import ILVCheckError, ILVConfig, ILVResult, generate_ilv
from surrogates.energyplus.metadata import HouseParameters, house_parameters_from_metadata

__all__ = ["EnergyPlusError", "EnergyPlusNotInstalledError", "HouseParameters", "ILVCheckError", "ILVConfig",
           "ILVResult", "find_energyplus", "generate_ilv", "house_parameters_from_metadata"]
