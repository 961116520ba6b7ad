"""Who is at home, minute by minute: one seeded day plan per occupant and day.

Each occupant gets a role once (a commuter, away for work or school on most weekdays, or a home-based
person) and then, every day of the calendar year, a wake-up time, a bedtime and zero or one block away
from home, drawn from the day type's distributions (weekday or weekend and the role). The result is a
state per occupant and minute of a day plan that runs from 04:00 to 04:00 on the household's clock:
:data:`AWAY`, :data:`ASLEEP` or :data:`AWAKE` (at home); :func:`standard_time_index` moves plan minutes to
the simulation's standard time, by the clock changes of the households' time zone. The numbers are rounded
from the American Time Use Survey summaries (sleep, work and commuting times of US adults); see the
section "Occupant-driven schedules" of docs/energyplus.md. This is a simpler cousin of the Markov-chain
generator ResStock uses since 2021 (day plans per person instead of 15-minute activity transitions).
"""

from __future__ import annotations

import datetime as dt
from functools import lru_cache
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import numpy as np

MINUTES_PER_DAY = 1440
#: occupant states per minute
AWAY, ASLEEP, AWAKE = 0, 1, 2
#: share of occupants who leave for work or school on weekdays (about the US employment-to-population
#: ratio of adults; children at school keep a similar weekday rhythm)
COMMUTER_SHARE = 0.6
#: a day plan runs from this clock hour to the same hour the next morning, so a bedtime after midnight
#: stays in its evening's plan [h]
DAY_START_H = 4.0
#: wake-up time [h], (mean, standard deviation), (weekday, weekend), for (home-based, commuter) occupants,
#: and bedtime [h] for every occupant (weekday, weekend); hours past 24 are after midnight
WAKE_H = (((7.4, 1.0), (8.2, 1.1)), ((6.3, 0.6), (7.9, 1.0)))
BED_H = ((22.9, 1.0), (23.4, 1.1))
#: earliest / latest wake-up and bedtime [h]
WAKE_LIMITS_H = (4.5, 11.0)
BED_LIMITS_H = (20.5, 27.5)
#: a commuter leaves this long after waking [h] and is away this long (work or school plus travel) [h]
LEAVE_AFTER_WAKE_H = (1.0, 0.3)
AWAY_H = (9.0, 1.0)
#: probability that a commuter also works on a weekend day
WEEKEND_WORK_PROBABILITY = 0.25
#: on days without work: probability of one outing (errands, visits), its start window [h] and length [h]
OUTING_PROBABILITY = (0.45, 0.6)
OUTING_START_H = (9.0, 19.0)
OUTING_LENGTH_H = (1.0, 3.5)


def weekend_days(year: int) -> np.ndarray:
    """Bool per day of ``year`` (Jan 1 first): True on Saturdays and Sundays."""
    days = (dt.date(year + 1, 1, 1) - dt.date(year, 1, 1)).days
    first = dt.date(year, 1, 1).weekday()  # Monday = 0
    return (first + np.arange(days)) % 7 >= 5


@lru_cache(maxsize=8)
def daylight_saving_minutes(year: int, zone: str | None) -> np.ndarray:
    """Bool per minute of calendar ``year`` in the zone's standard time (Jan 1 00:00 first): True while the
    clocks of IANA time zone ``zone`` show daylight time, by the tz database's rules for that year (resolved
    to the half hour); all False for ``None`` or a zone that keeps standard time. Raises ValueError for an
    unknown zone. Cached (every model build of a house asks again) and read-only."""
    days = len(weekend_days(year))
    out = np.zeros(days * MINUTES_PER_DAY, dtype=bool)
    if zone is None:
        out.setflags(write=False)
        return out
    try:
        tz = ZoneInfo(zone)
    except (ZoneInfoNotFoundError, ValueError):
        raise ValueError(f"unknown time zone {zone!r} (an IANA name like 'America/Chicago')") from None
    new_year = dt.datetime(year, 1, 1, tzinfo=tz)
    standard = new_year.utcoffset() - new_year.dst()
    start_utc = dt.datetime(year, 1, 1, tzinfo=dt.UTC) - standard
    for half_hour in range(days * 48):
        if (start_utc + dt.timedelta(minutes=30 * half_hour)).astimezone(tz).dst():
            out[half_hour * 30:(half_hour + 1) * 30] = True
    out.setflags(write=False)
    return out


def daylight_days(year: int, zone: str | None) -> np.ndarray:
    """Bool per day of calendar ``year``: True where the clocks of ``zone`` show daylight time at noon
    (:func:`daylight_saving_minutes`)."""
    return daylight_saving_minutes(year, zone).reshape(-1, MINUTES_PER_DAY)[:, 12 * 60]


def standard_time_index(year: int, zone: str | None) -> np.ndarray:
    """Where each minute of calendar ``year`` in local standard time (the simulation's clock) lies in the
    year's day plans laid end to end (day d's plan starts at :data:`DAY_START_H` of day d on the household's
    clock): ``series[..., index]`` turns per-minute plan series into standard time. While the clocks of
    ``zone`` show daylight time (:func:`daylight_saving_minutes`) the household's habits happen an hour
    earlier in standard time (the clock's skipped hour is dropped, its repeated hour shown twice). The
    year's first hours before :data:`DAY_START_H` take the last plan's end."""
    minutes = len(weekend_days(year)) * MINUTES_PER_DAY
    index = np.arange(minutes) - int(DAY_START_H * 60) + 60 * daylight_saving_minutes(year, zone)
    return index % minutes


def _hour(rng: np.random.Generator, mean_sd: tuple[float, float], limits: tuple[float, float]) -> float:
    """A time of day [h] from a normal distribution, clipped to ``limits``."""
    return float(np.clip(rng.normal(*mean_sd), *limits))


def _away_block(rng: np.random.Generator, commuter: bool, weekend: bool, wake_h: float,
                bed_h: float) -> tuple[float, float] | None:
    """(leave, return) [h] of the day's time away from home, or None for a day at home."""
    works = commuter and (not weekend or rng.random() < WEEKEND_WORK_PROBABILITY)
    if works:
        leave = wake_h + max(rng.normal(*LEAVE_AFTER_WAKE_H), 0.25)
        length = max(rng.normal(*AWAY_H), 3.0)
    elif rng.random() < OUTING_PROBABILITY[int(weekend)]:
        leave = rng.uniform(*OUTING_START_H)
        length = rng.uniform(*OUTING_LENGTH_H)
    else:
        return None
    back = min(leave + length, bed_h - 0.25)
    return (leave, back) if back > leave else None


def plan_minute(hour: float) -> int:
    """The minute of a day plan (0 = :data:`DAY_START_H`) of a clock time [h, past 24 after midnight]."""
    return int((hour - DAY_START_H) * 60)


def person_day(rng: np.random.Generator, commuter: bool, weekend: bool) -> np.ndarray:
    """States (int8, one per minute of the day plan, :func:`plan_minute`) of one occupant on one day."""
    wake = _hour(rng, WAKE_H[int(commuter)][int(weekend)], WAKE_LIMITS_H)
    bed = _hour(rng, BED_H[int(weekend)], BED_LIMITS_H)
    states = np.full(MINUTES_PER_DAY, AWAKE, dtype=np.int8)
    states[: plan_minute(wake)] = ASLEEP
    states[plan_minute(bed):] = ASLEEP
    block = _away_block(rng, commuter, weekend, wake, bed)
    if block is not None:
        states[plan_minute(block[0]): plan_minute(block[1])] = AWAY
    return states


def occupant_states(occupants: int, year: int, rng: np.random.Generator) -> np.ndarray:
    """States of every occupant in the day plans of the calendar year: int8 array (occupants, days, 1440),
    minute 0 of each day at :data:`DAY_START_H` (:func:`standard_time_index` maps them to clock minutes)."""
    weekend = weekend_days(year)
    out = np.empty((occupants, len(weekend), MINUTES_PER_DAY), dtype=np.int8)
    for person in range(occupants):
        commuter = bool(rng.random() < COMMUTER_SHARE)
        for day, is_weekend in enumerate(weekend):
            out[person, day] = person_day(rng, commuter, bool(is_weekend))
    return out
