"""Hourly grid carbon intensity from generation by fuel and life-cycle emission factors.

Factors live in ``pipeline/data/emission_factors.csv`` (g CO2e per kWh generated, IPCC SRREN Annex II,
Table A.II.4 medians, with the source of each row), read by
:func:`pipeline.ingest.fuel_mix.read_emission_factors`. A fuel with an empty factor is excluded from both the
emissions and the generation it is averaged over (storage: its charging is already in the load).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pipeline.errors import InputError
from pipeline.ingest.fuel_mix import read_emission_factors


def carbon_intensity(generation: pd.DataFrame, factors: pd.DataFrame | None = None) -> pd.Series:
    """Generation-weighted life-cycle carbon intensity.

    Parameters
    ----------
    generation
        Energy generated per fuel [MWh] per time step (one column per fuel, any index).
    factors
        Table from :func:`read_emission_factors` (default: the packaged one).

    Returns
    -------
    Series ``carbon_intensity`` [kg CO2e/kWh] = sum_f E_f * EF_f / sum_f E_f / 1000 with EF in g/kWh, over
    fuels with a factor; negative (net consumption) values count as zero generation.
    """
    factors = read_emission_factors() if factors is None else factors
    unknown = [fuel for fuel in generation.columns if fuel not in factors.index]
    if unknown:
        raise InputError(f"no emission factor for fuel {unknown[0]!r}; known: {', '.join(factors.index)}",
                         column=unknown[0])
    counted = [fuel for fuel in generation.columns if np.isfinite(factors.at[fuel, "g_co2e_per_kwh"])]
    energy = generation[counted].clip(lower=0.0)
    weights = factors.loc[counted, "g_co2e_per_kwh"].to_numpy(dtype=float)
    total = energy.sum(axis=1)
    if (total <= 0).any():
        raise InputError(f"no counted generation at {total.index[int(np.argmax(total.to_numpy() <= 0))]}",
                         column="generation")
    values = energy.to_numpy(dtype=float) @ weights / total.to_numpy() / 1000.0
    return pd.Series(values, index=generation.index, name="carbon_intensity")
