"""Who is at home, minute by minute: one seeded day plan per occupant and day.

Each occupant gets a role once (a commuter, away for work or school on most weekdays, or a home-based
person) and then, every day of the calendar year, a wake-up time, a bedtime and zero or one block away
from home, drawn from the day type's distributions (weekday or weekend). The result is a state per
occupant and minute: :data:`AWAY`, :data:`ASLEEP` or :data:`AWAKE` (at home). The numbers are rounded
from the American Time Use Survey summaries (sleep, work and commuting times of US adults); see the
section "Occupant-driven schedules" of docs/energyplus.md. This is a simpler cousin of the Markov-chain
generator ResStock uses since 2021 (day plans per person instead of 15-minute activity transitions).
"""

from __future__ import annotations

import datetime as dt

import numpy as np

MINUTES_PER_DAY = 1440
#: occupant states per minute
AWAY, ASLEEP, AWAKE = 0, 1, 2
#: share of occupants who leave for work or school on weekdays (about the US employment-to-population
#: ratio of adults; children at school keep a similar weekday rhythm)
COMMUTER_SHARE = 0.6
#: wake-up and bedtime [h], (mean, standard deviation) for (weekday, weekend)
WAKE_H = ((6.6, 0.7), (8.0, 1.0))
BED_H = ((22.7, 0.8), (23.2, 0.9))
#: earliest / latest wake-up and bedtime [h] (a bedtime after midnight is folded to 23:59)
WAKE_LIMITS_H = (4.5, 11.0)
BED_LIMITS_H = (20.5, 23.98)
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


def person_day(rng: np.random.Generator, commuter: bool, weekend: bool) -> np.ndarray:
    """States (int8, one per minute of the day) of one occupant on one day."""
    wake = _hour(rng, WAKE_H[int(weekend)], WAKE_LIMITS_H)
    bed = _hour(rng, BED_H[int(weekend)], BED_LIMITS_H)
    states = np.full(MINUTES_PER_DAY, AWAKE, dtype=np.int8)
    states[: int(wake * 60)] = ASLEEP
    states[int(bed * 60):] = ASLEEP
    block = _away_block(rng, commuter, weekend, wake, bed)
    if block is not None:
        states[int(block[0] * 60): int(block[1] * 60)] = AWAY
    return states


def occupant_states(occupants: int, year: int, rng: np.random.Generator) -> np.ndarray:
    """States of every occupant over the calendar year: int8 array (occupants, days, 1440)."""
    weekend = weekend_days(year)
    out = np.empty((occupants, len(weekend), MINUTES_PER_DAY), dtype=np.int8)
    for person in range(occupants):
        commuter = bool(rng.random() < COMMUTER_SHARE)
        for day, is_weekend in enumerate(weekend):
            out[person, day] = person_day(rng, commuter, bool(is_weekend))
    return out
