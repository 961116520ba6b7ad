"""A stock row's own annual end uses -> the daily totals its occupant-driven schedules keep.

ResStock simulates every dwelling it publishes; its results carry each end use's annual energy. Where a row
has them, the house's schedules take their daily totals from the row rather than from floor-area densities:
plug loads, appliances, lighting and hot water then add up to what the stock says this dwelling uses.

The mapping (one table, :data:`END_USE_GROUPS`): each group of :class:`EndUses` sums the row's electricity
of the listed ResStock end uses (absent end uses count 0):

==================== ============================================================= =============================
group                ResStock end uses (electricity)                               the house model
==================== ============================================================= =============================
``plug``             plug_loads, refrigerator, freezer, clothes_washer,            a full zone gain
                     dishwasher, ceiling_fan
``cooking``          range_oven                                                    vented (hood)
``dryer``            clothes_dryer                                                 vented (dryer duct)
``lighting``         lighting_interior                                             zone lighting
``outdoor_lighting`` lighting_garage, lighting_exterior                            electricity, no zone gain
``exterior``         pool_pump, pool_heater, hot_tub_pump, hot_tub_heater,         electricity, no zone gain
                     permanent_spa_pump, permanent_spa_heater, well_pump
==================== ============================================================= =============================

The garage is not part of the conditioned zone (the house model has none), so its lights heat it no more than
the porch lights do.

``dhw_delivered`` is the hot-water load the water heater delivers (``load_hot_water_delivered``), thermal.

Column layouts read (units converted here, at the edge): the buildstockbatch results
(``report_simulation_output.end_use_electricity_<x>_m_btu``, ``report_simulation_output.load_hot_water_
delivered_m_btu``, MBtu) and the published EULP annual results (``out.electricity.<x>.energy_consumption``
with an optional ``.kwh`` suffix, kWh; ``out.load.hot_water.energy_delivered.kbtu``, kBtu). A row without
``plug_loads`` in either layout has no end uses (None: the floor-area densities apply).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from citylearn_env.errors import InputError

#: kWh per MBtu and per kBtu
KWH_PER_MBTU = 293.07107
KWH_PER_KBTU = 0.29307107
DAYS_PER_YEAR = 365.0

#: column prefixes of the annual results this module reads (readers that trim a stock row keep them)
RESULT_PREFIXES = ("report_simulation_output.end_use_electricity_", "report_simulation_output.load_hot_water_",
                   "out.electricity.", "out.load.hot_water.")
#: our group -> the ResStock electricity end uses it sums
END_USE_GROUPS: dict[str, tuple[str, ...]] = {
    "plug": ("plug_loads", "refrigerator", "freezer", "clothes_washer", "dishwasher", "ceiling_fan"),
    "cooking": ("range_oven",),
    "dryer": ("clothes_dryer",),
    "lighting": ("lighting_interior",),
    "outdoor_lighting": ("lighting_garage", "lighting_exterior"),
    "exterior": ("pool_pump", "pool_heater", "hot_tub_pump", "hot_tub_heater", "permanent_spa_pump",
                 "permanent_spa_heater", "well_pump"),
}


@dataclass(frozen=True)
class EndUses:
    """A dwelling's mean daily end uses [kWh/day]: electricity of each group of :data:`END_USE_GROUPS` and
    the delivered hot-water heat ``dhw_delivered`` (None when the row does not say)."""

    plug: float
    cooking: float
    dryer: float
    lighting: float
    exterior: float
    outdoor_lighting: float = 0.0
    dhw_delivered: float | None = None


def _electricity_columns(end_use: str) -> tuple[tuple[str, float], ...]:
    """(column, kWh per unit) of one electricity end use in each layout read."""
    return ((f"report_simulation_output.end_use_electricity_{end_use}_m_btu", KWH_PER_MBTU),
            (f"out.electricity.{end_use}.energy_consumption.kwh", 1.0),
            (f"out.electricity.{end_use}.energy_consumption", 1.0))


#: (column, kWh per unit) of the delivered hot-water load in each layout read
DHW_COLUMNS = (("report_simulation_output.load_hot_water_delivered_m_btu", KWH_PER_MBTU),
               ("out.load.hot_water.energy_delivered.kbtu", KWH_PER_KBTU))


def _annual_kwh(row: Mapping[str, object], columns, *, source: object, bldg_id: object) -> float | None:
    """The first present column's value in kWh per year; None when no column is present; an
    :class:`InputError` naming the column for a value that is not a number >= 0."""
    for column, factor in columns:
        value = row.get(column)
        if value is None or (isinstance(value, float) and math.isnan(value)) or str(value).strip() == "":
            continue
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = float("nan")
        if not number >= 0.0:
            raise InputError(f"annual end use must be a number >= 0, got {value!r}", file=source, column=column,
                             row=f"bldg_id={bldg_id}")
        return number * factor
    return None


def parse_end_uses(row: Mapping[str, object], *, source: object = "metadata") -> EndUses | None:
    """The row's :class:`EndUses` [kWh/day] (annual / 365), or None when the row carries no annual results
    (no ``plug_loads`` end use in either layout)."""
    bldg_id = row.get("bldg_id", row.get("building_id"))

    def annual(end_use: str) -> float | None:
        return _annual_kwh(row, _electricity_columns(end_use), source=source, bldg_id=bldg_id)

    if annual("plug_loads") is None:
        return None
    groups = {group: sum(annual(u) or 0.0 for u in uses) / DAYS_PER_YEAR for group, uses in END_USE_GROUPS.items()}
    dhw = _annual_kwh(row, DHW_COLUMNS, source=source, bldg_id=bldg_id)
    return EndUses(**groups, dhw_delivered=None if dhw is None else dhw / DAYS_PER_YEAR)
