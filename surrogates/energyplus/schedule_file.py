"""The occupant-driven schedules of one house as EnergyPlus reads them: the daily totals kept from the former
fixed profiles (:func:`schedule_targets`), the seeded schedules of a year (:func:`house_schedules`), the design
levels their fractions multiply (:func:`schedule_peaks`) and the ``Schedule:File`` CSV
(:func:`write_schedule_file`). The house model that reads them: :mod:`surrogates.energyplus.house`.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np

from surrogates.energyplus.csv_text import csv_text
from surrogates.energyplus.metadata import HouseParameters
from surrogates.energyplus.occupant_schedules import HouseSchedules, ScheduleTargets, generate_schedules

#: mixed hot-water use temperature (C) the daily litres are counted at
HOT_WATER_USE_C = 43.0
#: volumetric heat capacity of water [kJ/(L K)]
WATER_KJ_PER_L_K = 4.186
#: smallest use-minus-mains temperature difference [K] the delivered-heat conversion divides by
MIN_HOT_WATER_RISE_K = 5.0

#: The former fixed hourly fractions (hour 0 = 00:00-01:00), weekday then weekend (engineering assumptions
#: for a working household). The occupant-driven schedules (:mod:`surrogates.energyplus.occupant_schedules`) keep the
#: daily lighting and plug energies these give (:func:`schedule_targets`); docs/energyplus.md.
OCCUPANCY = (
    [1, 1, 1, 1, 1, 1, 1, .85, .5, .35, .35, .35, .35, .35, .35, .35, .5, .7, .9, .9, .9, .9, 1, 1],
    [1, 1, 1, 1, 1, 1, 1, 1, 1, .7, .7, .7, .7, .6, .6, .6, .6, .9, .9, .9, .9, .9, 1, 1],
)
LIGHTING = (
    [.05, .05, .05, .05, .05, .05, .3, .3, .1, .1, .1, .1, .1, .1, .1, .1, .1, .4, .7, .7, .7, .7, .4, .1],
    [.05, .05, .05, .05, .05, .05, .1, .3, .3, .15, .15, .15,
     .15, .15, .15, .15, .2, .4, .7, .7, .7, .7, .4, .1],
)
EQUIPMENT = (
    [.45, .45, .45, .45, .45, .45, .6, .6, .6, .5, .5, .5,
     .5, .5, .5, .5, .6, .85, .85, .85, .85, .85, .6, .6],
    [.45, .45, .45, .45, .45, .45, .5, .6, .7, .7, .7, .7,
     .7, .7, .7, .7, .7, .85, .85, .85, .85, .85, .6, .6],
)
HOT_WATER = (
    [.02, .02, .02, .02, .02, .02, .5, 1, .6, .1, .1, .1, .1, .1, .1, .1, .1, .3, .6, .6, .6, .4, .2, .05],
    [.02, .02, .02, .02, .02, .02, .1, .5, 1, .8, .4, .3, .3, .2, .2, .2, .2, .3, .6, .6, .6, .4, .2, .05],
)
#: ``Schedule:File`` columns of the occupant-driven schedules and the schedule names that read them
SCHEDULE_COLUMNS = ("people_fraction", "activity_w", "lighting_fraction", "plug_fraction", "cooking_fraction",
                    "dryer_fraction", "exterior_fraction", "hot_water_fraction")
#: where :func:`build_house_model` writes the schedule CSV when given no folder (content-addressed names)
SCHEDULE_DIR = Path(tempfile.gettempdir()) / "districtgen-schedules"

def schedule_targets(house: HouseParameters, latitude_deg: float = 35.0, mains_mean_c: float = 20.0,
                     clock_zone: str | None = None) -> ScheduleTargets:
    """The daily totals of the house's occupant-driven schedules.

    With the stock row's own end uses (``house.end_uses``): plug, cooking, dryer, interior and outdoor
    lighting and exterior electricity [kWh/day] as the row says, and hot water [L/day of mixed water at :data:`HOT_WATER_USE_C`] =
    the delivered hot-water heat / (:data:`WATER_KJ_PER_L_K` x (use - ``mains_mean_c``, the annual mean
    mains temperature [C]; at least :data:`MIN_HOT_WATER_RISE_K`)).

    ``clock_zone``: the IANA time zone of the household's clock (:attr:`ScheduleTargets.clock_zone`).

    Otherwise the former fixed profiles' totals: hot water = (base + per person x occupants) x fixtures; plug
    and lighting = peak density x floor area x the week-weighted mean of :data:`EQUIPMENT` /
    :data:`LIGHTING` x 24 h.
    """
    def daily_kwh(w_per_m2: float, profile: tuple[list[float], list[float]]) -> float:
        mean = (5 * sum(profile[0]) + 2 * sum(profile[1])) / 7 / 24
        return w_per_m2 * house.floor_area_m2 * mean * 24 / 1000.0

    litres = (house.dhw_base_litres_day + house.dhw_litres_per_person_day * house.occupants) * house.dhw_scale
    uses = house.end_uses
    if uses is not None:
        if uses.dhw_delivered is not None:
            rise = max(HOT_WATER_USE_C - mains_mean_c, MIN_HOT_WATER_RISE_K)
            litres = uses.dhw_delivered * 3600.0 / (WATER_KJ_PER_L_K * rise)
        return ScheduleTargets(occupants=int(round(house.occupants)), dhw_litres_per_day=litres,
                               plug_kwh_per_day=uses.plug, lighting_kwh_per_day=uses.lighting,
                               latitude_deg=latitude_deg, cooking_kwh_per_day=uses.cooking,
                               dryer_kwh_per_day=uses.dryer, exterior_kwh_per_day=uses.exterior,
                               outdoor_lighting_kwh_per_day=uses.outdoor_lighting,
                               clock_zone=clock_zone)
    return ScheduleTargets(occupants=int(round(house.occupants)), dhw_litres_per_day=litres,
                           plug_kwh_per_day=daily_kwh(house.equipment_w_per_m2, EQUIPMENT),
                           lighting_kwh_per_day=daily_kwh(house.lighting_w_per_m2, LIGHTING),
                           latitude_deg=latitude_deg, clock_zone=clock_zone)


@lru_cache(maxsize=4)
def house_schedules(house: HouseParameters, year: int, timesteps_per_hour: int, seed: int = 0,
                    latitude_deg: float = 35.0, mains_mean_c: float = 20.0,
                    clock_zone: str | None = None) -> HouseSchedules:
    """The house's occupant-driven schedules (:func:`surrogates.energyplus.occupant_schedules.generate_schedules` of
    :func:`schedule_targets`), seeded with (``seed``, ``house.bldg_id``); cached, as one simulation builds the
    model several times."""
    return generate_schedules(schedule_targets(house, latitude_deg, mains_mean_c, clock_zone), year=year,
                              seed=seed, bldg_id=house.bldg_id, timesteps_per_hour=timesteps_per_hour)


def _peak(values: np.ndarray) -> float:
    return float(values.max()) if values.size and values.max() > 0 else 0.0


def schedule_peaks(house: HouseParameters, schedules: HouseSchedules) -> dict[str, float]:
    """Design levels the ``Schedule:File`` fractions multiply: people (occupants, rounded as the schedules
    round them), lighting, other plug, cooking, dryer and outdoor (exterior equipment and lighting, no zone
    gain) power [W], hot-water flow [m3/s], for the whole house."""
    return {"people": float(max(round(house.occupants), 0)), "lighting_w": _peak(schedules.lighting_w),
            "plug_w": _peak(_other_plug_w(schedules)), "cooking_w": _peak(schedules.cooking_w),
            "dryer_w": _peak(schedules.dryer_w), "exterior_w": _peak(_outdoor_w(schedules)),
            "dhw_m3_s": _peak(schedules.dhw_m3_s)}


def _other_plug_w(schedules: HouseSchedules) -> np.ndarray:
    """Plug power [W] other than cooking, the dryer and outdoor equipment (a full zone gain)."""
    return np.clip(schedules.plug_w - schedules.cooking_w - schedules.dryer_w - schedules.exterior_w, 0.0, None)


def _outdoor_w(schedules: HouseSchedules) -> np.ndarray:
    """Outdoor electricity [W]: exterior equipment and garage/exterior lighting (one object, no zone gain)."""
    return schedules.exterior_w + schedules.outdoor_lighting_w


def write_schedule_file(house: HouseParameters, directory: Path, year: int, timesteps_per_hour: int,
                        seed: int = 0, latitude_deg: float = 35.0, mains_mean_c: float = 20.0,
                        clock_zone: str | None = None) -> Path:
    """Write the ``Schedule:File`` CSV of :func:`house_schedules` (same arguments; :func:`schedule_csv`) into
    ``directory`` under a content-addressed name; an existing identical file is reused. Returns its path."""
    text, digest = schedule_csv(house, year, timesteps_per_hour, seed, latitude_deg, mains_mean_c, clock_zone)
    path = Path(directory) / f"schedules_{house.bldg_id}_{digest}.csv"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".csv", dir=path.parent)
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    return path


@lru_cache(maxsize=4)
def schedule_csv(house: HouseParameters, year: int, timesteps_per_hour: int, seed: int = 0,
                 latitude_deg: float = 35.0, mains_mean_c: float = 20.0,
                 clock_zone: str | None = None) -> tuple[str, str]:
    """The ``Schedule:File`` CSV text of :func:`house_schedules` (columns :data:`SCHEDULE_COLUMNS`: fractions
    of :func:`schedule_peaks` and the activity in W per person) and the first 16 hex digits of its sha256;
    cached like the schedules, as one house's runs build its model several times."""
    schedules = house_schedules(house, year, timesteps_per_hour, seed, latitude_deg, mains_mean_c, clock_zone)
    peaks = schedule_peaks(house, schedules)

    def fraction(values: np.ndarray, peak: float) -> np.ndarray:
        return values / peak if peak > 0 else np.zeros_like(values)

    table = np.column_stack([fraction(schedules.people, peaks["people"]), schedules.activity_w,
                             fraction(schedules.lighting_w, peaks["lighting_w"]),
                             fraction(_other_plug_w(schedules), peaks["plug_w"]),
                             fraction(schedules.cooking_w, peaks["cooking_w"]),
                             fraction(schedules.dryer_w, peaks["dryer_w"]),
                             fraction(_outdoor_w(schedules), peaks["exterior_w"]),
                             fraction(schedules.dhw_m3_s, peaks["dhw_m3_s"])])
    text = csv_text(SCHEDULE_COLUMNS, table)
    return text, hashlib.sha256(text.encode()).hexdigest()[:16]
