"""Shared test settings: where ../shared is, and quiet, isolated Prefect settings."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
DATASET = SHARED / "data" / "citylearn" / "citylearn_challenge_2023_phase_3_1-v2.1"
GOLDEN = SHARED / "reference" / "citylearn-2.1.2"

# Prefect: never touch ~/.prefect, no telemetry, quiet logs (must be set before prefect is imported).
if "PREFECT_HOME" not in os.environ:
    os.environ["PREFECT_HOME"] = tempfile.mkdtemp(prefix="prefect_home_")
    atexit.register(shutil.rmtree, os.environ["PREFECT_HOME"], ignore_errors=True)
os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_LOGGING_LEVEL", "WARNING")
os.environ.setdefault("PREFECT_SERVER_DATABASE_CONNECTION_URL", "sqlite+aiosqlite:///:memory:")
# the ephemeral API server starts slowly on 2 busy cores (default timeout 20 s)
os.environ.setdefault("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", "180")


#: Python source that makes the top-level packages named in ``sys.argv[1]`` (comma-separated) unimportable, as
#: in an install without them; a test appends what it runs (``python -c BLOCK_IMPORTS + "..." NAMES ...``)
BLOCK_IMPORTS = """
import importlib.abc, sys
BLOCKED = set(sys.argv[1].split(","))
class Missing(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Missing())
"""


def need_shared(*paths: Path) -> None:
    """Skip the calling test when a ../shared file it needs is absent (fresh clone without shared/)."""
    for path in paths:
        if not path.exists():
            pytest.skip(f"../shared data not present: {path} (tests on real data need the shared folder)")
