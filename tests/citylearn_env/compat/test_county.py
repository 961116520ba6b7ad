"""Upstream's county neighbourhoods run offline (issue 49, item 5): PV autosized from the EPW with pvlib's PVWatts
models (citylearn_env/pvwatts.py) and CityLearn 2.2+'s zero-net-energy rule; the 47 Vermont houses of v2.4.2 load
and run."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from citylearn_env import pvwatts
from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.version import VERSION_VAR
from citylearn_env.errors import SchemaError
from tests.citylearn_env.compat.conftest import UPSTREAM
from tests.conftest import need_shared

pytest.importorskip("pvlib", reason="pvlib (the pipeline extra) is not installed")

VERMONT = "vt_chittenden_county_neighborhood"
EPW = UPSTREAM / "v2.4.2" / VERMONT / "weather.epw"


def test_pvwatts_at_normal_incidence_matches_a_hand_calculation() -> None:
    # sun at zenith 20 deg due south: normal to the 20 deg, south-facing array; DNI 1000 W/m2, no diffuse
    zenith = np.array([20.0, 120.0])
    ghi = 1000.0 * np.cos(np.radians(zenith)).clip(0)
    got = pvwatts.pvwatts_ac_per_kw(ghi, np.array([1000.0, 0.0]), np.zeros(2), np.full(2, 25.0), np.ones(2),
                                    zenith, np.full(2, 180.0), np.full(2, 1367.0))
    poa = 1000.0 + ghi[0] * 0.2 * (1 - math.cos(math.radians(20.0))) / 2  # beam + ground-reflected [W/m2]
    cell = poa * math.exp(-3.56 - 0.075 * 1.0) + 25.0 + poa / 1000.0 * 3.0  # SAPM, open rack glass/polymer [degC]
    dc = poa * (1 - 0.0047 * (cell - 25.0)) * (1 - 0.1408)  # PVWatts DC less system losses [W/kW]
    zeta = dc / (1000.0 / 1.2)
    ac = dc * 0.96 / 0.9637 * (-0.0162 * zeta - 0.0059 / zeta + 0.9858)  # PVWatts inverter
    assert got[0] == pytest.approx(ac, rel=1e-6)
    assert got[1] == 0.0  # night


def test_the_vermont_epw_yields_a_plausible_year() -> None:
    need_shared(EPW)
    y = pvwatts.epw_yield(EPW)
    assert y.shape == (8760,) and y.min() == 0.0
    assert y.max() <= 1000.0 / 1.2 * 0.96 + 1e-9  # the inverter's AC limit per kW of DC
    assert 1050.0 < y.sum() / 1000.0 < 1400.0  # kWh per kW per year, Burlington VT (PVWatts: about 1,250)
    noon = y.reshape(365, 24)[:, 12]
    assert noon[150:210].mean() > noon[:30].mean()  # summer noons above January's
    np.testing.assert_array_equal(pvwatts.aligned(y, 8759, 2), [y[8759], y[0]])


def test_missing_pvlib_is_one_line(monkeypatch, tmp_path) -> None:
    monkeypatch.setitem(sys.modules, "pvlib", None)
    (tmp_path / "w.epw").write_text("x")
    with pytest.raises(SchemaError, match="needs pvlib") as error:
        pvwatts.epw_yield(tmp_path / "w.epw")
    assert "\n" not in str(error.value)


def test_the_vermont_neighbourhood_loads_with_pvwatts_pv_and_runs(cache, monkeypatch) -> None:
    need_shared(EPW)
    monkeypatch.delenv(VERSION_VAR)  # a name only v2.4.2 holds: read from there, a 2.2+ program
    env = CityLearnEnv(VERMONT, central_agent=True, simulation_end_time_step=23)
    assert len(env.buildings) == 47 and env.mirror.version == "2.5"
    y = pvwatts.epw_yield(EPW)[:24]
    for b in env.buildings[:3]:
        np.testing.assert_allclose(b.energy_simulation.solar_generation, y)  # the PVWatts profile [W/kW]
        assert 1.0 < b.pv.nominal_power <= 60.0
    observations, _ = env.reset()
    n = len(env.action_space[0].low)
    while not env.terminated:
        observations, reward, terminated, truncated, _ = env.step([[0.0] * n])
    generation = -env.buildings[0].solar_generation
    np.testing.assert_allclose(generation[1:], env.buildings[0].pv.nominal_power * y[1:] / 1000.0, rtol=1e-6)
    assert generation.sum() > 0 and np.isfinite(reward[0])
