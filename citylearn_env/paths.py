"""Dataset paths stay inside the dataset folder.

A schema names its data files (CSVs, LSTM weights) relative to ``root_directory``. A schema may come from
someone else, so every file it names must lie inside its *dataset folder*:

* a schema file: the folder holding ``schema.json``; ``root_directory`` (if given) must lie inside it;
* a schema dict: ``root_directory`` as given (the caller chose it), else the current folder.

Paths are resolved (``..`` collapsed, symlinks followed) before the check, so a ``../`` file name, an
absolute file name or ``root_directory`` elsewhere, and a symlink that points out of the folder are all
refused with one :class:`~citylearn_env.errors.SchemaError` naming the schema key, without reading the file
(so no message ever quotes a file outside the folder). ``allow_outside=True``
(``load_schema(path, allow_outside_paths=True)``) lifts the rule for a schema you trust.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from citylearn_env.errors import SchemaError


def is_inside(path: Path, folder: Path) -> bool:
    """Whether resolved ``path`` is ``folder`` or lies below resolved ``folder`` (both resolved here)."""
    path, folder = Path(path).resolve(), Path(folder).resolve()
    return path == folder or folder in path.parents


@dataclass(frozen=True)
class DatasetFolder:
    """Where a schema's files may come from: ``folder`` (the confinement), ``root`` (what relative names
    join to: ``root_directory`` or the folder), ``allow_outside`` (no confinement)."""

    folder: Path
    root: Path
    allow_outside: bool = False

    def file(self, name: Any, *, where: str) -> Path:
        """The path of data file ``name`` (a schema value at key ``where``), joined to :attr:`root`, checked to
        lie inside the folder and then to exist."""
        if not isinstance(name, str) or not name.strip():
            raise SchemaError(f"expected a file name (a non-empty string), got {name!r}", column=where)
        path = self.check(self.root / name, where=where)
        if not path.is_file():
            raise SchemaError(f"data file not found (names resolve against root_directory {self.root})", file=path,
                              column=where)
        return path

    def check(self, path: str | Path, *, where: str) -> Path:
        """``path`` (absolute, or relative to the current folder) if it lies inside :attr:`folder`."""
        if "\x00" in str(path):
            raise SchemaError("a path must not contain a NUL character", column=where)
        path = Path(path)
        try:
            inside = self.allow_outside or is_inside(path, self.folder)
        except (OSError, RuntimeError) as error:  # a symlink loop, a name too long
            raise SchemaError(f"not a usable path ({error})", column=where) from None
        if not inside:
            raise SchemaError(f"points outside the dataset folder {self.folder} ('..', an absolute path or a "
                              "symlink); pass allow_outside_paths=True to load_schema to allow it", column=where)
        return path


def dataset_folder(root_directory: Any, schema_folder: Path | None, *, allow_outside: bool = False
                   ) -> DatasetFolder:
    """The :class:`DatasetFolder` of a schema: ``schema_folder`` is the schema file's folder (None for a dict).

    ``root_directory`` must be null or a string; for a schema file it must lie inside ``schema_folder``
    (relative values join to it).
    """
    if root_directory is not None and not isinstance(root_directory, str):
        raise SchemaError(f"expected a folder name or null, got {root_directory!r}", column="root_directory")
    if schema_folder is None:
        root = Path(root_directory) if root_directory else Path.cwd()
        return DatasetFolder(root.resolve(), root, allow_outside)
    root = schema_folder / root_directory if root_directory else schema_folder
    found = DatasetFolder(schema_folder.resolve(), root, allow_outside)
    found.check(root, where="root_directory")
    return found


__all__ = ["DatasetFolder", "dataset_folder", "is_inside"]
