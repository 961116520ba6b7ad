"""Write a CityLearn CSV (building, weather, pricing or carbon file) in either dataset layout."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.dataset import header

#: columns written as integers (calendar and mode flags); everything else as floats
INTEGER_COLUMNS = frozenset({"month", "hour", "day_type", "daylight_savings_status", "hvac_mode", "power_outage"})


def write_citylearn_csv(
    frame: pd.DataFrame,
    columns: dict[str, str],
    path: str | os.PathLike,
    layout: str = "v2.2",
    required: int | None = None,
) -> Path:
    """Write ``frame`` as a CityLearn CSV, atomically (temp file in the same folder, then rename).

    Parameters
    ----------
    frame
        One row per time step; columns named by our internal (v2.2) names, i.e. keys of ``columns``.
    columns
        A column table from :mod:`citylearn_env.dataset` (internal name -> v2.1 header, in file order).
    path
        Output file.
    layout
        ``"v2.1"`` (positional columns, human-readable header) or ``"v2.2"`` (snake_case header).
    required
        How many leading columns of the table must be present (default: all). The file holds the longest
        leading run of table columns found in ``frame``, so v2.1 positions stay right.

    Returns
    -------
    The written path. Raises ValueError for unknown or missing columns and for NaN/inf values (a writer
    bug, not bad user input).
    """
    names = list(columns)
    unknown = [c for c in frame.columns if c not in columns]
    if unknown:
        raise ValueError(f"columns not in the CityLearn table: {unknown}")
    count = 0
    while count < len(names) and names[count] in frame.columns:
        count += 1
    need = len(names) if required is None else required
    if count < need:
        raise ValueError(f"missing CityLearn column {names[count]!r} (the first {need} are required)")
    skipped = [c for c in names[count:] if c in frame.columns]
    if skipped:
        raise ValueError(f"column(s) {skipped} present but {names[count]!r} before them is missing")
    out = frame[names[:count]].copy()
    for name in out.columns:
        values = out[name].to_numpy(dtype=float)
        if not np.isfinite(values).all():
            raise ValueError(f"column {name!r} has NaN or infinite values at row {int(np.argmin(np.isfinite(values)))}")
        if name in INTEGER_COLUMNS:
            out[name] = np.rint(values).astype(np.int64)
    out.columns = header(dict(zip(names[:count], [columns[n] for n in names[:count]], strict=True)), layout)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "w", newline="") as stream:
            out.to_csv(stream, index=False, lineterminator="\n")
        os.replace(temp, path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise
    return path
