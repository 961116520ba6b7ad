"""Occupant-driven schedules of a house: people at home, hot-water draws, appliance and plug loads, lighting.

Pure and seeded: :func:`generate_schedules` turns the household size, the calendar year and the house's
daily targets (hot-water litres, plug and lighting kWh) into per-timestep series for the whole year
(rows = interval-beginning timesteps from Jan 1 00:00, local standard time). Same inputs -> identical
output; the random stream is seeded with ``(seed, bldg_id, SEED_TAG)``.

Method (docs/energyplus.md, "Occupant-driven schedules", gives the sources):

1. per-minute occupant states (:mod:`surrogates.energyplus.occupancy`): asleep, at home awake, away, in day
   plans on the household's clock (``ScheduleTargets.clock_zone``); every event below is placed in those
   plans, and the finished series are moved to standard time (an hour earlier while the clocks show
   daylight time);
2. hot-water draws as events (showers, baths, sinks, dishwasher fills, clothes-washer fills): counts per day
   from per-person and per-household rates, start times from the occupants' states and time-of-day
   weights, durations and flow rates per kind. A house that uses more or less hot water than these rates
   give (the stock's fixture usage multiplier) draws more or less often: the fixtures' rates (showers,
   baths, sinks) are multiplied by :func:`fixture_rate`, the shower head's flow stays. The month's draws
   are then scaled so the month's mean daily volume equals the target (a residual of a few per cent);
3. appliance cycles as events (cooking, dishwasher, clothes washer and dryer, evening TV) plus a small
   per-awake-person electronics load and an always-on base (refrigerator, standby) that takes up the rest
   of the daily plug target; the year's mean equals the target. With the stock's own end uses
   (:mod:`surrogates.energyplus.end_uses`) the range and the dryer keep their own daily electricity (their
   events' power scaled to it) and outdoor equipment (pool, spa and well pumps) runs as a daytime block;
4. lighting: lit share of the house from the awake occupants at home times a darkness factor from the
   sun's elevation; scaled so the year's mean equals the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from surrogates.energyplus.occupancy import (
    ASLEEP,
    AWAKE,
    AWAY,
    MINUTES_PER_DAY,
    occupant_states,
    plan_minute,
    standard_time_index,
    weekend_days,
)

#: bump when the method changes: part of the simulation cache key (pipeline/builder/houses.py)
SCHEDULE_VERSION = 5
#: the fixtures' draws are at least this share of the daily hot-water target (when the appliances' fills
#: alone would exceed it)
MIN_FIXTURE_SHARE = 0.25
#: third element of the seed sequence (keeps this stream apart from the ILV multipliers' streams)
SEED_TAG = 27
#: metabolic heat per person at home [W]: asleep (about 0.7 met) and awake (light domestic activity)
SLEEP_ACTIVITY_W = 72.0
AWAKE_ACTIVITY_W = 110.0

#: hot-water draw kinds: (mean duration [min], duration standard deviation [min], flow [L/min] of mixed water);
#: showers: 7.8 min at 2.1 gpm (7.9 L/min) on average with a long tail of long showers (Residential End Uses of
#: Water, 2016)
SHOWER = (7.8, 4.5, 7.9)
BATH = (5.0, 1.5, 16.0)
SINK = (0.8, 0.6, 4.0)
DISHWASHER_FILL = (1.0, 0.0, 5.5)
WASHER_FILL = (2.0, 0.0, 8.0)
#: showers and baths per person per day; sink draws per person per day and per household per day
SHOWERS_PER_PERSON = 0.7
BATHS_PER_PERSON = 0.08
SINKS_PER_PERSON, SINKS_PER_HOUSEHOLD = 6.0, 3.0
#: share of showers taken in the morning (within half an hour after waking); the rest before bed
MORNING_SHOWER_SHARE = 0.7
#: dishwasher and laundry cycles per day: (per household, per person); laundry weekday/weekend factors
DISHWASHER_CYCLES = (0.2, 0.12)
LAUNDRY_CYCLES = (0.2, 0.15)
LAUNDRY_DAY_FACTOR = (0.8, 1.5)
#: share of laundry cycles followed by an electric dryer cycle
DRYER_SHARE = 0.85
#: appliance cycles: (length [min], mean electric power [W]); fills at these minutes after a start
DISHWASHER = (100, 650.0)
DISHWASHER_FILL_MIN = (0, 20, 45, 70)
WASHER = (45, 400.0)
WASHER_FILL_MIN = (0, 25)
DRYER = (55, 2800.0)
#: cooking on the range/oven: meal -> (probability per day (weekday, weekend), window [h], length [min]);
#: mean power while cooking [W]
MEALS = {"breakfast": ((0.35, 0.45), (6.0, 10.0), 10), "lunch": ((0.2, 0.45), (11.5, 13.5), 20),
         "dinner": ((0.8, 0.8), (17.0, 19.5), 45)}
RANGE_W = 2000.0
#: evening TV/entertainment: probability per day, start window [h], length range [h], power [W];
#: electronics per awake person at home [W]
TV = (0.85, (18.5, 21.5), (1.5, 4.0), 150.0)
ELECTRONICS_PER_AWAKE_W = 40.0
#: the always-on plug base is at least this share of the plug target
MIN_BASE_SHARE = 0.15
#: lighting: share of the house lit by each awake occupant (lit share = 1 - (1 - s)^awake), night-light
#: share, solar elevation [deg] above which daylight is enough, indoor floor of the darkness factor
LIT_PER_PERSON = 0.45
NIGHT_LIGHT = 0.02
DAYLIGHT_ELEVATION_DEG = 8.0
DAYLIGHT_FLOOR = 0.35
#: hours of the day [h] outdoor equipment (pool, spa, well pumps) runs: one daily block (engineering
#: assumption: a single-speed pool pump's 8-hour daytime run)
EXTERIOR_HOURS = (8.0, 16.0)
#: time-of-day weights of sink draws: (start h, end h, extra weight) around meals and getting ready
SINK_PEAKS = ((6.0, 9.0, 1.5), (11.5, 13.5, 1.0), (17.0, 21.0, 1.5))


@dataclass(frozen=True)
class ScheduleTargets:
    """What the schedules must add up to: household size, daily hot water [L of mixed water at the use
    temperature], daily plug and lighting electricity [kWh], and the site latitude [deg] for daylight."""

    occupants: int
    dhw_litres_per_day: float
    plug_kwh_per_day: float
    lighting_kwh_per_day: float
    latitude_deg: float = 35.0
    #: the range's and the dryer's own daily electricity [kWh/day]; then ``plug_kwh_per_day`` is the rest of
    #: the indoor plug loads. None (both): one plug total that includes them
    cooking_kwh_per_day: float | None = None
    dryer_kwh_per_day: float | None = None
    #: outdoor equipment [kWh/day] (no zone gain), run in :data:`EXTERIOR_HOURS`
    exterior_kwh_per_day: float = 0.0
    #: garage and exterior lighting [kWh/day] (no zone gain), lit as the interior lights are
    outdoor_lighting_kwh_per_day: float = 0.0
    #: IANA time zone of the household's clock (its habits follow the clock; the series are in the zone's
    #: standard time, so they come an hour earlier while the clocks show daylight time,
    #: :func:`surrogates.energyplus.occupancy.standard_time_index`); None: standard time all year
    clock_zone: str | None = None


@dataclass(frozen=True)
class HouseSchedules:
    """Per-timestep series over the calendar year (interval-beginning rows from Jan 1 00:00).

    ``people``: occupants at home; ``activity_w``: metabolic heat per person at home [W]; ``lighting_w`` and
    ``plug_w``: house electricity [W], of which ``cooking_w`` (range/oven), ``dryer_w`` (clothes dryer) and
    ``exterior_w`` (outdoor pumps); ``outdoor_lighting_w``: garage and exterior lighting [W] (not in
    ``lighting_w``, no zone gain);
    ``dhw_m3_s``: mixed hot-water flow [m3/s]; ``events``: counts per event kind over the year.
    """

    timesteps_per_hour: int
    people: np.ndarray
    activity_w: np.ndarray
    lighting_w: np.ndarray
    plug_w: np.ndarray
    cooking_w: np.ndarray
    dryer_w: np.ndarray
    exterior_w: np.ndarray
    outdoor_lighting_w: np.ndarray
    dhw_m3_s: np.ndarray
    events: dict[str, int] = field(default_factory=dict)
    #: the multiplier of the fixtures' event rates (:func:`fixture_rate`) the draws were generated at [-]
    fixture_rate: float = 1.0


def _add(series: np.ndarray, start: int, minutes: float, rate: float) -> None:
    """Add ``rate`` over ``minutes`` (fractional: the last minute gets its share) from minute ``start``."""
    whole = int(minutes)
    series[start:start + whole] += rate
    if minutes > whole and start + whole < len(series):
        series[start + whole] += rate * (minutes - whole)


def _duration(rng: np.random.Generator, mean: float, sd: float) -> float:
    """A draw length [min]: lognormal with ``mean`` and ``sd`` (fixed when ``sd`` is 0), at least 0.1 min."""
    if sd <= 0:
        return mean
    sigma2 = math.log(1.0 + (sd / mean) ** 2)
    return max(float(rng.lognormal(math.log(mean) - sigma2 / 2, math.sqrt(sigma2))), 0.1)


def _pick(rng: np.random.Generator, weights: np.ndarray, size: int = 1) -> np.ndarray:
    """``size`` minutes of the day drawn with ``weights`` (empty when every weight is 0)."""
    total = weights.sum()
    if size <= 0 or total <= 0:
        return np.empty(0, dtype=int)
    return rng.choice(len(weights), size=size, p=weights / total)


def _window(start_h: float, end_h: float) -> np.ndarray:
    """1 in the minutes of the day plan between clock times ``start_h`` and ``end_h`` [h], else 0."""
    out = np.zeros(MINUTES_PER_DAY)
    out[plan_minute(start_h):plan_minute(end_h)] = 1.0
    return out


def _times(rng: np.random.Generator, rate: float) -> int:
    """How many times an event of mean ``rate`` per day happens on one day: floor(``rate``) plus one more with
    probability frac(``rate``) (the count's variance is as small as its mean allows)."""
    whole = math.floor(rate)
    return whole + int(rng.random() < rate - whole)


def _showers_and_baths(rng: np.random.Generator, day: np.ndarray, base: int, flow: np.ndarray,
                       rate: float = 1.0) -> tuple[int, int]:
    """Each occupant's showers (the first in the morning or before bed, a second in the other slot, any
    further one at an awake minute) and baths of one day ``day`` (occupants x minutes), at ``rate`` times the
    per-person rates; adds to ``flow`` [L/min] from minute ``base``; returns (showers, baths)."""
    showers = baths = 0
    for person in day:
        awake = np.flatnonzero(person == AWAKE)
        if awake.size == 0:
            continue
        for _ in range(_times(rng, BATHS_PER_PERSON * rate)):
            start = max(int(awake[-1] - rng.uniform(30, 120)), 0)
            _add(flow, base + start, _duration(rng, *BATH[:2]), BATH[2])
            baths += 1
        morning = rng.random() < MORNING_SHOWER_SHARE
        for n in range(_times(rng, SHOWERS_PER_PERSON * rate)):
            if n >= 2:
                start = int(awake[rng.integers(awake.size)])
            elif morning != bool(n):  # the first in its slot, the second in the other
                start = awake[0] + int(rng.uniform(0, 30))
            else:
                start = awake[-1] - int(rng.uniform(30, 150))
            start = int(np.clip(start, 0, MINUTES_PER_DAY - 1))
            _add(flow, base + start, _duration(rng, *SHOWER[:2]), SHOWER[2])
            showers += 1
    return showers, baths


def expected_draws_litres(occupants: int) -> tuple[float, float]:
    """Expected mixed hot water of one day [L] at the base rates: (fixtures: showers, baths and sinks;
    appliances: dishwasher and clothes-washer fills), counting every occupant as awake at home some time of
    the day."""
    shower_l = SHOWER[0] * SHOWER[2]
    bath_l = BATH[0] * BATH[2]
    sinks = SINKS_PER_HOUSEHOLD + SINKS_PER_PERSON * occupants
    fixtures = occupants * (SHOWERS_PER_PERSON * shower_l + BATHS_PER_PERSON * bath_l) + sinks * SINK[0] * SINK[2]
    week_factor = (5 * LAUNDRY_DAY_FACTOR[0] + 2 * LAUNDRY_DAY_FACTOR[1]) / 7
    appliances = ((DISHWASHER_CYCLES[0] + DISHWASHER_CYCLES[1] * occupants) * len(DISHWASHER_FILL_MIN)
                  * DISHWASHER_FILL[0] * DISHWASHER_FILL[2]
                  + (LAUNDRY_CYCLES[0] + LAUNDRY_CYCLES[1] * occupants) * week_factor * len(WASHER_FILL_MIN)
                  * WASHER_FILL[0] * WASHER_FILL[2])
    return fixtures, appliances


def fixture_rate(occupants: int, litres_per_day: float) -> float:
    """Multiplier of the fixtures' event rates [-] that makes the expected daily draws equal
    ``litres_per_day`` [L of mixed water]: (target - appliances' fills) / fixtures' draws at the base rates
    (:func:`expected_draws_litres`), the fixtures keeping at least :data:`MIN_FIXTURE_SHARE` of the target.
    A stock row's "200% Usage" of hot-water fixtures gives about 2: twice the showers and sink draws, each at
    the fixture's own flow; 1 when the target is 0."""
    fixtures, appliances = expected_draws_litres(max(int(occupants), 0))
    if not litres_per_day > 0 or fixtures <= 0:
        return 1.0
    return max(litres_per_day - appliances, MIN_FIXTURE_SHARE * litres_per_day) / fixtures


def _appliances(rng: np.random.Generator, awake_home: np.ndarray, occupants: int, weekend: bool, base: int,
                flow: np.ndarray, power: dict[str, np.ndarray], sink_rate: float = 1.0) -> dict[str, int]:
    """One day's sinks (at ``sink_rate`` times the base rates), dishwasher, laundry (washer + dryer), cooking
    and TV events; adds hot water [L/min] to ``flow`` and electricity [W] to ``power["cooking"]``,
    ``power["dryer"]`` or ``power["other"]`` from minute ``base``; returns the counts."""
    plug = power["other"]
    someone = (awake_home > 0).astype(float)
    counts = {}
    sink_weight = (awake_home + 0.05) * (1.0 + sum(w * _window(a, b) for a, b, w in SINK_PEAKS))
    starts = _pick(rng, sink_weight, rng.poisson(sink_rate * (SINKS_PER_HOUSEHOLD + SINKS_PER_PERSON * occupants)))
    for start in starts:
        _add(flow, base + start, _duration(rng, *SINK[:2]), SINK[2])
    counts["sinks"] = len(starts)
    rate = DISHWASHER_CYCLES[0] + DISHWASHER_CYCLES[1] * occupants
    starts = _pick(rng, someone * (1.0 + 3.0 * _window(19.0, 23.0)), rng.poisson(rate))
    for start in starts:
        _add(plug, base + start, DISHWASHER[0], DISHWASHER[1])
        for offset in DISHWASHER_FILL_MIN:
            _add(flow, base + start + offset, DISHWASHER_FILL[0], DISHWASHER_FILL[2])
    counts["dishwasher"] = len(starts)
    rate = (LAUNDRY_CYCLES[0] + LAUNDRY_CYCLES[1] * occupants) * LAUNDRY_DAY_FACTOR[int(weekend)]
    starts = _pick(rng, someone * _window(8.0, 20.0), rng.poisson(rate))
    counts["dryer"] = 0
    for start in starts:
        _add(plug, base + start, WASHER[0], WASHER[1])
        for offset in WASHER_FILL_MIN:
            _add(flow, base + start + offset, WASHER_FILL[0], WASHER_FILL[2])
        if rng.random() < DRYER_SHARE:
            _add(power["dryer"], base + start + WASHER[0] + int(rng.uniform(0, 30)), DRYER[0], DRYER[1])
            counts["dryer"] += 1
    counts["laundry"] = len(starts)
    counts["meals"] = 0
    for probability, (a, b), minutes in MEALS.values():
        weights = someone * _window(a, b)
        if weights.any() and rng.random() < probability[int(weekend)]:
            _add(power["cooking"], base + int(_pick(rng, weights)[0]), minutes * rng.uniform(0.6, 1.4), RANGE_W)
            counts["meals"] += 1
    probability, (a, b), (low, high), watts = TV
    weights = someone * _window(a, b)
    counts["tv"] = 0
    if weights.any() and rng.random() < probability:
        _add(plug, base + int(_pick(rng, weights)[0]), 60.0 * rng.uniform(low, high), watts)
        counts["tv"] = 1
    return counts


def darkness(day_of_year: np.ndarray, minute_of_day: np.ndarray, latitude_deg: float) -> np.ndarray:
    """Need for electric light (0..1) from the sun's elevation (local standard time taken as solar time):
    1 with the sun below the horizon, falling linearly to :data:`DAYLIGHT_FLOOR` at
    :data:`DAYLIGHT_ELEVATION_DEG`."""
    declination = np.radians(23.44) * np.sin(2 * np.pi * (284 + day_of_year) / 365.0)
    hour_angle = np.radians(15.0 * (minute_of_day / 60.0 - 12.0))
    phi = math.radians(latitude_deg)
    sin_elevation = (math.sin(phi) * np.sin(declination)
                     + math.cos(phi) * np.cos(declination) * np.cos(hour_angle))
    elevation = np.degrees(np.arcsin(np.clip(sin_elevation, -1.0, 1.0)))
    return np.clip(1.0 - (1.0 - DAYLIGHT_FLOOR) * elevation / DAYLIGHT_ELEVATION_DEG, DAYLIGHT_FLOOR, 1.0)


def _per_timestep(minutes: np.ndarray, timesteps_per_hour: int) -> np.ndarray:
    """Per-minute series -> the mean of each timestep (energy- and volume-conserving)."""
    return minutes.reshape(-1, 60 // timesteps_per_hour).mean(axis=1)


def _fill_to_target(power: dict[str, np.ndarray], kinds: tuple[str, ...], target_w: float) -> None:
    """Scale the events of ``kinds`` plus an always-on base (added to ``kinds[0]``, at least
    :data:`MIN_BASE_SHARE` of the target) so their mean is ``target_w`` [W]; in place."""
    events_w = sum(power[kind].mean() for kind in kinds)
    base_w = max(target_w - events_w, MIN_BASE_SHARE * target_w)
    power[kinds[0]] += base_w
    scale = target_w / (events_w + base_w) if target_w > 0 else 0.0
    for kind in kinds:
        power[kind] *= scale


def _scale_events(series: np.ndarray, target_w: float) -> np.ndarray:
    """``series`` [W] scaled to the mean ``target_w``; a flat ``target_w`` when the series has no event."""
    mean = series.mean()
    return series * (target_w / mean) if mean > 0 else np.full_like(series, target_w)


def _scale_monthly(flow: np.ndarray, year: int, litres_per_day: float) -> np.ndarray:
    """``flow`` [L/min per minute] scaled month by month so each month's mean daily volume is the target."""
    days = len(flow) // MINUTES_PER_DAY
    month = (np.datetime64(f"{year}-01-01") + np.arange(days)).astype("datetime64[M]").astype(int) % 12
    out = flow.copy()
    for m in range(12):
        rows = np.repeat(month == m, MINUTES_PER_DAY)
        volume = flow[rows].sum()
        if volume > 0:
            out[rows] *= litres_per_day * (rows.sum() / MINUTES_PER_DAY) / volume
    return out


def generate_schedules(targets: ScheduleTargets, *, year: int, seed: int, bldg_id: int,
                       timesteps_per_hour: int = 1) -> HouseSchedules:
    """The house's occupant-driven schedules over calendar ``year`` (see the module docstring).

    Means over the year [W = kWh/day x 1000/24]: ``plug_w`` = the plug target (plus the cooking, dryer and
    exterior targets when given), ``cooking_w`` / ``dryer_w`` / ``exterior_w`` = their targets when given,
    ``lighting_w`` = the lighting target, ``outdoor_lighting_w`` = the outdoor lighting target (the same
    occupant- and daylight-driven shape); each month's mean daily hot-water volume =
    ``targets.dhw_litres_per_day`` L (when the month has any draw).
    """
    if 60 % timesteps_per_hour:
        raise ValueError(f"timesteps_per_hour must divide 60, got {timesteps_per_hour}")
    rng = np.random.default_rng([int(seed), int(bldg_id), SEED_TAG])
    occupants = max(int(round(targets.occupants)), 0)
    states = occupant_states(occupants, year, rng)  # (people, days, minutes)
    weekend = weekend_days(year)
    minutes = len(weekend) * MINUTES_PER_DAY
    flow = np.zeros(minutes)
    power = {kind: np.zeros(minutes) for kind in ("other", "cooking", "dryer")}
    counts = {"showers": 0, "baths": 0}
    rate = fixture_rate(occupants, targets.dhw_litres_per_day)
    awake_home = (states == AWAKE).sum(axis=0)  # (days, minutes)
    for day, is_weekend in enumerate(weekend):
        base = day * MINUTES_PER_DAY
        showers, baths = _showers_and_baths(rng, states[:, day], base, flow, rate)
        counts["showers"] += showers
        counts["baths"] += baths
        for kind, n in _appliances(rng, awake_home[day], occupants, bool(is_weekend), base, flow, power,
                                   rate).items():
            counts[kind] = counts.get(kind, 0) + n
    block = np.tile(_window(*EXTERIOR_HOURS), len(weekend))
    # so far the day plans of the household's clock; from here on the simulation's standard time
    index = standard_time_index(year, targets.clock_zone)
    flow, block = flow[index], block[index]
    power = {kind: series[index] for kind, series in power.items()}
    states = states.reshape(occupants, minutes)[:, index]
    awake = (states == AWAKE).sum(axis=0).astype(float)
    power["other"] += ELECTRONICS_PER_AWAKE_W * awake
    w_per_kwh_day = 1000.0 / 24.0
    if targets.cooking_kwh_per_day is None and targets.dryer_kwh_per_day is None:
        _fill_to_target(power, ("other", "cooking", "dryer"), targets.plug_kwh_per_day * w_per_kwh_day)
    else:
        _fill_to_target(power, ("other",), targets.plug_kwh_per_day * w_per_kwh_day)
        for kind, daily in (("cooking", targets.cooking_kwh_per_day), ("dryer", targets.dryer_kwh_per_day)):
            power[kind] = _scale_events(power[kind], (daily or 0.0) * w_per_kwh_day)
    power["exterior"] = block * (targets.exterior_kwh_per_day * 1000.0 / (EXTERIOR_HOURS[1] - EXTERIOR_HOURS[0]))
    power = {kind: _per_timestep(series, timesteps_per_hour) for kind, series in power.items()}
    minute_of_day = np.tile(np.arange(MINUTES_PER_DAY), len(weekend))
    day_of_year = np.repeat(np.arange(1, len(weekend) + 1), MINUTES_PER_DAY)
    lit = (1.0 - (1.0 - LIT_PER_PERSON) ** awake) * darkness(day_of_year, minute_of_day, targets.latitude_deg)
    lit += NIGHT_LIGHT
    lit_w_per_kwh_day = w_per_kwh_day / lit.mean()
    lighting = lit * (targets.lighting_kwh_per_day * lit_w_per_kwh_day)
    outdoor_lighting = lit * (targets.outdoor_lighting_kwh_per_day * lit_w_per_kwh_day)
    home = (states != AWAY).sum(axis=0).astype(float)
    asleep = (states == ASLEEP).sum(axis=0)
    heat = SLEEP_ACTIVITY_W * asleep + AWAKE_ACTIVITY_W * awake
    tph = timesteps_per_hour
    people = _per_timestep(home, tph)
    activity = np.where(people > 0, _per_timestep(heat, tph) / np.maximum(people, 1e-9), AWAKE_ACTIVITY_W)
    dhw = _scale_monthly(flow, year, targets.dhw_litres_per_day) / 1000.0 / 60.0
    return HouseSchedules(timesteps_per_hour=tph, people=people, activity_w=activity,
                          lighting_w=_per_timestep(lighting, tph), plug_w=sum(power.values()),
                          cooking_w=power["cooking"], dryer_w=power["dryer"], exterior_w=power["exterior"],
                          outdoor_lighting_w=_per_timestep(outdoor_lighting, tph),
                          dhw_m3_s=_per_timestep(dhw, tph), events=counts, fixture_rate=rate)
