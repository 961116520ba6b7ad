"""Which CityLearn version a program was written for, and the API, physics and data-set folder that follow.

CityLearn 2.1 and 2.2+ programs differ in their step API (2.1, gym 0.21: ``reset()`` returns the observations and
``step()`` four values ``(observations, reward, done, info)``; 2.2+: gymnasium's ``(observations, info)`` and five
values) and read different data-set layouts (2.1: positional CSV header texts such as ``Month``, ``dynamics:
{cooling, heating}``; 2.2+: snake_case names, one ``dynamics`` object). A 2.1 program can only have read a v2.1
layout, a 2.2+ program only a v2.2+ one, so the layout decides, unless the program says otherwise:

1. ``CityLearnEnv(..., citylearn_version="2.1" | "2.5")`` (any 2.1.x, or 2.2 .. 2.5.x);
2. else ``$DISTRICTGEN_CITYLEARN_VERSION`` (same values: a whole session of 2.1 programs, no code change);
3. else the schema's layout (its ``dynamics`` blocks, then the header of the first building's CSV);
4. else (a ``DistrictConfig``, an unreadable layout) a ``settings=`` preset name, else 2.5.

Version "2.1" mirrors CityLearn 2.1.2 (its API, the "citylearn-2.1" preset, data sets of ``v2.1.2``), "2.5"
CityLearn 2.5.0 (gymnasium's API, the "citylearn-2.5" preset and KPI names, data sets of ``v2.4.2``).
``settings=`` still overrides the physics alone. One notice line (logger ``citylearn_env.compat``, level WARNING,
once per process for each version and reason) names the version mirrored and why.

Calls made by gymnasium, Stable-Baselines3, PettingZoo or this package (their wrappers and training loops, which
all speak gymnasium) always get gymnasium's API; only the program's own calls get the 2.1 forms (see
:func:`program_call`).
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from citylearn_env import dataset, paths
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_1, CITYLEARN_2_5, Behaviour

#: environment variable naming the CityLearn version of the session's programs
VERSION_VAR = "DISTRICTGEN_CITYLEARN_VERSION"
#: mirrored version -> (preset, data-set release folder, API)
MIRRORS = {"2.1": ("citylearn-2.1", "v2.1.2", "2.1"), "2.5": ("citylearn-2.5", "v2.4.2", "gymnasium")}
#: top-level packages whose calls get gymnasium's API whatever the program's version
GYMNASIUM_CALLERS = frozenset({"gymnasium", "stable_baselines3", "sb3_contrib", "shimmy", "pettingzoo", "ray",
                               "citylearn_env"})
#: the header bytes read to tell a CSV's layout
HEADER_BYTES = 65536

LOGGER = logging.getLogger("citylearn_env.compat")
_NOTICED: set[tuple[str, str]] = set()


@dataclass(frozen=True)
class Mirror:
    """The CityLearn version mirrored (``version`` "2.1" or "2.5"), its ``api`` ("2.1" or "gymnasium"), the
    data-set release folder ``release`` and the ``reason`` it was chosen."""

    version: str
    reason: str

    @property
    def api(self) -> str:
        return MIRRORS[self.version][2]

    @property
    def preset(self) -> str:
        return MIRRORS[self.version][0]

    @property
    def release(self) -> str:
        return MIRRORS[self.version][1]


def parse_version(value: Any, where: str = "citylearn_version") -> str:
    """"2.1" for any CityLearn 2.1.x, "2.5" for 2.2 .. 2.5.x; one SchemaError line otherwise."""
    text = str(value).strip().lstrip("v") if isinstance(value, (str, int, float)) else ""
    parts = text.split(".")
    if len(parts) >= 2 and parts[0] == "2" and parts[1].isdigit() and 1 <= int(parts[1]) <= 5:
        return "2.1" if parts[1] == "1" else "2.5"
    raise SchemaError(f"unknown CityLearn version {value!r}: expected 2.1 (any 2.1.x) or 2.2 .. 2.5", column=where)


def explicit_version(citylearn_version: Any) -> Mirror | None:
    """The version the program chose: the keyword, else ``$DISTRICTGEN_CITYLEARN_VERSION``; None if neither."""
    if citylearn_version is not None:
        return Mirror(parse_version(citylearn_version), "citylearn_version=")
    if os.environ.get(VERSION_VAR):
        return Mirror(parse_version(os.environ[VERSION_VAR], VERSION_VAR), f"${VERSION_VAR}")
    return None


def preset_version(settings: Behaviour | str | None) -> str | None:
    """The version a settings preset names ("citylearn-2.1" -> "2.1", "citylearn-2.5" -> "2.5"), else None."""
    if settings in ("citylearn-2.1", CITYLEARN_2_1):
        return "2.1"
    if settings in ("citylearn-2.5", CITYLEARN_2_5):
        return "2.5"
    return None


def _dynamics_layout(buildings: Mapping[str, Any]) -> str | None:
    for spec in buildings.values():
        dynamics = spec.get("dynamics") if isinstance(spec, Mapping) else None
        if isinstance(dynamics, Mapping) and ("cooling" in dynamics or "heating" in dynamics):
            return "v2.1"
        if isinstance(dynamics, Mapping) and "type" in dynamics:
            return "v2.2"
    return None


def _header_layout(path: Path) -> str | None:
    """"v2.1" or "v2.2" from the header line of a building CSV (None when unreadable or undecided)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            line = f.readline(HEADER_BYTES)
    except OSError:
        return None
    headers = [h.strip().strip('"') for h in line.split(",")]
    old = sum(h in dataset.V21_HEADERS for h in headers)
    new = sum(dataset.NAME_ALIASES.get(h, h) in dataset.TABLES["building"] for h in headers)
    return None if old == new else ("v2.1" if old > new else "v2.2")


def schema_layout(raw: Mapping[str, Any], schema_folder: Path | None) -> str | None:
    """The data-set layout ("v2.1" or "v2.2") of a raw schema whose file lies in ``schema_folder`` (None for a
    dict): its ``dynamics`` blocks, else the header of its first building CSV (read only inside the data-set
    folder); None when neither tells."""
    buildings = raw.get("buildings")
    if not isinstance(buildings, Mapping):
        return None
    found = _dynamics_layout(buildings)
    if found:
        return found
    try:
        folder = paths.dataset_folder(raw.get("root_directory"), schema_folder)
        for spec in buildings.values():
            if isinstance(spec, Mapping) and isinstance(spec.get("energy_simulation"), str):
                return _header_layout(folder.file(spec["energy_simulation"], where="energy_simulation"))
    except SchemaError:  # the load itself reports it
        return None
    return None


def choose(explicit: Mirror | None, layout: str | None, settings: Behaviour | str | None) -> Mirror:
    """The mirrored version: ``explicit``, else the layout's, else a preset's, else 2.5 (module docstring)."""
    if explicit is not None:
        return explicit
    if layout is not None:
        return Mirror("2.1" if layout == "v2.1" else "2.5", f"the data set's {layout} layout")
    named = preset_version(settings)
    if named is not None:
        return Mirror(named, f"settings={settings if isinstance(settings, str) else named!r}")
    return Mirror("2.5", "no layout to tell (default: the current CityLearn)")


def notice(mirror: Mirror) -> None:
    """Say once per process, in one line, which CityLearn version is mirrored and why."""
    key = (mirror.version, mirror.reason)
    if key in _NOTICED:
        return
    _NOTICED.add(key)
    api = ("reset() -> observations, step() -> (observations, reward, done, info)" if mirror.api == "2.1"
           else "gymnasium: reset() -> (observations, info), step() -> 5 values")
    LOGGER.warning("citylearn_env.compat: mirroring CityLearn %s (from %s): %s; %s physics. Choose with "
                   "CityLearnEnv(citylearn_version=...) or $%s.", "2.1.2" if mirror.version == "2.1" else "2.5.0",
                   mirror.reason, api, mirror.preset, VERSION_VAR)


def program_call(depth: int = 2) -> bool:
    """Whether the function ``depth`` frames up was called by the program (not by gymnasium, Stable-Baselines3,
    PettingZoo, ray or this package, which all expect gymnasium's API)."""
    frame = sys._getframe(depth)  # noqa: SLF001 - the caller decides the API form (module docstring)
    name = frame.f_globals.get("__name__") or ""
    return name.split(".", 1)[0] not in GYMNASIUM_CALLERS


def reset_form(api: str, result: tuple[Any, dict], program: bool) -> Any:
    """``(observations, info)`` as the caller expects it: the observations alone for a 2.1 program."""
    return result[0] if api == "2.1" and program else result


def step_form(api: str, result: tuple[Any, Any, bool, bool, dict], program: bool) -> tuple:
    """gymnasium's five step values as the caller expects them: ``(observations, reward, done, info)`` for a 2.1
    program (``done`` = terminated or truncated)."""
    if api == "2.1" and program:
        observations, reward, terminated, truncated, info = result
        return observations, reward, bool(terminated or truncated), info
    return result


__all__ = ["MIRRORS", "Mirror", "VERSION_VAR", "choose", "explicit_version", "notice", "parse_version",
           "preset_version", "program_call", "reset_form", "schema_layout", "step_form"]
