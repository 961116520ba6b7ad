"""EnergyPlus house models and ideal-load-variation generation (optional extra ``energyplus``).

Modules: :mod:`.metadata` (EULP ``in.*`` fields -> :class:`HouseParameters`), :mod:`.house` (the epJSON
house model), :mod:`.runner` (engine lookup, runs, ``.err`` excerpts), :mod:`.sqlite` (SQLite output),
:mod:`.ilv` (ideal pass + replays -> ILV table). The scripts that regenerate raw/ live in the top-level
``tools`` package (``python -m tools.make_raw``).
"""

from surrogates.energyplus.ilv import ILVCheckError, ILVConfig, ILVResult, generate_ilv
from surrogates.energyplus.metadata import HouseParameters, house_parameters_from_metadata
from surrogates.energyplus.runner import EnergyPlusError, EnergyPlusNotInstalledError, find_energyplus

__all__ = ["EnergyPlusError", "EnergyPlusNotInstalledError", "HouseParameters", "ILVCheckError", "ILVConfig",
           "ILVResult", "find_energyplus", "generate_ilv", "house_parameters_from_metadata"]
