"""What the house model needs from an EPW: monthly ground temperatures, the latitude and the time zone of the
site's clocks (header), and the annual mean mains water temperature (data rows)."""

from __future__ import annotations

from pathlib import Path

from citylearn_env.errors import InputError


def read_epw_ground_temperatures(path: Path) -> list[float]:
    """The 12 monthly undisturbed ground temperatures (C) at the DEEPEST depth of the EPW header's
    ``GROUND TEMPERATURES`` line (field layout: count, then per depth: depth, conductivity, density,
    specific heat, 12 temperatures); the boundary under the house's slab is their annual mean
    (:func:`surrogates.energyplus.house.slab_boundary_c`).

    Not the shallowest (0.5 m) values: those follow the outdoor surface (Austin: 27.7 C in June) while the
    soil under a conditioned slab is held near the indoor and the annual-mean ground temperature; with the
    shallow values a 21 C house gains ~9 W per m2 of slab all June (docs/energyplus.md, "Cooling
    realism")."""
    path = Path(path)
    if not path.is_file():
        raise InputError("EPW weather file not found", file=path)
    with path.open(errors="replace") as handle:
        header = [next(handle, "") for _ in range(8)]
    for number, line in enumerate(header, start=1):
        if line.upper().startswith("GROUND TEMPERATURES"):
            fields = line.strip().split(",")
            try:
                depths = int(fields[1])
                if depths < 1:
                    break
                first = 2 + 16 * (depths - 1)  # each depth: depth, conductivity, density, heat, 12 months
                return [float(v) for v in fields[first + 4:first + 16]]
            except (ValueError, IndexError):
                raise InputError("unreadable GROUND TEMPERATURES header line", file=path,
                                 row=number) from None
    raise InputError("EPW header has no ground temperatures", file=path, column="GROUND TEMPERATURES")


def _location_fields(path: Path) -> list[str]:
    """The fields of the EPW header's first line (``LOCATION``, city, state, country, source, WMO, latitude,
    longitude, time zone, elevation); one error naming the file when it is missing or not that line."""
    path = Path(path)
    if not path.is_file():
        raise InputError("EPW weather file not found", file=path)
    with path.open(errors="replace") as handle:
        fields = next(handle, "").strip().split(",")
    if not fields[0].upper().startswith("LOCATION") or len(fields) < 7:
        raise InputError("unreadable LOCATION header line (expected LOCATION,city,state,country,...)", file=path,
                         row=1)
    return fields


#: IANA zones of US sites by the EPW's UTC offset [h] (standard time), and of the states and territories
#: whose clocks keep standard time all year
US_ZONES = {-5.0: "America/New_York", -6.0: "America/Chicago", -7.0: "America/Denver",
            -8.0: "America/Los_Angeles", -9.0: "America/Anchorage", -10.0: "Pacific/Honolulu"}
US_STANDARD_TIME_ZONES = {"AZ": "America/Phoenix", "HI": "Pacific/Honolulu", "PR": "America/Puerto_Rico",
                          "VI": "America/St_Thomas", "GU": "Pacific/Guam", "AS": "Pacific/Pago_Pago",
                          "MP": "Pacific/Saipan"}


def read_epw_timezone(path: Path) -> str | None:
    """The IANA time zone of the households' clocks at the EPW's site, where the header tells it: a site in
    the USA (``LOCATION`` country ``USA``/``US``) gets its state's standard-time zone
    (:data:`US_STANDARD_TIME_ZONES`) or the zone of its UTC offset (field 9, :data:`US_ZONES`); None
    elsewhere (the offset alone does not tell a country's daylight-time rule: set the zone explicitly)."""
    fields = _location_fields(path)
    country, state = fields[3].strip().upper(), fields[2].strip().upper()
    if country not in ("USA", "US", "UNITED STATES"):
        return None
    if state in US_STANDARD_TIME_ZONES:
        return US_STANDARD_TIME_ZONES[state]
    try:
        return US_ZONES.get(float(fields[8]))
    except (ValueError, IndexError):
        raise InputError("unreadable time zone in the LOCATION header line (field 9)", file=path, row=1) from None


def read_epw_latitude(path: Path) -> float:
    """The site latitude [degrees north] of the EPW header's ``LOCATION`` line (field 7)."""
    fields = _location_fields(path)
    try:
        latitude = float(fields[6])
    except ValueError:
        raise InputError("unreadable LOCATION header line (latitude in field 7)", file=path, row=1) from None
    if not -90.0 <= latitude <= 90.0:
        raise InputError(f"latitude {latitude:g} outside -90..90", file=path, row=1, column="LOCATION")
    return latitude


#: the mains-temperature correlation's offset of the annual mean over the annual mean air temperature [K]
#: (6 F; the correlation EnergyPlus's ``Site:WaterMainsTemperature`` ``CorrelationFromWeatherFile`` uses)
MAINS_OFFSET_K = 6.0 * 5.0 / 9.0


def read_epw_mains_mean(path: Path) -> float:
    """The annual mean mains water temperature [C] the house model's EnergyPlus runs see: the mean outdoor
    dry-bulb temperature of the EPW's data rows (field 7) plus :data:`MAINS_OFFSET_K` (the sine term of the
    correlation averages to zero over the year)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("EPW weather file not found", file=path)
    total, count = 0.0, 0
    with path.open(errors="replace") as handle:
        for number, line in enumerate(handle, start=1):
            if number <= 8:
                continue
            fields = line.split(",", 7)
            try:
                total += float(fields[6])
            except (ValueError, IndexError):
                raise InputError("unreadable dry-bulb temperature", file=path, row=number, column="field 7") from None
            count += 1
    if count == 0:
        raise InputError("EPW has no data rows", file=path)
    return total / count + MAINS_OFFSET_K
