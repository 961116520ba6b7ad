"""Power-outage signals: the SAIFI/CAIDI reliability model and validation of a data-set outage column.

The stochastic model draws, for every day of the episode, whether an outage starts that day
(probability SAIFI / 365), a start step within the day and an exponentially distributed duration with mean
CAIDI minutes. ``legacy=True`` reproduces CityLearn 2.1 draw for draw (including its quirks; the environment
passes ``settings.legacy_outage_draws``); ``legacy=False`` is the corrected model. Differences:
docs/environment_dynamics.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from citylearn_env.errors import SchemaError

SECONDS_PER_DAY = 86400.0
DAYS_PER_YEAR = 365.0


def _steps_per_day(seconds_per_time_step: float) -> int:
    spd = SECONDS_PER_DAY / float(seconds_per_time_step)
    if not np.isfinite(spd) or spd < 1 or abs(spd - round(spd)) > 1e-9:
        raise SchemaError(f"a day (86400 s) must hold a whole number of time steps, not {spd!r}",
                          column="seconds_per_time_step")
    return int(round(spd))


def _start_choices(start_time_steps: Sequence[int] | None, spd: int) -> np.ndarray:
    if start_time_steps is None:
        return np.arange(spd)
    choices = np.asarray(start_time_steps, dtype=np.float64)
    if choices.ndim != 1 or choices.size == 0 or np.any(choices != np.round(choices)) \
            or choices.min() < 0 or choices.max() >= spd:
        raise SchemaError(f"start_time_steps must be a non-empty list of integer steps of the day in 0..{spd - 1}",
                          column="power_outage.start_time_steps")
    return choices.astype(np.int64)


def reliability_outage_signal(n_steps: int, *, saifi: float = 1.436, caidi: float = 331.2, seed: int,
                              seconds_per_time_step: float = 3600.0,
                              start_time_steps: Sequence[int] | None = None, legacy: bool = False) -> np.ndarray:
    """Outage signal (1 = outage) of an ``n_steps``-step episode from the reliability indices.

    Parameters
    ----------
    n_steps : number of time steps of the episode.
    saifi : system average interruption frequency index, outages per customer per year.
    caidi : customer average interruption duration index, minutes per outage (mean duration).
    seed : random seed; the same seed gives the same signal.
    seconds_per_time_step : time-step length in s (a day must hold a whole number of steps).
    start_time_steps : allowed start steps within a day (0 = midnight); default: any step.
    legacy : reproduce CityLearn 2.1's ``ReliabilityMetricsPowerOutage`` exactly (legacy ``RandomState``;
        all day draws, then all start draws, then all durations; day 0 never has an outage but its draw
        shifts the start/duration draws of later days; ``int`` truncation of start and end; the episode must
        be a whole number of days).

    Returns
    -------
    int8 array (n_steps,), 1 during an outage.
    """
    n_steps = int(n_steps)
    if n_steps < 0:
        raise SchemaError(f"n_steps must be >= 0, not {n_steps}", column="episode_time_steps")
    if not (saifi >= 0 and caidi >= 0):
        raise SchemaError(f"saifi ({saifi}) and caidi ({caidi}) must be >= 0", column="power_outage")
    if not 0 <= int(seed) < 2**32 or int(seed) != seed:
        raise SchemaError(f"random seed must be an integer in 0..2**32-1, not {seed!r}",
                          column="power_outage.random_seed")
    spd = _steps_per_day(seconds_per_time_step)
    choices = _start_choices(start_time_steps, spd)
    steps_per_minute = 60.0 / float(seconds_per_time_step)
    p_day = saifi / DAYS_PER_YEAR
    if p_day > 1:
        raise SchemaError(f"saifi {saifi} exceeds one outage per day", column="power_outage.saifi")
    signal = np.zeros(n_steps, dtype=np.int8)
    if legacy:
        if n_steps % spd:
            raise SchemaError(f"CityLearn 2.1 needs a whole number of days: {n_steps} steps is not a multiple of "
                              f"{spd}", column="episode_time_steps")
        rng = np.random.RandomState(seed)
        n_days = n_steps // spd
        drawn = rng.binomial(n=1, p=p_day, size=n_days)
        days = (drawn * np.arange(n_days))
        days = days[days != 0]  # day 0 dropped ...
        n_out = int(drawn.sum())  # ... but still counted: draws of day 0 shift onto later days
        starts = rng.choice(choices, size=n_out)
        durations = rng.exponential(scale=caidi, size=n_out) * steps_per_minute
        for day, start, duration in zip(days, starts, durations, strict=False):
            first = day * spd + start
            signal[int(first):int(first + duration)] = 1
        return signal
    rng = np.random.default_rng(seed)
    n_days = -(-n_steps // spd)  # a trailing partial day is eligible too
    for day in np.flatnonzero(rng.random(n_days) < p_day):
        start = int(rng.choice(choices))
        duration = int(np.rint(rng.exponential(scale=caidi) * steps_per_minute)) if caidi > 0 else 0
        first = int(day) * spd + start
        signal[first:min(first + duration, n_steps)] = 1
    return signal


def csv_outage_signal(values: ArrayLike, *, file: object = None, column: str = "power_outage") -> np.ndarray:
    """Validate a data-set outage column: every value must be 0 or 1 (1 = outage); returns int8 (N,)."""
    array = np.asarray(values, dtype=np.float64).reshape(-1)
    bad = ~np.isin(array, (0.0, 1.0))
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise SchemaError(f"outage values must be 0 or 1, found {array[row]!r}", file=file, column=column, row=row)
    return array.astype(np.int8)
