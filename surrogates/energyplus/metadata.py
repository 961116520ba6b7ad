"""EULP (ResStock) metadata fields -> the parameters of the project's parametric house model.

Every ``parse_*`` function is pure and maps one ResStock string encoding to a number in SI units. Fields
that are absent (or ``None``/NaN) fall back to the documented defaults in :data:`VINTAGE_DEFAULTS` and
:class:`HouseParameters`; fields that are present but unreadable raise :class:`InputError` naming the column
and the building. Rows of the buildstockbatch layout (``building_id``, ``build_existing_model.<x>``) are
first renamed to the published layout (``bldg_id``, ``in.<x>``) by :func:`normalise_characteristics`.

The mapping (one table; units converted here, at the edge; docs/energyplus.md repeats it):

======================================== ============================== ==========================================
characteristic (``in.`` prefix)          parameter                      conversion
======================================== ============================== ==========================================
``sqft`` (else ``floor_area_conditioned`` ``floor_area_m2``             ft2 x 0.09290304; a ``geometry_floor_area``
``_ft_2`` / ``geometry_floor_area`` bin)                                bin -> its mid-point
``geometry_stories``                     ``stories`` (1-4)              leading number
``vintage``                              ``vintage`` (decade)           ``1980s`` -> 1980, ``<1940`` -> 1930
``orientation``                          ``front_azimuth_deg``          8 compass points -> 0, 45, ... 315 deg
``window_areas`` (else window/wall ft2)  ``window_to_wall``             mean of ``F B L R`` percents / 100
``windows``                              ``window_u``, ``window_shgc``  the option's U and SHGC,
                                                                        :data:`RESSTOCK_WINDOWS` (else the
                                                                        glazing class -> :data:`GLAZING`)
``insulation_wall`` / ``_slab``          ``wall_r_si`` / ``slab_r_si``  R (h ft2 F/Btu) x 0.1761102 -> m2 K/W
``insulation_ceiling``, else             ``ceiling_r_si`` (the model's  the attic floor's R; ``None`` (no attic
``insulation_roof`` (``Finished, R-x``)  one roof assembly)             floor) -> the finished roof's R
``infiltration``                         ``ach50``                      ``7 ACH50`` -> 7; natural ACH = ACH50 / 20
``occupants``                            ``occupants``                  leading number (0 allowed: vacant)
``cooling_setpoint`` / ``heating_setpoint`` base set points [degC]      ``76F`` -> (76 - 32) x 5/9
``*_setpoint_has_offset``, ``*_offset_   hourly set-point schedules     offset degF x 5/9 [K], raised (setup) or
magnitude``, ``*_offset_period``         (weekday, weekend)             lowered (setback) in the night 22:00-07:00
                                                                        and weekday 09:00-17:00 windows the period
                                                                        names, shifted by its ``+Nh``/``-Nh``
                                                                        (:mod:`surrogates.energyplus.setpoints`);
                                                                        crossed hours repaired (below)
``lighting``                             ``lighting_w_per_m2``          :data:`LIGHTING_W_PER_M2` by lamp type
``plug_loads``                           ``equipment_w_per_m2``         3.5 W/m2 x the percent / 100
``hot_water_fixtures``                   ``dhw_scale``                  the percent / 100 (scales daily litres)
annual end uses (results columns)        ``end_uses``                   :mod:`surrogates.energyplus.end_uses`
``heating_fuel``, ``hvac_heating_type_   ``heating_system``             :func:`parse_heating_system`
and_fuel`` / ``hvac_heating_efficiency``
======================================== ============================== ==========================================

Set-point repair (:mod:`surrogates.energyplus.setpoints`): where heating >= cooling, both move 0.5 K either
side of their mean; :meth:`HouseParameters.setpoints` reports how many hours were repaired.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TypeVar

from citylearn_env.errors import InputError
from surrogates.energyplus.end_uses import EndUses, parse_end_uses
from surrogates.energyplus.setpoints import OffsetPeriod, parse_offset_period, setpoint_schedules

T = TypeVar("T")
FT2_TO_M2 = 0.09290304
#: 1 h*ft2*F/Btu (an "R-1" in US units) in m2*K/W.
R_IP_TO_SI = 0.1761102

ORIENTATIONS = {
    "north": 0.0, "northeast": 45.0, "east": 90.0, "southeast": 135.0,
    "south": 180.0, "southwest": 225.0, "west": 270.0, "northwest": 315.0,
}

#: Envelope defaults by construction decade when a metadata field is missing (engineering assumptions
#: loosely following US code history): wall cavity R, ceiling R, ACH50, glazing key of GLAZING.
VINTAGE_DEFAULTS: dict[int, tuple[float, float, float, str]] = {
    1930: (0.0, 7.0, 20.0, "single"),
    1940: (0.0, 7.0, 20.0, "single"),
    1950: (7.0, 13.0, 15.0, "single"),
    1960: (7.0, 13.0, 15.0, "single"),
    1970: (11.0, 19.0, 12.0, "single"),
    1980: (11.0, 30.0, 10.0, "double_clear"),
    1990: (13.0, 30.0, 8.0, "double_clear"),
    2000: (13.0, 38.0, 7.0, "double_low_e"),
    2010: (19.0, 38.0, 5.0, "double_low_e"),
}

#: Simple-glazing (U-factor W/m2K, SHGC) per glazing key.
GLAZING: dict[str, tuple[float, float]] = {
    "single": (5.8, 0.76),
    "double_clear": (3.0, 0.65),
    "double_low_e": (1.9, 0.40),
    "triple": (1.4, 0.33),
}

#: 1 Btu/(h*ft2*F) (a U-factor in US units) in W/(m2*K).
U_IP_TO_SI = 5.678263
#: The ResStock ``Windows`` options and the whole-window U-factor [Btu/(h ft2 F)] and SHGC each one defines
#: (ResStock's options lookup); :func:`parse_window_properties` converts U to SI.
RESSTOCK_WINDOWS: dict[str, tuple[float, float]] = {
    "single, clear, metal": (1.16, 0.76),
    "single, clear, non-metal": (0.84, 0.63),
    "single, clear, metal, exterior clear storm": (0.67, 0.56),
    "single, clear, non-metal, exterior clear storm": (0.47, 0.54),
    "double, clear, metal, air": (0.76, 0.67),
    "double, clear, non-metal, air": (0.49, 0.56),
    "double, clear, metal, air, exterior clear storm": (0.55, 0.51),
    "double, clear, non-metal, air, exterior clear storm": (0.34, 0.49),
    "double, low-e, non-metal, air, m-gain": (0.38, 0.44),
    "triple, low-e, non-metal, air, l-gain": (0.29, 0.26),
}

#: ACH50 -> natural air changes per hour (the common "divide by 20" rule of thumb).
ACH50_TO_ACH_NATURAL = 1.0 / 20.0
#: peak lighting power density [W/m2] by lamp type (engineering assumption: the same light output, lamp
#: efficacies of about 90 (LED), 60 (CFL) and 15 (incandescent) lm/W)
LIGHTING_W_PER_M2 = {"led": 1.0, "cfl": 1.5, "incandescent": 6.0}
#: heating systems: what the house's space heating is, as far as the schema's devices go
HEATING_SYSTEMS = ("heat_pump", "electric_resistance", "fuel", "none")


@dataclass(frozen=True)
class HouseParameters:
    """Everything the house model needs, in SI units.

    ``floor_area_m2`` is conditioned floor area over all stories; ``front_azimuth_deg`` is the compass
    direction the front (long) facade faces (180 = south); R values are the nominal insulation
    resistances (m2*K/W) added to the bare assembly.
    """

    bldg_id: int
    floor_area_m2: float
    stories: int = 1
    vintage: int = 1990
    front_azimuth_deg: float = 180.0
    aspect_ratio: float = 1.5
    story_height_m: float = 2.44
    window_to_wall: float = 0.15
    window_u: float = 3.0
    window_shgc: float = 0.65
    wall_r_si: float = 13 * R_IP_TO_SI
    ceiling_r_si: float = 30 * R_IP_TO_SI
    slab_r_si: float = 0.0
    ach50: float = 8.0
    occupants: float = 3.0
    cooling_setpoint_c: float = 24.0
    heating_setpoint_c: float = 20.0
    lighting_w_per_m2: float = 2.0
    equipment_w_per_m2: float = 3.5
    dhw_litres_per_person_day: float = 45.0
    dhw_base_litres_day: float = 30.0
    dhw_scale: float = 1.0
    #: set-point offsets (cooling, heating): magnitudes [K] and where they apply
    #: (:mod:`surrogates.energyplus.setpoints`)
    offsets_k: tuple[float, float] = (0.0, 0.0)
    offset_periods: tuple[OffsetPeriod, OffsetPeriod] = (OffsetPeriod(), OffsetPeriod())
    #: the stock's heating fuel (``in.heating_fuel``) and system (one of :data:`HEATING_SYSTEMS`)
    heating_fuel: str = "Electricity"
    heating_system: str = "heat_pump"
    #: the row's own annual end uses [kWh/day] (:mod:`surrogates.energyplus.end_uses`); None: the schedules'
    #: daily totals come from the floor-area densities above
    end_uses: EndUses | None = None

    @property
    def ach_natural(self) -> float:
        """Natural infiltration in air changes per hour."""
        return self.ach50 * ACH50_TO_ACH_NATURAL

    def setpoints(self) -> tuple[tuple[list[float], list[float]], tuple[list[float], list[float]], int]:
        """The house's hourly set points [degC], ``(weekday, weekend)`` for cooling then heating, with its
        offsets and the repair rule applied, and the hours of the day repaired
        (:func:`surrogates.energyplus.setpoints.setpoint_schedules`)."""
        return setpoint_schedules(self.cooling_setpoint_c, self.heating_setpoint_c, self.offsets_k,
                                  self.offset_periods)


def _missing(value: object) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value)) or str(value).strip() == ""


def _number(pattern: str, text: object, expected: str, *, whole: bool = False) -> float:
    """The number in group 1 of ``pattern`` matched in ``text`` (the whole text if ``whole``, else the first
    occurrence); ValueError "``expected``, got ..." otherwise."""
    match = (re.fullmatch if whole else re.search)(pattern, str(text), re.IGNORECASE)
    if not match:
        raise ValueError(f"{expected}, got {text!r}")
    return float(match.group(1))


def parse_r_value(text: str) -> float:
    """Nominal insulation R value in US units (h*ft2*F/Btu) from strings like ``R-30``,
    ``Wood Stud, R-11``, ``2ft R10 Under, Horizontal``; ``None``/``Uninsulated`` -> 0."""
    s = str(text).strip()
    match = re.search(r"R-?(\d+(?:\.\d+)?)", s)
    if match:
        return float(match.group(1))
    if re.search(r"\b(none|uninsulated)\b", s, re.IGNORECASE):
        return 0.0
    raise ValueError(f"no R value in {text!r} (expected e.g. 'R-30' or 'Uninsulated')")


def parse_ach50(text: str) -> float:
    """Air changes per hour at 50 Pa from ``'7 ACH50'`` (or a bare number)."""
    return _number(r"\s*(\d+(?:\.\d+)?)\s*(ACH50)?\s*", text, "expected e.g. '7 ACH50'", whole=True)


def parse_vintage(text: str) -> int:
    """Construction decade from ``'1980s'`` or ``'<1940'`` (-> 1930)."""
    s = str(text).strip()
    if match := re.fullmatch(r"<\s*(\d{4})", s):
        return int(match.group(1)) - 10
    if match := re.fullmatch(r"(\d{4})s?", s):
        return int(match.group(1)) // 10 * 10
    raise ValueError(f"expected e.g. '1980s' or '<1940', got {text!r}")


def parse_orientation(text: str) -> float:
    """Compass azimuth (degrees clockwise from north) of ``'North'`` ... ``'Northwest'``."""
    key = str(text).strip().lower().replace(" ", "").replace("-", "")
    if key not in ORIENTATIONS:
        raise ValueError(f"expected one of {sorted(ORIENTATIONS)}, got {text!r}")
    return ORIENTATIONS[key]


#: plausible thermostat set points [degC]; a value outside is a unit mistake (bare numbers are degF)
SETPOINT_RANGE_C = (0.0, 40.0)


def parse_setpoint(text: object) -> float:
    """ResStock/EULP set point -> degC. The one parser for ``in.cooling_setpoint`` / ``in.heating_setpoint``.

    Accepted spellings: ``"76F"`` (what ResStock writes; also ``"76 F"``, ``"76°F"``, ``"76.5F"``),
    ``"24C"`` (explicit Celsius), and bare numbers ``76``, ``"76"``, ``"76.0"``, which are **degF** as in the
    ResStock set-point columns. Offsets live in their own columns (``*_setpoint_offset_magnitude``) and are
    not part of this value. Raises ValueError for anything else and for a result outside
    :data:`SETPOINT_RANGE_C` (e.g. a Celsius number written without its unit).
    """
    if isinstance(text, bool):
        raise ValueError(f"expected a set point like '76F', got {text!r}")
    if isinstance(text, (int, float)):
        value, unit = float(text), "F"
    else:
        match = re.fullmatch(r"\s*(-?\d+(?:\.\d+)?)\s*(?:°|deg)?\s*([FC]?)\s*", str(text), re.IGNORECASE)
        if not match:
            raise ValueError(f"expected a set point like '76F', got {text!r}")
        value, unit = float(match.group(1)), (match.group(2).upper() or "F")
    celsius = (value - 32.0) * 5.0 / 9.0 if unit == "F" else value
    low, high = SETPOINT_RANGE_C
    if not (math.isfinite(celsius) and low <= celsius <= high):
        raise ValueError(f"set point {text!r} is {celsius:.1f} degC, outside {low:g}..{high:g} degC "
                         "(bare numbers are degF; write e.g. '24C' for Celsius)")
    return celsius


def parse_leading_number(text: object) -> float:
    """First number in ``'3'``, ``'10+'``, ``'1500-1999'`` style strings."""
    return _number(r"(\d+(?:\.\d+)?)", text, "expected a number")


def parse_floor_area_bin(text: str) -> float:
    """Mid-point (ft2) of a ``in.geometry_floor_area`` bin like ``'1500-1999'``; ``'4000+'`` -> 4500."""
    s = str(text).strip()
    if match := re.fullmatch(r"(\d+)\s*-\s*(\d+)", s):
        return (float(match.group(1)) + float(match.group(2)) + 1.0) / 2.0
    if match := re.fullmatch(r"(\d+)\+", s):
        return float(match.group(1)) + 500.0
    if match := re.fullmatch(r"0\s*-\s*(\d+)|<\s*(\d+)", s):
        return float(match.group(1) or match.group(2)) / 2.0
    raise ValueError(f"expected a bin like '1500-1999', got {text!r}")


def parse_glazing(text: str) -> str:
    """Glazing key of :data:`GLAZING` from ``in.windows`` strings like ``'Double, Low-E, Non-metal, Air'``."""
    s = str(text).lower()
    if "triple" in s:
        return "triple"
    if "double" in s:
        return "double_low_e" if "low-e" in s else "double_clear"
    if "single" in s:
        return "single"
    raise ValueError(f"expected 'Single'/'Double'/'Triple' glazing, got {text!r}")


def parse_window_properties(text: object) -> tuple[float, float]:
    """(U-factor [W/(m2 K)], SHGC) of an ``in.windows`` option: the values the ResStock option defines
    (:data:`RESSTOCK_WINDOWS`, U converted from Btu/(h ft2 F)); an option not in that table -> its glazing
    class (:func:`parse_glazing`, :data:`GLAZING`)."""
    key = ", ".join(part.strip() for part in str(text).lower().split(","))
    if key in RESSTOCK_WINDOWS:
        u_ip, shgc = RESSTOCK_WINDOWS[key]
        return u_ip * U_IP_TO_SI, shgc
    return GLAZING[parse_glazing(str(text))]


def parse_ceiling_r(text: object) -> float | None:
    """Attic-floor insulation R (US units) from ``in.insulation_ceiling``; ``None`` -> None: the house has no
    attic floor (a finished roof or cathedral ceiling, whose insulation is ``in.insulation_roof``), which is
    not an uninsulated ceiling."""
    if str(text).strip().lower() == "none":
        return None
    return parse_r_value(str(text))


def parse_roof_r(text: object) -> float | None:
    """Roof-deck insulation R (US units) of a finished roof from ``in.insulation_roof`` (``Finished, R-30``,
    ``Finished, Uninsulated`` -> 0); an ``Unfinished, ...`` roof (over a vented attic: outside the thermal
    envelope) or ``None`` -> None."""
    s = str(text).strip()
    if s.lower() == "none" or s.lower().startswith("unfinished"):
        return None
    return parse_r_value(s)


def parse_window_to_wall(text: str) -> float:
    """Mean facade window-to-wall ratio from ``in.window_areas`` like ``'F15 B15 L15 R15'`` (percent)."""
    values = re.findall(r"[FBLR](\d+(?:\.\d+)?)", str(text))
    if len(values) != 4:
        raise ValueError(f"expected e.g. 'F15 B15 L15 R15', got {text!r}")
    return sum(float(v) for v in values) / 400.0


def normalise_characteristics(row: Mapping[str, object]) -> dict[str, object]:
    """A buildstockbatch results row (``building_id``, ``build_existing_model.<x>``,
    ``upgrade_costs.floor_area_conditioned_ft_2``) -> the published layout (``bldg_id``, ``in.<x>``,
    ``in.sqft``); rows already in the published layout pass through unchanged."""
    out = dict(row)
    if "bldg_id" not in out and "building_id" in out:
        out["bldg_id"] = out.pop("building_id")
    for key in list(out):
        if key.startswith("build_existing_model."):
            out.setdefault("in." + key[len("build_existing_model."):], out[key])
    area = out.get("upgrade_costs.floor_area_conditioned_ft_2", out.get("in.floor_area_conditioned_ft_2"))
    if _missing(out.get("in.sqft")) and not _missing(area):
        out["in.sqft"] = area
    return out


def parse_offset_f(text: object) -> float:
    """Set-point offset magnitude ``'2F'`` (degF difference) -> K."""
    return _number(r"\s*(\d+(?:\.\d+)?)\s*F?\s*", text, "expected e.g. '2F'", whole=True) * 5.0 / 9.0


def parse_heating_system(fuel: object, system: object) -> str:
    """One of :data:`HEATING_SYSTEMS` from ``in.heating_fuel`` and ``in.hvac_heating_type_and_fuel`` (or
    ``in.hvac_heating_efficiency``): electricity with a heat pump (``ASHP``, ``MSHP``, ``Heat Pump``) ->
    ``heat_pump``; other electricity (furnace, baseboard, boiler) -> ``electric_resistance``; any other fuel
    -> ``fuel``; ``None`` -> ``none``."""
    f, k = str(fuel).strip().lower(), str(system).strip().lower()
    if f in ("none", ""):
        return "none"
    if f != "electricity":
        return "fuel"
    if re.search(r"ashp|mshp|gshp|heat pump", k):
        return "heat_pump"
    return "electric_resistance"


@dataclass(frozen=True)
class _Fields:
    """The optional fields of one metadata row, read by ``fields(column, parse)``: ``None`` when the field is
    absent (or ``None``/NaN/empty), else ``parse(value)``; an unreadable value is an :class:`InputError`
    naming ``source``, the column and the building."""

    row: Mapping[str, object]
    source: object
    bldg_id: int

    def __call__(self, column: str, parse: Callable[[object], T]) -> T | None:
        value = self.row.get(column)
        if _missing(value):
            return None
        try:
            return parse(value)
        except (TypeError, ValueError) as error:
            raise self.error(str(error), column) from None

    def error(self, message: str, column: str) -> InputError:
        return InputError(message, file=self.source, column=column, row=f"bldg_id={self.bldg_id}")


def house_parameters_from_metadata(row: Mapping[str, object], *,
                                   source: object = "metadata") -> HouseParameters:
    """Map one EULP metadata row (``bldg_id``, ``in.*``) to :class:`HouseParameters`.

    Required: ``bldg_id`` and either ``in.sqft`` (ft2) or ``in.geometry_floor_area`` (bin). Everything else
    is optional and falls back to the vintage defaults. Raises :class:`InputError` naming ``source``, the
    column and the building id for an unreadable field.
    """
    row = normalise_characteristics(row)
    if _missing(row.get("bldg_id")):
        raise InputError("missing building id (expected column bldg_id or building_id)", file=source,
                         column="bldg_id")
    field = _Fields(row, source, int(row["bldg_id"]))
    sqft = _floor_area_ft2(field)
    vintage = field("in.vintage", parse_vintage) or 1990
    defaults = VINTAGE_DEFAULTS[min(max(vintage, 1930), 2010)]  # wall R, ceiling R, ACH50, glazing
    window_u, window_shgc = field("in.windows", parse_window_properties) or GLAZING[defaults[3]]
    stories = _stories(field)
    wwr = _window_to_wall(field)
    wall_r = field("in.insulation_wall", parse_r_value)
    ceiling_r = _top_r(field)
    slab_r = field("in.insulation_slab", parse_r_value)
    occupants = field("in.occupants", parse_leading_number)
    lamp = field("in.lighting", parse_lighting)
    plug = field("in.plug_loads", parse_percent)
    fixtures = field("in.hot_water_fixtures", parse_percent)
    fuel = row.get("in.heating_fuel")
    cooling_offset, heating_offset = _setpoint_offset(field, "cooling"), _setpoint_offset(field, "heating")
    cooling_sp = field("in.cooling_setpoint", parse_setpoint)
    heating_sp = field("in.heating_setpoint", parse_setpoint)
    azimuth = field("in.orientation", parse_orientation)
    return HouseParameters(
        bldg_id=field.bldg_id,
        floor_area_m2=sqft * FT2_TO_M2,
        stories=stories,
        vintage=vintage,
        front_azimuth_deg=180.0 if azimuth is None else azimuth,
        window_to_wall=min(max(wwr, 0.0), 0.6),
        window_u=window_u,
        window_shgc=window_shgc,
        wall_r_si=(defaults[0] if wall_r is None else wall_r) * R_IP_TO_SI,
        ceiling_r_si=(defaults[1] if ceiling_r is None else ceiling_r) * R_IP_TO_SI,
        slab_r_si=(slab_r or 0.0) * R_IP_TO_SI,
        ach50=field("in.infiltration", parse_ach50) or defaults[2],
        occupants=3.0 if occupants is None else occupants,
        cooling_setpoint_c=24.0 if cooling_sp is None else cooling_sp,
        heating_setpoint_c=20.0 if heating_sp is None else heating_sp,
        lighting_w_per_m2=LIGHTING_W_PER_M2[lamp] if lamp else 2.0,
        equipment_w_per_m2=3.5 * (1.0 if plug is None else plug),
        dhw_scale=1.0 if fixtures is None else fixtures,
        offsets_k=(cooling_offset[0], heating_offset[0]), offset_periods=(cooling_offset[1], heating_offset[1]),
        heating_fuel="Electricity" if _missing(fuel) else str(fuel),
        heating_system=_heating_system(row),
        end_uses=parse_end_uses(row, source=source),
    )


def _floor_area_ft2(field: _Fields) -> float:
    """Conditioned floor area (ft2): ``in.sqft``, else the mid-point of the ``in.geometry_floor_area`` bin;
    required, and more than 100 ft2."""
    sqft = field("in.sqft", float)
    if sqft is None:
        sqft = field("in.geometry_floor_area", parse_floor_area_bin)
    if sqft is None or not sqft > 100:
        raise field.error(f"conditioned floor area missing or < 100 ft2 ({sqft})", "in.sqft")
    return sqft


def _stories(field: _Fields) -> int:
    """Stories above grade, 1 to 4 (default 1)."""
    stories = int(field("in.geometry_stories", parse_leading_number) or 1)
    if not 1 <= stories <= 4:
        raise field.error(f"expected 1 to 4 stories, got {stories}", "in.geometry_stories")
    return stories


def _top_r(field: _Fields) -> float | None:
    """R (US units) of the model's one roof assembly, the insulation between the top story and outdoors:
    the attic floor's (``in.insulation_ceiling``) when the house has one, else the finished roof's
    (``in.insulation_roof``); None when neither says (the vintage default applies)."""
    ceiling = field("in.insulation_ceiling", parse_ceiling_r)
    return ceiling if ceiling is not None else field("in.insulation_roof", parse_roof_r)


def _window_to_wall(field: _Fields) -> float:
    """Window-to-wall ratio: ``in.window_areas``, else window / (window + wall) area, else 0.15."""
    wwr = field("in.window_areas", parse_window_to_wall)
    if wwr is not None:
        return wwr
    window = field("in.window_area_ft_2", float)
    wall = field("in.wall_area_above_grade_exterior_ft_2", float)
    return window / (window + wall) if window and wall else 0.15


def _heating_system(row: Mapping[str, object]) -> str:
    """:func:`parse_heating_system` of the row's heating fuel and system (a heat pump without a fuel)."""
    fuel = row.get("in.heating_fuel")
    if _missing(fuel):
        return "heat_pump"
    system = row.get("in.hvac_heating_type_and_fuel", row.get("in.hvac_heating_efficiency"))
    return parse_heating_system(fuel, "" if _missing(system) else system)


def _setpoint_offset(field: _Fields, kind: str) -> tuple[float, OffsetPeriod]:
    """Set-point offset of ``kind`` (``cooling`` or ``heating``): (magnitude K, :class:`OffsetPeriod`); none
    unless ``in.<kind>_setpoint_has_offset`` is ``Yes``."""
    if str(field.row.get(f"in.{kind}_setpoint_has_offset", "No")).strip().lower() != "yes":
        return 0.0, OffsetPeriod()
    return (field(f"in.{kind}_setpoint_offset_magnitude", parse_offset_f) or 0.0,
            field(f"in.{kind}_setpoint_offset_period", lambda text: parse_offset_period(text, kind))
            or OffsetPeriod())


def parse_lighting(text: object) -> str:
    """Lamp key of :data:`LIGHTING_W_PER_M2` from ``in.lighting`` like ``'100% LED'``."""
    s = str(text).lower()
    for key in ("incandescent", "cfl", "led"):
        if key in s:
            return key
    raise ValueError(f"expected '100% LED', '100% CFL' or '100% Incandescent', got {text!r}")


def parse_percent(text: object) -> float:
    """``'113%'`` or ``'50% Usage'`` -> 1.13 / 0.5."""
    return _number(r"\s*(\d+(?:\.\d+)?)\s*%", text, "expected e.g. '100%'") / 100.0
