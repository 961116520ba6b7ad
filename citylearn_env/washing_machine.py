"""Washing machines, as the CityLearn v2.2+ schema describes them (contract: docs/ev.md section 6).

A machine has a data file with one row per time step: a start window (``wm_start_time_step`` ..
``wm_end_time_step``, absolute time steps, -1 for none) and the load profile of the cycle that may start in
it (kWh per step from the start step on). An action > 0 inside the window starts the cycle once per window.
Shapes: (M,) per machine, (M, T) over the simulation range. Energies kWh per step.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env.dataset import read_frame, row_label
from citylearn_env.errors import SchemaError
from citylearn_env.ev import parse_number_column

WASHING_MACHINE_COLUMNS = ("day_type", "hour", "wm_start_time_step", "wm_end_time_step", "load_profile")
NO_WINDOW = -1


@dataclass(frozen=True, eq=False)
class WashingMachineTable:
    """One machine's file over T rows: ``start`` and ``end`` of the row's window [time step, -1 none] (T,)
    and the row's cycle ``profile`` [kWh per step] (a tuple of T tuples; empty when none)."""

    start: np.ndarray
    end: np.ndarray
    profile: tuple[tuple[float, ...], ...]


@dataclass(frozen=True, eq=False)
class WashingMachines:
    """M machines: ``names`` (also their action names), owning ``building`` index (M,), windows ``start``
    and ``end`` (M, T) and per-row profiles ``profile[m][t]`` [kWh per step]."""

    names: tuple[str, ...]
    building: np.ndarray
    start: np.ndarray
    end: np.ndarray
    profile: tuple[tuple[tuple[float, ...], ...], ...]


def parse_load_profile(text: str, path: object, row: int) -> tuple[float, ...]:
    """A ``load_profile`` cell: ``[a, b, ...]`` (kWh per step) -> (a, b, ...); ``-1`` or empty -> ()."""
    cell = text.strip()
    if cell in ("", "-1", "-1.0", "[]"):
        return ()
    if not (cell.startswith("[") and cell.endswith("]")):
        raise SchemaError(f"load profile {cell!r} is not a [list] of kWh", file=path, column="load_profile",
                          row=row_label(row))
    try:
        values = tuple(float(v) for v in cell[1:-1].split(",") if v.strip())
    except ValueError:
        raise SchemaError(f"load profile {cell!r} holds a non-number", file=path, column="load_profile",
                          row=row_label(row)) from None
    if any(not np.isfinite(v) or v < 0 for v in values):
        raise SchemaError(f"load profile {cell!r} needs finite values >= 0", file=path, column="load_profile",
                          row=row_label(row))
    return values


def read_washing_machine_table(path: str | Path, n_rows: int) -> WashingMachineTable:
    """Read the first ``n_rows`` rows of a washing-machine CSV (columns by header name); one SchemaError
    naming file, column and row for a missing column, a short file, a non-number or a window with only one
    end given."""
    path = Path(path)
    frame = read_frame(path)
    missing = [c for c in WASHING_MACHINE_COLUMNS if c not in frame.columns]
    if missing:
        raise SchemaError(f"missing washing-machine column (has {list(frame.columns)})", file=path,
                          column=missing[0])
    if len(frame) < n_rows:
        raise SchemaError(f"has {len(frame)} data rows; the simulation range needs {n_rows}", file=path,
                          row=len(frame))
    window = {c: parse_number_column(np.char.strip(frame[c].to_numpy()[:n_rows].astype(str)), path, c,
                                     allow_empty=True)
              for c in ("wm_start_time_step", "wm_end_time_step")}
    start, end = (np.where(np.isnan(v), NO_WINDOW, v).astype(np.int64) for v in window.values())
    half = (start == NO_WINDOW) != (end == NO_WINDOW)
    if half.any():
        i = int(half.argmax())
        raise SchemaError("a start window needs both ends (or -1 for both)", file=path,
                          column="wm_start_time_step / wm_end_time_step", row=row_label(i))
    profiles = tuple(parse_load_profile(str(cell), path, i)
                     for i, cell in enumerate(frame["load_profile"].to_numpy()[:n_rows]))
    return WashingMachineTable(start=start, end=end, profile=profiles)


def parse_washing_machines(raw_schema: Mapping[str, Any], root: str | Path) -> WashingMachines | None:
    """The ``washing_machines`` of every included building (schema order) with their data over the
    simulation range; ``None`` when there are none."""
    start_row = int(raw_schema.get("simulation_start_time_step") or 0)
    end_row = raw_schema.get("simulation_end_time_step")
    buildings = [spec for spec in raw_schema.get("buildings", {}).values() if spec.get("include", True)]
    machines = [(b, name, spec) for b, bspec in enumerate(buildings)
                for name, spec in (bspec.get("washing_machines") or {}).items()]
    if not machines:
        return None
    if end_row is None:
        raise SchemaError("needed to read washing-machine files", column="simulation_end_time_step")
    tables = []
    for _, name, spec in machines:
        file = spec.get("washing_machine_energy_simulation")
        if not isinstance(file, str):
            raise SchemaError("missing data file name",
                              column=f"washing_machines.{name}.washing_machine_energy_simulation")
        tables.append(read_washing_machine_table(Path(root) / file, int(end_row) + 1))
    return WashingMachines(names=tuple(name for _, name, _ in machines),
                           building=np.array([b for b, _, _ in machines], dtype=np.int64),
                           start=np.stack([t.start[start_row:] for t in tables]),
                           end=np.stack([t.end[start_row:] for t in tables]),
                           profile=tuple(t.profile[start_row:] for t in tables))


def cycle_starts(action: np.ndarray, running: np.ndarray, start: np.ndarray, end: np.ndarray,
                 has_profile: np.ndarray, t: int) -> np.ndarray:
    """Which machines (M,) start a cycle at step t: action > 0, no cycle started in this window yet
    (``running`` False), start <= t <= end of row t's window (``start``/``end`` (M,) of row t) and a
    non-empty row-t profile (upstream skips an empty one without marking the machine running). The caller
    then sets ``running |= started``; after each advance it clears ``running`` where :func:`window_changed`."""
    inside = (start != NO_WINDOW) & (end != NO_WINDOW) & (start <= t) & (t <= end)
    return (action > 0) & ~running & inside & has_profile


def window_changed(start: np.ndarray, end: np.ndarray, t: int) -> np.ndarray:
    """Machines (M,) whose window at row t differs from row t - 1 (the running flag is cleared then);
    ``start``/``end`` are (M, T). All False at t = 0."""
    if t == 0:
        return np.zeros(start.shape[0], dtype=bool)
    return (start[:, t] != start[:, t - 1]) | (end[:, t] != end[:, t - 1])


def add_cycle_load(consumption: np.ndarray, started: np.ndarray, profiles: Sequence[Sequence[float]],
                   t: int) -> np.ndarray:
    """A copy of the (M, T) consumption [kWh] with each started machine's profile added from step t on
    (value k at t + k), cut at the episode end. ``profiles[m]`` is machine m's row-t profile."""
    out = consumption.copy()
    horizon = out.shape[1]
    for m in np.flatnonzero(started):
        load = np.asarray(profiles[m], dtype=np.float64)[: max(horizon - t, 0)]
        out[m, t:t + len(load)] += load
    return out
