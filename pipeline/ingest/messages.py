"""Turning library exceptions into the one-line text of an InputError."""

from __future__ import annotations


def one_line(error: BaseException) -> str:
    """``str(error)`` on a single line (pandas and pyarrow messages often carry newlines)."""
    return " ".join(str(error).split())
