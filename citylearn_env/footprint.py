"""How much memory a run of a schema will need, estimated from the schema file alone (no data file is read).

A whole-episode run (``districtgen run``: load, reset, every step, then the episode series and KPI tables) holds
per building and time step the episode records it writes, the data series that differ between buildings, the
PV generation and outage signal, and at the end the episode series and KPIs (float64 arrays of B x T values);
per distinct data file its columns; and the interpreter with its imports. The constants below were measured
with ``benchmarks/env_scale.py --run`` (peak resident memory of ``districtgen run``; benchmarks/README.md,
"The environment at city scale") and rounded up.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

#: interpreter and the imports of ``districtgen run`` [bytes] (measured: 220 MB peak for 17 buildings x 8,760
#: steps, of which about 170 MB before any building)
BASE_BYTES = 192 * 2**20
#: per building and time step of a whole-episode run [bytes] (measured: 3,335 MB at 1,000 and 483 MB at 100
#: buildings x 8,760 steps, about 370 bytes; the KPI tables after the episode are the peak)
BYTES_PER_BUILDING_STEP = 400
#: per distinct data file and time step [bytes]: its columns (up to 19 float64), held while the run lasts
BYTES_PER_FILE_STEP = 160

_FILE_KEYS = ("energy_simulation", "weather", "pricing", "carbon_intensity")


def schema_size(schema: Mapping[str, Any]) -> tuple[int, int, int]:
    """(buildings included, time steps of the simulation range, distinct data files named) of a parsed
    schema; ValueError/KeyError/TypeError when the schema does not say."""
    buildings = [b for b in schema["buildings"].values() if not isinstance(b, Mapping) or b.get("include", True)]
    steps = int(schema["simulation_end_time_step"]) - int(schema.get("simulation_start_time_step") or 0) + 1
    files = {b.get(k) for b in buildings if isinstance(b, Mapping) for k in _FILE_KEYS if b.get(k)}
    return len(buildings), steps, len(files)


def estimate_run_memory(schema: str | Path | Mapping[str, Any]) -> int:
    """Peak resident memory [bytes] of a whole-episode run of ``schema`` (a schema.json path or a parsed dict):
    :data:`BASE_BYTES` + buildings x steps x :data:`BYTES_PER_BUILDING_STEP` + distinct files x steps x
    :data:`BYTES_PER_FILE_STEP`. Raises OSError/ValueError/KeyError/TypeError for a schema it cannot size."""
    raw = json.loads(Path(schema).read_text()) if isinstance(schema, (str, Path)) else schema
    buildings, steps, files = schema_size(raw)
    return BASE_BYTES + max(steps, 0) * (buildings * BYTES_PER_BUILDING_STEP + files * BYTES_PER_FILE_STEP)


def available_memory() -> int | None:
    """The memory this process can still get [bytes]: Linux ``MemAvailable``, lowered to the room left under a
    cgroup v2 ``memory.max`` (a container's limit) when there is one; None where unknown."""
    available = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                available = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit != "max":
            room = int(limit) - int(Path("/sys/fs/cgroup/memory.current").read_text())
            available = room if available is None else min(available, room)
    except (OSError, ValueError):
        pass
    return available


def memory_refusal(schema: str | Path, available: int | None = None) -> str | None:
    """One line refusing ``schema`` when its run's estimate exceeds ``available`` [bytes; default
    :func:`available_memory`], naming both and what to do; None when it fits, or when the schema cannot be
    sized (the loader then gives its own error)."""
    try:
        raw = json.loads(Path(schema).read_text())
        buildings, steps, _ = schema_size(raw)
        needed = estimate_run_memory(raw)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    available = available_memory() if available is None else available
    if available is None or needed <= available:
        return None
    return (f"{buildings} buildings x {steps} time steps need about {needed / 2**30:.1f} GiB of memory (estimate) "
            f"and {available / 2**30:.1f} GiB are available: run fewer buildings or a shorter period "
            "(simulation_end_time_step), or split the district into several schemas")


def peak_resident_memory() -> int | None:
    """This process's peak resident memory so far [bytes]: Linux ``VmHWM`` (of this program's own memory; unlike
    ``getrusage``'s ``ru_maxrss``, not raised by the parent a child was forked from); None where unknown."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None

