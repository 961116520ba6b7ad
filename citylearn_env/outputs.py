"""Where a command may write, and how: the one rule of every writer outside a build.

A command's output (``paper -o``, ``optimal -o``, ``select -o``, ``surrogate train -o``, the ingest commands'
``-o``) lands in a folder the user named. That folder may be shared, so someone may have planted a symbolic link
at the very name the command is about to write; and it may be a built district, which only ``build`` and
``surrogate install`` change (through their staging copies). The rule:

* an output folder is a real folder (created if missing, never a symlink) that is not inside a built district
  (:func:`output_folder`, :func:`check_not_district`); a district is a folder holding ``manifest.json`` and
  ``manifest.sha256``;
* a name that becomes a path (a building, an id, a benchmark key) is a slug (:func:`check_slug`): no ``/``, no
  ``..``, no leading dot;
* every file is written as a NEW file beside its name (``O_CREAT | O_EXCL | O_NOFOLLOW``, mode 0644) and renamed
  over the name when complete (:func:`open_output`): a link at the name is refused in one line naming it, and one
  planted in between is replaced, never written through; a failed write leaves nothing.

Problems are one :class:`~citylearn_env.errors.InputError` naming the path and the option. This module lives in
the environment package (beside :mod:`citylearn_env.paths`, its reading counterpart) because every package
writes through it and the environment is the one all others may import.
"""

from __future__ import annotations

import os
import re
import secrets
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

from citylearn_env.errors import InputError

#: a name that may become a file or folder name: starts with a letter or digit, then letters, digits, ``_.-``
SLUG = r"[A-Za-z0-9][A-Za-z0-9_.-]{0,127}"
#: the two files that make a folder a built district (written by ``build`` and ``surrogate install`` only)
DISTRICT_MARKS = ("manifest.json", "manifest.sha256")
#: ``O_NOFOLLOW`` where the OS has it (0 elsewhere)
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)


def check_slug(name: Any, *, column: str, file: object = None) -> str:
    """``name`` if it is a slug (:data:`SLUG`), else one :class:`InputError` naming ``column``."""
    if not isinstance(name, str) or not re.fullmatch(SLUG, name) or ".." in name:
        raise InputError(f"{name!r} is not a safe name: it becomes a file name, so it must be letters, digits, "
                         "'_', '-', '.' (starting with a letter or digit, no '..')", file=file, column=column)
    return name


def is_district(folder: Path) -> bool:
    """Whether ``folder`` is a built district (:data:`DISTRICT_MARKS` both present)."""
    return all((folder / mark).exists() for mark in DISTRICT_MARKS)


def check_not_district(path: str | os.PathLike, *, column: str | None = None) -> None:
    """Refuse (one line) to write at ``path`` when it (resolved: links followed) is a built district or lies
    inside one: only ``build`` and ``surrogate install`` write there."""
    try:
        resolved = Path(path).resolve()
    except (OSError, RuntimeError) as error:
        raise InputError(f"not a usable output path ({error})", file=path, column=column) from None
    for folder in (resolved, *resolved.parents):
        if is_district(folder):
            raise InputError(f"is {'inside ' if folder != resolved else ''}the built district {folder}: only "
                             "'build' and 'surrogate install' write there (choose an output outside it)",
                             file=path, column=column)


def output_folder(path: str | os.PathLike, *, column: str, create: bool = True) -> Path:
    """The output folder ``path``, created (with its parents) if missing (unless not ``create``: checked only):
    refused (one line) when it is a symbolic link, a file, or a built district or inside one
    (:func:`check_not_district`). Returns the path."""
    folder = Path(path)
    if folder.is_symlink():
        raise InputError("the output folder is a symbolic link: not written through (give the real folder)",
                         file=folder, column=column)
    check_not_district(folder, column=column)
    if folder.exists() and not folder.is_dir():
        raise InputError("the output folder is a file", file=folder, column=column)
    if not create:
        return folder
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"cannot create the output folder: {error.strerror or error}", file=folder,
                         column=column) from None
    return folder


def output_file(path: str | os.PathLike, *, column: str) -> tuple[Path, str]:
    """The folder (:func:`output_folder`) and name of a single output file ``path``; refused when the name is a
    link (:func:`check_output_name`), a folder, or in a built district."""
    path = Path(path)
    if not path.name or path.name in (".", ".."):
        raise InputError("not a file name", file=path, column=column)
    check_not_district(path, column=column)
    folder = output_folder(path.parent, column=column)
    check_output_name(folder, path.name, column=column)
    if (folder / path.name).is_dir():
        raise InputError("is a folder, not a file", file=path, column=column)
    return folder, path.name


def check_output_name(folder: Path, name: str, *, column: str | None = None) -> Path:
    """``folder / name`` if no symbolic link stands at it (else one line naming it: a planted link is refused,
    never written through)."""
    target = folder / name
    if target.is_symlink():
        raise InputError("a symbolic link stands at this output name: not written through (remove it)",
                         file=target, column=column)
    return target


@contextmanager
def open_output(folder: str | os.PathLike, name: str, mode: str = "w", *, column: str | None = None,
                **kwargs: Any) -> Iterator[IO[Any]]:
    """Write ``folder / name`` (``name`` one path component): yields a stream on a NEW sibling file (O_CREAT | O_EXCL |
    O_NOFOLLOW, mode 0644) that replaces ``name`` when the block ends without error; a link at ``name`` is refused
    in one line, and nothing is left when the block fails. ``mode``: ``"w"`` (text) or ``"wb"``; ``kwargs`` go to
    :func:`os.fdopen` (``newline``, ``encoding``)."""
    folder = Path(folder)
    if not name or name in (".", "..") or "/" in name or os.sep in name or "\x00" in name:
        raise InputError(f"{name!r} is not a file name inside the output folder", file=folder, column=column)
    target = check_output_name(folder, name, column=column)
    temp = folder / f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    handle = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW, 0o644)
    try:
        with os.fdopen(handle, mode, **kwargs) as stream:
            yield stream
        os.chmod(temp, 0o644)  # whatever the umask
        os.replace(temp, target)  # a link planted at the name meanwhile is replaced, never followed
    except BaseException:
        temp.unlink(missing_ok=True)
        raise


def write_output(folder: str | os.PathLike, name: str, data: str | bytes | Callable[[IO[Any]], object], *,
                 binary: bool = False, column: str | None = None) -> Path:
    """Write ``data`` (text, bytes, or a function writing to a stream: a text stream with ``newline=""``, or a
    binary one when ``binary``) to ``folder / name`` through :func:`open_output`; returns the path."""
    binary = binary or isinstance(data, bytes)
    extra = {} if binary else {"newline": "", "encoding": "utf-8"}
    with open_output(folder, name, "wb" if binary else "w", column=column, **extra) as stream:
        if callable(data):
            data(stream)
        else:
            stream.write(data)
    return Path(folder) / name


__all__ = ["SLUG", "check_not_district", "check_output_name", "check_slug", "is_district", "open_output",
           "output_file", "output_folder", "write_output"]
