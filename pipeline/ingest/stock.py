"""Stock rows: one building's row of a ResStock characteristics table or of an EULP metadata table, as plain
JSON values (the simulation's input and a part of the build's cache keys).

Both readers return ``{column: value}`` with numpy scalars as Python values and NaN as None
(:func:`plain_value`); a missing file, id column or building is one :class:`pipeline.errors.InputError`
naming the file and the column.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.errors import InputError
from pipeline.ingest.eulp import locate_building, read_eulp_metadata
from pipeline.select import read_stock_table
from surrogates.energyplus.end_uses import RESULT_PREFIXES
from surrogates.energyplus.metadata import normalise_characteristics

#: columns of a characteristics row the simulation reads (the published layout and ResStock's own)
KEPT_PREFIXES = ("bldg_id", "building_id", "in.", "build_existing_model.", "upgrade_costs.floor")


def plain_value(value: object) -> object:
    """A numpy scalar as a plain Python value; NaN -> None (JSON-safe cache-key parts)."""
    value = value.item() if isinstance(value, np.generic) else value
    return None if isinstance(value, float) and np.isnan(value) else value


def read_characteristics_row(path: str | Path, bldg_id: int) -> dict[str, object]:
    """One stock row (either metadata layout) as plain JSON values in the published layout (``bldg_id``,
    ``in.*``) with its annual end uses (:data:`surrogates.energyplus.end_uses.RESULT_PREFIXES`); NaN -> None."""

    path = Path(path)
    raw = read_stock_table(path)
    id_column = "bldg_id" if "bldg_id" in raw.columns else "building_id"
    if id_column not in raw.columns:
        raise InputError("no building id column (expected 'bldg_id' or 'building_id')", file=path, column="bldg_id")
    rows = raw[pd.to_numeric(raw[id_column], errors="coerce") == int(bldg_id)]
    if rows.empty:
        raise InputError(f"building {bldg_id} not in the characteristics", file=path, column=id_column)
    keep = {k: v for k, v in rows.iloc[0].to_dict().items() if str(k).startswith((*KEPT_PREFIXES, *RESULT_PREFIXES))}
    return {k: plain_value(v) for k, v in normalise_characteristics(keep).items()}


def read_eulp_metadata_row(source: str, bldg_id: int, *, upgrade: int = 0,
                           state: str | None = None) -> dict[str, object]:
    """One building's EULP metadata row (release folder or base URL ``source``, see
    :func:`pipeline.ingest.eulp.locate_building`) as plain JSON values, ``bldg_id`` included; NaN -> None."""

    metadata_path, _ = locate_building(source, int(bldg_id), upgrade=upgrade, state=state)
    table = read_eulp_metadata(metadata_path)
    if int(bldg_id) not in table.index:
        raise InputError(f"building {bldg_id} not in the metadata", file=metadata_path, column="bldg_id")
    row = table.loc[int(bldg_id)].to_dict()
    return {"bldg_id": int(bldg_id), **{str(k): plain_value(v) for k, v in row.items()}}
