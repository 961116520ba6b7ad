"""JSON helpers with upstream's names (mirrors ``citylearn.utilities``: ``read_json``, ``write_json``)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def read_json(filepath: str | Path, **kwargs: Any) -> Any:
    """The parsed content of the JSON file ``filepath`` (``kwargs`` go to :func:`json.load`)."""
    with open(filepath, encoding="utf-8") as f:
        return json.load(f, **kwargs)


def _plain(value: Any) -> Any:
    """``value`` with numpy scalars and arrays turned into Python numbers and lists, NaN and infinities into
    None (upstream writes with ``ignore_nan``), recursively."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(filepath: str | Path, dictionary: Any, **kwargs: Any) -> None:
    """Write ``dictionary`` to ``filepath`` as indented JSON: numpy values become plain numbers, NaN and infinite
    floats become null, anything else unknown is written as its ``str`` (upstream's ``default``)."""
    kwargs = {"indent": 2, "default": str, **kwargs}
    with open(filepath, "w", encoding="utf-8") as f:
        json.dump(_plain(dictionary), f, **kwargs)


__all__ = ["read_json", "write_json"]
