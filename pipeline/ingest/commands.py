"""CLI sub-commands that write CityLearn input files (weather, tariff, carbon, eulp)."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ingest sub-commands to ``districtgen``."""
