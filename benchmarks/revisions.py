"""A module of this repository as it was at a git revision: the anchor of the side-by-side benchmarks
(``paper_speed.py revision``, ``surrogate_train_speed.py``)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def source_at(revision: str, path: str) -> str:
    """The text of ``path`` (relative to the repository root) at git ``revision``."""
    return subprocess.run(["git", "show", f"{revision}:{path}"], cwd=ROOT, check=True, capture_output=True,
                          text=True).stdout


def import_source(name: str, source: str, folder: Path) -> ModuleType:
    """Import ``source`` as module ``name`` (written to ``folder/<name>.py`` and registered in sys.modules, so
    other revision modules can import it by that name)."""
    path = Path(folder) / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
