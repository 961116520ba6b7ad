"""Fixtures shared by the surrogate tests: the Room2R2C FMU and a surrogate trained on an Austin year."""

from __future__ import annotations

import pytest

from tests.conftest import SHARED, need_shared
from tests.surrogates.fmu.build import VARIABLE_MAP, build_room_fmu, house_loads

AUSTIN = SHARED / "data" / "weather" / "USA_TX_Austin-Camp.Mabry.722544_TMY3.epw"


@pytest.fixture(scope="session")
def room_fmu(tmp_path_factory):
    return build_room_fmu(tmp_path_factory.mktemp("fmu"))


@pytest.fixture(scope="session")
def austin_surrogate(room_fmu):
    """(loads, ILV table, trained surrogate) of the 2R2C zone on the Austin TMY3 year, default training."""
    from surrogates.config import TrainConfig
    from surrogates.sources.fmu import simulate_ilv_fmu
    from surrogates.train import train_surrogate

    need_shared(AUSTIN)
    loads = house_loads(room_fmu, AUSTIN)
    table = simulate_ilv_fmu(room_fmu, loads, VARIABLE_MAP, n_partial=4, seed=0, start_values={"T0": 22.0})
    return loads, table, train_surrogate(table, TrainConfig(progress=False))
