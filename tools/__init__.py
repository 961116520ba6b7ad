"""Developer scripts that regenerate the embedded inputs under ``raw/`` (not shipped in the wheel).

Modules: :mod:`tools.make_raw` (``python -m tools.make_raw``: everything under raw/ but raw/tariffs/),
:mod:`tools.eulp_export` (a house-year of the EnergyPlus house model in the EULP 15-minute layout),
:mod:`tools.synthetic_fuel_mix` (the SYNTHETIC ERCOT fuel-mix workbook). They need the ``energyplus`` extra.
"""
