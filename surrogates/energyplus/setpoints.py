"""Thermostat set-point offsets of a stock row and the hourly set-point schedules they give.

ResStock's offset periods (``in.cooling_setpoint_offset_period``, ``in.heating_setpoint_offset_period``) name a
night window, 22:00-07:00, a day window, 09:00-17:00 on weekdays only, and the direction in each:
*setup* raises the set point by the offset magnitude, *setback* lowers it. A trailing ``+Nh``/``-Nh``
shifts both windows N hours later/earlier. Cooling periods carry their verbs (``Night Setback``: cooler
nights; ``Day Setup``: warmer weekdays; ``Day Setup and Night Setback``; ``Day and Night Setup``; ``Night
Setup``); heating periods (``Night``, ``Day``, ``Day and Night``) are setbacks.

Repair: EnergyPlus's dual set point refuses a heating set point at or above the cooling one. In every hour
where heating >= cooling, both move to their mean m: heating = m - 0.5 K, cooling = m + 0.5 K (a 1 K dead
band centred where the household asked for).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: the night and day windows of set-point offsets: hours of the day (0 = 00:00-01:00) before shifting
NIGHT_HOURS = (22, 23, 0, 1, 2, 3, 4, 5, 6)
DAY_HOURS = (9, 10, 11, 12, 13, 14, 15, 16)
#: half the dead band the repair leaves between heating and cooling set points [K]
REPAIR_HALF_BAND_K = 0.5
#: the sign of each verb of an offset period
VERB_SIGN = {"setup": 1, "setback": -1}


@dataclass(frozen=True)
class OffsetPeriod:
    """Where an offset applies: the sign (+1 raise, -1 lower, 0 none) in the night window (every day) and in
    the day window (weekdays), and the shift of both windows [h]."""

    night_sign: int = 0
    day_sign: int = 0
    shift_h: int = 0


def parse_offset_period(text: object, kind: str) -> OffsetPeriod:
    """``'Night Setback +3h'``, ``'Day Setup and Night Setback'``, ``'Day and Night -2h'``, ``'None'`` ->
    :class:`OffsetPeriod` for ``kind`` ``"cooling"`` or ``"heating"``. A window without its own verb takes the
    next one (``Day and Night Setup``); a period without any verb is a setback for heating and a setup for
    cooling (the energy-saving direction). ValueError for text naming neither window."""
    s = str(text).strip().lower()
    if s == "none":
        return OffsetPeriod()
    shift = re.search(r"([+-]\d+)\s*h\b", s)
    windows = re.findall(r"\b(day|night)\b(?:\s+(setup|setback))?", s)
    if not windows:
        raise ValueError(f"expected an offset period like 'Night Setback +2h' or 'Day and Night', got {text!r}")
    verbs: dict[str, str] = {}
    pending: list[str] = []
    for window, verb in windows:
        pending.append(window)
        if verb:
            verbs.update({w: verb for w in pending})
            pending = []
    default = "setback" if kind == "heating" else "setup"
    verbs.update({w: default for w in pending})
    return OffsetPeriod(night_sign=VERB_SIGN[verbs["night"]] if "night" in verbs else 0,
                        day_sign=VERB_SIGN[verbs["day"]] if "day" in verbs else 0,
                        shift_h=int(shift.group(1)) if shift else 0)


def shifted(hours: tuple[int, ...], shift_h: int) -> list[int]:
    """Hours of the day (0..23) of a window shifted by ``shift_h``."""
    return sorted((h + shift_h) % 24 for h in hours)


def offset_profile(period: OffsetPeriod, magnitude_k: float, weekend: bool) -> list[float]:
    """Hourly (0..23) offset [K] of one day type: +-``magnitude_k`` in the shifted windows of ``period`` (the
    day window on weekdays only), else 0."""
    out = [0.0] * 24
    windows = [(NIGHT_HOURS, period.night_sign)] + ([] if weekend else [(DAY_HOURS, period.day_sign)])
    for hours, sign in windows:
        for h in shifted(hours, period.shift_h) if sign else []:
            out[h] += sign * magnitude_k
    return out


def setpoint_schedules(cooling_c: float, heating_c: float, offsets_k: tuple[float, float],
                       periods: tuple[OffsetPeriod, OffsetPeriod]) -> tuple[tuple[list[float], list[float]],
                                                                             tuple[list[float], list[float]], int]:
    """Hourly set points [degC] (``(weekday, weekend)`` lists of 24 for cooling, then heating) with the
    offsets (magnitudes [K] and periods, each (cooling, heating)) and the repair rule applied, and the number
    of hours of the day repaired (the larger of weekday and weekend; 0 = the set points were usable)."""
    cooling, heating, repaired = [], [], 0
    for weekend in (False, True):
        cool = [cooling_c + d for d in offset_profile(periods[0], offsets_k[0], weekend)]
        heat = [heating_c + d for d in offset_profile(periods[1], offsets_k[1], weekend)]
        count = 0
        for h in range(24):
            if heat[h] >= cool[h]:
                mean = (heat[h] + cool[h]) / 2.0
                heat[h], cool[h] = mean - REPAIR_HALF_BAND_K, mean + REPAIR_HALF_BAND_K
                count += 1
        cooling.append([round(v, 4) for v in cool])
        heating.append([round(v, 4) for v in heat])
        repaired = max(repaired, count)
    return (cooling[0], cooling[1]), (heating[0], heating[1]), repaired
