"""What the house model needs from an EPW: monthly ground temperatures and the latitude (header), and the
annual mean mains water temperature (data rows)."""

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


def read_epw_latitude(path: Path) -> float:
    """The site latitude [degrees north] of the EPW header's ``LOCATION`` line (field 7)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("EPW weather file not found", file=path)
    with path.open(errors="replace") as handle:
        line = next(handle, "")
    fields = line.strip().split(",")
    try:
        if not fields[0].upper().startswith("LOCATION"):
            raise ValueError
        latitude = float(fields[6])
    except (ValueError, IndexError):
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
