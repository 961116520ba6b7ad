"""Errors for bad input, shared by every part of districtgen (this package depends on nothing else).

Each message says where: the file (or schema key path), the column or key, and the first bad row, in one line
(a message quoting a library's multi-line text is joined into one).
"""

from __future__ import annotations


class LocatedError(ValueError):
    """A ValueError whose message starts with the location of the problem: file, column/key, row."""

    def __init__(self, message: str, *, file: object = None, column: object = None, row: object = None):
        parts = []
        if file is not None:
            parts.append(_printable(f"{file}"))
        if column is not None:
            parts.append(f"column/key {column!r}")
        if row is not None:
            parts.append(f"row {_printable(str(row))}")
        where = ", ".join(parts)
        message = " ".join(line.strip() for line in str(message).splitlines() if line.strip())  # one line
        super().__init__(f"{where}: {message}" if where else message)
        self.file, self.column, self.row = file, column, row


def _printable(text: str) -> str:
    """``text`` with each non-printable character (a newline in a file name, say) written as its escape
    (``\\n``): the location stays on the message's one line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class SchemaError(LocatedError):
    """A schema, data file or action given to the environment is invalid."""


class InputError(LocatedError):
    """A raw input of the pipeline or the surrogates (EULP, weather, tariff, fuel mix, ILV table, FMU, ...)
    is invalid. The CLI prints ``str(error)`` and exits with status 2, never a traceback."""


class DynamicsError(SchemaError):
    """A building's temperature model produced what no building can be (an indoor temperature outside the
    physical range): its weights or normalisation do not belong to this building. The episode stops."""
