"""Carbon intensity from generation by fuel, against hand-computed weighted means of the SRREN medians."""

from __future__ import annotations

import pandas as pd
import pytest

from pipeline.carbon import carbon_intensity, read_emission_factors
from pipeline.errors import InputError


def test_factor_table_holds_srren_medians_with_sources():
    factors = read_emission_factors()
    # IPCC SRREN Annex II Table A.II.4 medians [g CO2e/kWh]
    srren = {"Coal": 1001, "Gas": 469, "Gas-CC": 469, "Nuclear": 16, "Wind": 12, "Solar": 46, "Hydro": 4,
             "Biomass": 18}
    for fuel, value in srren.items():
        assert factors.at[fuel, "g_co2e_per_kwh"] == value
    assert factors["note"].str.len().min() > 10  # every row says where its number comes from
    assert pd.isna(factors.at["Power Storage", "g_co2e_per_kwh"])


def test_weighted_mean_by_hand():
    generation = pd.DataFrame({"Coal": [1.0, 0.0], "Wind": [1.0, 3.0], "Nuclear": [2.0, 1.0]},
                              index=pd.date_range("2018-06-01", periods=2, freq="h"))
    ci = carbon_intensity(generation)
    assert ci.iloc[0] == pytest.approx((1001 + 12 + 2 * 16) / 4 / 1000)
    assert ci.iloc[1] == pytest.approx((3 * 12 + 16) / 4 / 1000)


def test_storage_excluded_and_negative_other_counts_as_zero():
    generation = pd.DataFrame({"Coal": [2.0], "Other": [-0.5], "Power Storage": [5.0]})
    assert carbon_intensity(generation).iloc[0] == pytest.approx(1.001)


def test_unknown_fuel_and_bad_factor_file(tmp_path):
    with pytest.raises(InputError, match="no emission factor for fuel 'Lignite'"):
        carbon_intensity(pd.DataFrame({"Lignite": [1.0]}))
    path = tmp_path / "f.csv"
    path.write_text("fuel,g_co2e_per_kwh,srren_technology,negative_allowed,note\nCoal,lots,Coal,false,x\n")
    with pytest.raises(InputError, match=r"column/key 'g_co2e_per_kwh', row 2"):
        read_emission_factors(path)
