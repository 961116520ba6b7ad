"""Sources of ideal-load-variation tables: precomputed CSV/parquet, FMU, EnergyPlus."""
