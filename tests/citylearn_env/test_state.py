"""The end uses' slots, read by name (state.END_USE_SLOTS)."""

from __future__ import annotations

import dataclasses

import pytest

from citylearn_env.state import END_USE_SLOTS, END_USES


def test_end_use_slots_are_named_and_frozen():
    assert tuple(END_USE_SLOTS) == END_USES
    dhw = END_USE_SLOTS["dhw"]
    assert (dhw.device, dhw.storage, dhw.demand, dhw.action) == ("dhw_device", "dhw_storage", "dhw_demand",
                                                                 "dhw_storage")
    assert END_USE_SLOTS["heating"].device == "heating_device"
    with pytest.raises(dataclasses.FrozenInstanceError):
        dhw.device = "x"  # type: ignore[misc]
    with pytest.raises(TypeError):
        END_USE_SLOTS["cooling"] = dhw  # type: ignore[index]
    with pytest.raises(TypeError):
        dhw[0]  # type: ignore[index]  # no position: read by name
