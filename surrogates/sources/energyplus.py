"""ILV source "energyplus": EULP metadata row + EPW -> the ILV table of one building, via EnergyPlus.

Plain functions: :func:`energyplus_ilv_table` (the table in memory), :func:`write_ilv_table`,
:func:`build_ilv_table` (one building's table generated and written; the build's Prefect flow runs its own
tasks, :mod:`pipeline.flows`). Needs the optional extra ``districtgen[energyplus]``.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

import pandas as pd

from citylearn_env.errors import InputError
from surrogates.energyplus.ilv_runs import ILVConfig, ILVResult, generate_ilv
from surrogates.energyplus.metadata import HouseParameters, house_parameters_from_metadata
from surrogates.ilv import validate_ilv


def energyplus_ilv_table(metadata_row: Mapping[str, object], epw: Path, *, config: ILVConfig | None = None,
                         workdir: Path | None = None, source: object = "metadata") -> ILVResult:
    """Generate one building's ILV data (see :func:`surrogates.energyplus.ilv_runs.generate_ilv`) from its EULP
    metadata row (``bldg_id``, ``in.sqft``, ``in.vintage``, ...; ``source`` names the file in errors)."""
    house = house_parameters_from_metadata(metadata_row, source=source)
    return generate_ilv(house, Path(epw), config=config or ILVConfig(), workdir=workdir)


def write_ilv_table(table: pd.DataFrame, path: Path, *, compression_level: int = 9) -> Path:
    """Validate ``table`` against the ILV contract (:func:`surrogates.ilv.validate_ilv`) and write it
    atomically (``.parquet`` with zstd compression, or ``.csv``, by suffix): a temporary file in the same
    folder is renamed into place, so a failure never leaves a partial table."""
    path = Path(path)
    if path.suffix not in (".parquet", ".csv"):
        raise InputError("ILV table must end in .parquet or .csv", file=path)
    table = validate_ilv(table, source=path, min_references=1)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        if path.suffix == ".parquet":
            table.to_parquet(tmp_name, index=False, compression="zstd", compression_level=compression_level)
        else:
            table.to_csv(tmp_name, index=False, date_format="%Y-%m-%d %H:%M:%S")
        os.replace(tmp_name, path)
    finally:
        Path(tmp_name).unlink(missing_ok=True)
    return path


def build_ilv_table(metadata_row: Mapping[str, object], epw: str | Path, output: str | Path, *,
                    config: ILVConfig | None = None, workdir: str | Path | None = None) -> dict[str, object]:
    """Generate and write one building's ILV table; returns a summary (``bldg_id``, ``path``, ``rows``,
    ``replay_mad_c``, ``timings_s``). Nothing is written when any simulation or the physical check fails."""
    result = energyplus_ilv_table(metadata_row, Path(epw), config=config,
                                  workdir=Path(workdir) if workdir else None)
    path = write_ilv_table(result.table, Path(output))
    return {"bldg_id": int(metadata_row["bldg_id"]), "path": str(path), "rows": len(result.table),
            "replay_mad_c": result.replay_mad_c, "timings_s": result.timings_s}


def house_summary(house: HouseParameters) -> dict[str, object]:
    """What the report says about a simulated house: heating fuel and system, set points [degC] as used
    (after offsets and the repair rule) and how many hours of the day were repaired."""
    cooling, heating, repaired = house.setpoints()
    return {"bldg_id": house.bldg_id, "floor_area_m2": round(house.floor_area_m2, 1), "stories": house.stories,
            "vintage": house.vintage, "occupants": house.occupants, "heating_fuel": house.heating_fuel,
            "heating_system": house.heating_system,
            "cooling_set_point_c": [min(map(min, cooling)), max(map(max, cooling))],
            "heating_set_point_c": [min(map(min, heating)), max(map(max, heating))],
            "set_point_hours_repaired": repaired,
            "stock_set_points_c": [round(house.heating_setpoint_c, 2), round(house.cooling_setpoint_c, 2)]}


def simulate_house(characteristics: Mapping[str, object], epw: Path, *, config: ILVConfig | None = None,
                   source: object = "characteristics") -> tuple[pd.DataFrame, pd.DataFrame, dict[str, object]]:
    """One EnergyPlus pass over a real stock row: (hourly loads, ILV table, house summary).

    ``characteristics``: a row of either metadata layout (``bldg_id``/``in.*`` or
    ``building_id``/``build_existing_model.*``). The loads (:func:`surrogates.energyplus.ilv_runs.hourly_loads`)
    and the ILV table come from the same runs on ``epw``; the summary is :func:`house_summary` plus the
    replay check's mean absolute deviation [degC].
    """
    house = house_parameters_from_metadata(characteristics, source=source)
    result = generate_ilv(house, Path(epw), config=config or ILVConfig())
    table = validate_ilv(result.table, source=f"EnergyPlus ILV of building {house.bldg_id}")
    return result.loads, table, {**house_summary(house), "replay_mad_c": round(result.replay_mad_c, 4)}
