"""The one error type users see for bad input."""

from __future__ import annotations


class InputError(ValueError):
    """Bad input, reported once and clearly: which file, which column or key, which row.

    The CLI prints ``str(error)`` and exits with status 2, never a traceback.
    """

    def __init__(self, message: str, *, file: object = None, column: object = None, row: object = None):
        parts = []
        if file is not None:
            parts.append(f"{file}")
        if column is not None:
            parts.append(f"column/key {column!r}")
        if row is not None:
            parts.append(f"row {row}")
        where = ", ".join(parts)
        super().__init__(f"{where}: {message}" if where else message)
        self.file, self.column, self.row = file, column, row
