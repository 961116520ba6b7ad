"""Errors raised by the environment for bad schemas, data files or actions."""

from __future__ import annotations


class SchemaError(ValueError):
    """A schema, data file or action is invalid.

    The message always says where: the file (or schema key path), the column or key, and the first bad row.
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
