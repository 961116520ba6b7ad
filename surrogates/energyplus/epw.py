"""What the house model needs from an EPW header: monthly ground temperatures."""

from __future__ import annotations

from pathlib import Path

from citylearn_env.errors import InputError


def read_epw_ground_temperatures(path: Path) -> list[float]:
    """The 12 monthly undisturbed ground temperatures (C) at the shallowest depth of the EPW header's
    ``GROUND TEMPERATURES`` line (field layout: count, then per depth: depth, conductivity, density,
    specific heat, 12 temperatures)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("EPW weather file not found", file=path)
    with path.open(errors="replace") as handle:
        header = [next(handle, "") for _ in range(8)]
    for number, line in enumerate(header, start=1):
        if line.upper().startswith("GROUND TEMPERATURES"):
            fields = line.strip().split(",")
            try:
                if int(fields[1]) < 1:
                    break
                return [float(v) for v in fields[6:18]]
            except (ValueError, IndexError):
                raise InputError("unreadable GROUND TEMPERATURES header line", file=path,
                                 row=number) from None
    raise InputError("EPW header has no ground temperatures", file=path, column="GROUND TEMPERATURES")
