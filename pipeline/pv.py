"""PV yield per kW installed: the CityLearn ``solar_generation`` column [W AC per kW DC], with pvlib.

Model chain (PVWatts-like, all pvlib functions): solar position at the middle of each hour; plane-of-array
irradiance by the Perez transposition from the weather file's GHI/DNI/DHI; SAPM cell temperature
(open rack, glass/polymer); PVWatts DC power (temperature coefficient ``gamma_pdc``) less lumped system
losses; PVWatts inverter with a DC/AC ratio. No shading, soiling beyond the lumped losses, or degradation.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pandas as pd
import pvlib

from pipeline.errors import InputError


@dataclasses.dataclass(frozen=True)
class PVSite:
    """A PV array and its site.

    latitude [deg north], longitude [deg east], tilt [deg from horizontal; None = latitude],
    azimuth [deg clockwise from north, 180 = south], altitude [m], albedo [-], dc_ac_ratio [-],
    gamma_pdc [1/C], system_losses [fraction of DC], inverter_efficiency [-] (nominal).
    """

    latitude: float
    longitude: float
    tilt: float | None = None
    azimuth: float = 180.0
    altitude: float = 0.0
    albedo: float = 0.2
    dc_ac_ratio: float = 1.2
    gamma_pdc: float = -0.0037
    system_losses: float = 0.14
    inverter_efficiency: float = 0.96

    def __post_init__(self) -> None:
        checks = {"latitude": -90 <= self.latitude <= 90, "longitude": -180 <= self.longitude <= 180,
                  "tilt": self.tilt is None or 0 <= self.tilt <= 90, "azimuth": 0 <= self.azimuth <= 360,
                  "dc_ac_ratio": self.dc_ac_ratio > 0, "system_losses": 0 <= self.system_losses < 1}
        for key, ok in checks.items():
            if not ok:
                raise InputError(f"out of range: {getattr(self, key)}", column=key)


def pv_yield(weather: pd.DataFrame, site: PVSite, utc_offset_hours: float) -> pd.Series:
    """AC output per kW of installed DC capacity for every hour of ``weather``.

    Parameters
    ----------
    weather
        Canonical hourly weather (interval-beginning, local standard time): ``ghi_w_m2``, ``dni_w_m2``,
        ``dhi_w_m2`` [W/m2, hourly means], ``outdoor_dry_bulb_temperature_c`` [C], ``wind_speed_m_s`` [m/s].
    site
        Array and site.
    utc_offset_hours
        Offset of the index's standard time from UTC [h], e.g. -6 for US Central.

    Returns
    -------
    Series ``solar_generation`` [W per kW] (= Wh per kW in each hour), >= 0.
    """
    tilt = abs(site.latitude) if site.tilt is None else site.tilt
    mid = pd.DatetimeIndex(weather.index) + pd.Timedelta(minutes=30)
    times = (mid - pd.Timedelta(hours=utc_offset_hours)).tz_localize("UTC")
    solpos = pvlib.solarposition.get_solarposition(
        times, site.latitude, site.longitude, altitude=site.altitude,
        temperature=weather["outdoor_dry_bulb_temperature_c"].to_numpy())
    dni_extra = pvlib.irradiance.get_extra_radiation(times)
    airmass = pvlib.atmosphere.get_relative_airmass(solpos["apparent_zenith"].to_numpy())
    poa = pvlib.irradiance.get_total_irradiance(
        tilt, site.azimuth, solpos["apparent_zenith"].to_numpy(), solpos["azimuth"].to_numpy(),
        weather["dni_w_m2"].to_numpy(), weather["ghi_w_m2"].to_numpy(), weather["dhi_w_m2"].to_numpy(),
        dni_extra=dni_extra.to_numpy(), airmass=airmass, albedo=site.albedo, model="perez")
    poa_global = np.nan_to_num(np.asarray(poa["poa_global"], dtype=float), nan=0.0).clip(min=0.0)
    params = pvlib.temperature.TEMPERATURE_MODEL_PARAMETERS["sapm"]["open_rack_glass_polymer"]
    cell = pvlib.temperature.sapm_cell(poa_global, weather["outdoor_dry_bulb_temperature_c"].to_numpy(),
                                       weather["wind_speed_m_s"].to_numpy(), **params)
    dc = pvlib.pvsystem.pvwatts_dc(poa_global, cell, 1000.0, site.gamma_pdc) * (1.0 - site.system_losses)
    ac = pvlib.inverter.pvwatts(dc, 1000.0 / site.dc_ac_ratio, eta_inv_nom=site.inverter_efficiency)
    values = np.clip(np.nan_to_num(np.asarray(ac, dtype=float), nan=0.0), 0.0, None)
    return pd.Series(values, index=weather.index, name="solar_generation")


def site_pv_yield(weather: pd.DataFrame, meta: Mapping[str, object], *, tilt: float | None = None,
                  azimuth: float = 180.0, file: object = None) -> pd.Series:
    """The site's PV yield [W AC per kW DC] for every hour of a weather file (see :func:`pv_yield`).

    Computed once per weather file: all buildings of a district share the site, so they share this series.
    ``meta`` is the weather reader's metadata (``latitude``, ``longitude`` [deg], ``utc_offset_hours``,
    optional ``elevation_m``); a file without a site location (ResStock weather CSV) is an
    :class:`InputError` naming ``file``.
    """
    if "latitude" not in meta or "longitude" not in meta:
        raise InputError("PV needs an EPW (site latitude/longitude)", file=file)
    site = PVSite(float(meta["latitude"]), float(meta["longitude"]), tilt=tilt, azimuth=azimuth,
                  altitude=float(meta.get("elevation_m", 0.0)))
    return pv_yield(weather, site, float(meta["utc_offset_hours"]))
