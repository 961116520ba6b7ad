"""Fixtures shared by the surrogate tests: the Room2R2C FMU built once per session."""

from __future__ import annotations

import pytest

from tests.surrogates.fmu.build import build_room_fmu


@pytest.fixture(scope="session")
def room_fmu(tmp_path_factory):
    return build_room_fmu(tmp_path_factory.mktemp("fmu"))
