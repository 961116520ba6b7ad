"""Grid carbon intensity of a period, read from an ERCOT fuel-mix file: the fuel-mix readers
(:mod:`pipeline.ingest.fuel_mix`) and the generation-weighted intensity (:func:`pipeline.carbon.carbon_intensity`)
composed over the period's hours.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from pipeline.carbon import carbon_intensity
from pipeline.ingest.fuel_mix import (
    TIMEZONE,
    read_emission_factors,
    read_fuel_mix_csv,
    read_fuel_mix_workbook,
)
from pipeline.ingest.timeindex import select_period


def read_carbon_intensity(path: str | os.PathLike, index: pd.DatetimeIndex, *, clock: str = "prevailing",
                          timezone: str = TIMEZONE, factors: str | os.PathLike | None = None) -> pd.DataFrame:
    """Hourly grid carbon intensity [kg CO2e/kWh] over ``index`` (local standard time, interval-beginning)
    from an ERCOT fuel-mix workbook (.xlsx, .xlsm) or a long CSV (``clock``: the clock of its naive timestamps,
    ``prevailing`` or ``standard``); ``factors``: an emission factor CSV (None: the packaged one). One column
    ``carbon_intensity``; an hour of ``index`` the file does not cover is an error naming the file."""

    path = Path(path)
    if path.suffix.lower() in (".xlsx", ".xlsm"):
        generation, _ = read_fuel_mix_workbook(path, timezone=timezone)
    else:
        generation, _ = read_fuel_mix_csv(path, clock=clock, timezone=timezone)
    generation = select_period(generation, index, file=path)
    return carbon_intensity(generation, read_emission_factors(factors)).to_frame("carbon_intensity")
