"""CLI sub-commands ``districtgen surrogate train|evaluate``."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the surrogate sub-commands to ``districtgen``."""
