"""PV yield per kW from an EPW weather file with pvlib's PVWatts models, offline.

CityLearn 2.2+ autosizes a schema's PV (``"autosize": true`` with ``autosize_attributes.epw_filepath``) by running
PySAM's PVWatts on the EPW for a system drawn from a table it downloads. Offline, this module computes the same kind
of profile with pvlib (the ``pipeline`` extra; imported inside :func:`epw_yield`, one clear line when missing):

* the EPW's hourly GHI, DNI, DHI [W/m2], dry-bulb temperature [degC] and wind speed [m/s]; EPW rows are hour-ending
  in local standard time, so the sun's position is taken at the middle of each hour;
* plane-of-array irradiance by the Perez transposition on a fixed array (:data:`PVWATTS_DEFAULTS`: PVWatts v5's
  defaults -- tilt 20 deg, azimuth 180 deg (south), albedo 0.2);
* cell temperature by the SAPM model (open rack, glass/polymer);
* DC power by PVWatts (temperature coefficient -0.0047 /degC, PVWatts' standard module) less 14.08 % system losses
  (PVWatts' default), AC by the PVWatts inverter model (nominal efficiency 0.96, DC/AC ratio 1.2).

The result is CityLearn's ``solar_generation`` column: W of AC output per kW of DC capacity for each hour (= Wh per
kW in the hour). The sizing rule that uses it is :func:`citylearn_env.pv_battery_autosize.pv_power`.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env.errors import SchemaError

#: the fixed-array PVWatts parameters used (PVWatts v5 defaults; angles in degrees, losses as fractions)
PVWATTS_DEFAULTS: dict[str, float] = {"tilt": 20.0, "azimuth": 180.0, "albedo": 0.2, "gamma_pdc": -0.0047,
                                      "system_losses": 0.1408, "inverter_efficiency": 0.96, "dc_ac_ratio": 1.2}


def _pvlib() -> Any:
    try:
        import pvlib
    except ImportError:
        raise SchemaError("PV autosize from an EPW file needs pvlib, which is not installed: pip install "
                          "'districtgen[pipeline]' (or give the PV's nominal_power with autosize false)",
                          column="pv.autosize_attributes.epw_filepath") from None
    return pvlib


def pvwatts_ac_per_kw(ghi: np.ndarray, dni: np.ndarray, dhi: np.ndarray, temp_air: np.ndarray,
                      wind_speed: np.ndarray, apparent_zenith: np.ndarray, sun_azimuth: np.ndarray,
                      dni_extra: np.ndarray, params: dict[str, float] = PVWATTS_DEFAULTS) -> np.ndarray:
    """AC power per kW of DC capacity [W/kW] from irradiance [W/m2], air temperature [degC], wind [m/s], the sun's
    apparent zenith and azimuth [deg] and extraterrestrial DNI [W/m2] (module docstring); never negative."""
    pvlib = _pvlib()
    airmass = pvlib.atmosphere.get_relative_airmass(apparent_zenith)
    poa = pvlib.irradiance.get_total_irradiance(params["tilt"], params["azimuth"], apparent_zenith, sun_azimuth,
                                                dni, ghi, dhi, dni_extra=dni_extra, airmass=airmass,
                                                albedo=params["albedo"], model="perez")
    poa_global = np.clip(np.nan_to_num(np.asarray(poa["poa_global"], dtype=np.float64)), 0.0, None)
    cell = pvlib.temperature.sapm_cell(poa_global, temp_air, wind_speed,
                                       **pvlib.temperature.TEMPERATURE_MODEL_PARAMETERS["sapm"]["open_rack_glass_polymer"])
    dc = pvlib.pvsystem.pvwatts_dc(poa_global, cell, 1000.0, params["gamma_pdc"]) * (1.0 - params["system_losses"])
    ac = pvlib.inverter.pvwatts(dc, 1000.0 / params["dc_ac_ratio"], eta_inv_nom=params["inverter_efficiency"])
    return np.clip(np.nan_to_num(np.asarray(ac, dtype=np.float64)), 0.0, None)


@functools.lru_cache(maxsize=8)
def _epw_yield(path: str, mtime_ns: int) -> np.ndarray:
    pvlib = _pvlib()
    try:
        data, meta = pvlib.iotools.read_epw(path)
    except Exception as error:  # noqa: BLE001 - any parse failure of a foreign file is one line
        raise SchemaError(f"not a readable EPW weather file ({type(error).__name__}: {str(error)[:120]})",
                          file=path) from None
    times = data.index - np.timedelta64(30, "m")  # the middle of each hour-ending row
    position = pvlib.solarposition.get_solarposition(times, meta["latitude"], meta["longitude"],
                                                     altitude=meta.get("altitude", 0.0))
    dni_extra = np.asarray(pvlib.irradiance.get_extra_radiation(times), dtype=np.float64)
    columns = [np.asarray(data[c], dtype=np.float64) for c in ("ghi", "dni", "dhi", "temp_air", "wind_speed")]
    values = pvwatts_ac_per_kw(*columns, np.asarray(position["apparent_zenith"], dtype=np.float64),
                               np.asarray(position["azimuth"], dtype=np.float64), dni_extra)
    values.setflags(write=False)
    return values


def epw_yield(path: str | Path) -> np.ndarray:
    """The hourly PV yield [W AC per kW DC] of the EPW file ``path``, one value per EPW row (cached per file)."""
    path = Path(path)
    return _epw_yield(str(path.resolve()), path.stat().st_mtime_ns)


def aligned(yield_w_per_kw: np.ndarray, start: int, n: int) -> np.ndarray:
    """Rows ``start .. start + n - 1`` of an EPW yield, as the data rows of a schema's simulation range (row k of
    the building file is row k of the EPW; a range past the EPW's year wraps to its start)."""
    return np.asarray(yield_w_per_kw)[(start + np.arange(n)) % len(yield_w_per_kw)].astype(np.float64)


__all__ = ["PVWATTS_DEFAULTS", "aligned", "epw_yield", "pvwatts_ac_per_kw"]
