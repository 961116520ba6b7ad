"""CityLearn data set names (mirrors ``citylearn.data``): ``CityLearnEnv("citylearn_challenge_2022_phase_1")``.

Upstream ships its data sets in the wheel (2.1) or downloads them into a cache (2.4+). Here a name resolves,
offline, through a cache folder:

* the root is ``$DISTRICTGEN_CITYLEARN_DATA`` if set, else ``~/.cache/districtgen/citylearn``;
* a data set is ``<root>/<version>/<name>/schema.json`` (``<version>``: ``v2.1.2`` for the CityLearn 2.1 and
  corrected presets, ``v2.4.2`` for the 2.5 preset; see :func:`dataset_version`), else ``<root>/<name>/schema.json``.

Nothing is ever downloaded. :func:`get_dataset` copies a data-set folder you already have (an upstream wheel's
``citylearn/data/<name>``, a git checkout) into the cache; an unknown or absent name is one
:class:`~citylearn_env.errors.SchemaError` line that says where it looked and how to get the data set.
I/O naming: ``get_*`` puts a data set into the cache, ``read_*`` reads files; :class:`DataSet` keeps upstream's
method names.
"""

from __future__ import annotations

import functools
import os
import re
import shutil
from pathlib import Path
from typing import Any

from citylearn_env import paths
from citylearn_env.compat.utilities import read_json
from citylearn_env.compat.version import MIRRORS, VERSION_VAR, parse_version
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_5, Behaviour

#: environment variable naming the cache root
ENV_VAR = "DISTRICTGEN_CITYLEARN_DATA"
#: the cache root when the variable is not set
DEFAULT_ROOT = Path("~/.cache/districtgen/citylearn")
#: upstream release whose data sets each preset reads by default
VERSIONS = {"citylearn-2.1": "v2.1.2", "corrected": "v2.1.2", "citylearn-2.5": "v2.4.2"}
#: what a data-set name may look like (no path separators, no leading dot, at most 200 characters)
NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,199}")
#: the longest schema path or data-set name accepted [characters]
MAX_PATH = 4096


def cache_root() -> Path:
    """The cache root: ``$DISTRICTGEN_CITYLEARN_DATA`` or ``~/.cache/districtgen/citylearn`` (user expanded)."""
    value = os.environ.get(ENV_VAR)
    return Path(value).expanduser() if value else DEFAULT_ROOT.expanduser()


def dataset_version(settings: Behaviour | str | None) -> str:
    """The upstream release folder (``v2.1.2`` or ``v2.4.2``) whose data sets ``settings`` reads: ``v2.4.2`` for
    the CityLearn 2.5 preset, ``v2.1.2`` otherwise."""
    if settings == "citylearn-2.5" or settings is CITYLEARN_2_5:
        return VERSIONS["citylearn-2.5"]
    return VERSIONS["citylearn-2.1"]


def dataset_release(name: str, release: str | None) -> str:
    """The release folder to read data set ``name`` from: ``release`` if given, else the one release folder of
    the cache holding it, else the newest (``v2.4.2``: what a current CityLearn program downloads);
    ``$DISTRICTGEN_CITYLEARN_VERSION`` stands for ``release`` when it is None."""
    if release is None and os.environ.get(VERSION_VAR):
        release = MIRRORS[parse_version(os.environ[VERSION_VAR], VERSION_VAR)][1]
    if release is not None:
        return release
    held = releases_holding(name)
    return held[0] if len(held) == 1 else VERSIONS["citylearn-2.5"]


def releases_holding(name: str) -> list[str]:
    """The release folders of the cache holding data set ``name`` (sorted, oldest first); [] when
    ``$DISTRICTGEN_CITYLEARN_VERSION`` chooses the release."""
    if os.environ.get(VERSION_VAR):
        return []
    return [r for r in sorted(set(VERSIONS.values())) if (cache_root() / r / name / "schema.json").is_file()]


def is_dataset_name(schema: Any) -> bool:
    """Whether ``schema`` reads as a data-set name rather than a file: a string of :data:`NAME`'s form (no path
    separator, no NUL, at most 200 characters) that is not an existing file and has no ``.json`` suffix."""
    if not isinstance(schema, str) or NAME.fullmatch(schema) is None or schema.endswith(".json"):
        return False
    return not Path(schema).is_file()


def candidate_folders(name: str, version: str) -> list[Path]:
    """Where data set ``name`` may lie, in the order they are tried."""
    root = cache_root()
    return [root / version / name, root / name]


def dataset_schema_path(name: str, version: str = "v2.1.2") -> Path:
    """The ``schema.json`` of data set ``name`` in the cache; SchemaError (one line) when it is absent."""
    if not isinstance(name, str) or NAME.fullmatch(name) is None:
        shown = repr(name[:60]) + ("..." if len(name) > 60 else "") if isinstance(name, str) else type(name).__name__
        raise SchemaError(f"not a CityLearn data-set name: {shown} (letters, digits, _ . -; at most 200)",
                          column="schema")
    folders = candidate_folders(name, version)
    for folder in folders:
        if (folder / "schema.json").is_file():
            return folder / "schema.json"
    known = read_dataset_names(version)
    hint = f"; cached data sets: {', '.join(known)}" if known else ""
    raise SchemaError(
        f"unknown or absent CityLearn data set {name!r}: no schema.json in {' or '.join(map(str, folders))}"
        f"{hint}. Nothing is downloaded: copy the data-set folder there (citylearn_env.compat.data.get_dataset"
        f"(name, source=FOLDER), e.g. from the citylearn 2.1.2 wheel's citylearn/data/{name}) or set {ENV_VAR} "
        f"to a folder holding {version}/{name}/schema.json", column="schema")


def read_dataset_names(version: str = "v2.1.2") -> list[str]:
    """Names of the data sets in the cache for ``version`` (sorted; folders with a ``schema.json``)."""
    names: set[str] = set()
    for folder in (cache_root() / version, cache_root()):
        if folder.is_dir():
            names |= {p.name for p in folder.iterdir() if (p / "schema.json").is_file()}
    return sorted(names)


def read_dataset_schema(name: str, version: str = "v2.1.2") -> dict[str, Any]:
    """The schema dict of data set ``name`` with ``root_directory`` made the absolute data-set folder (as
    upstream's ``DataSet.get_schema``)."""
    path = dataset_schema_path(name, version)
    schema = read_json(path)
    if not isinstance(schema, dict):
        raise SchemaError("a schema file holds one JSON object", file=path)
    try:  # a root_directory leaving the data-set folder is refused, never returned
        found = paths.dataset_folder(schema.get("root_directory"), path.parent.resolve())
    except SchemaError as error:
        raise SchemaError(str(error), file=path) from None
    schema["root_directory"] = str(found.root.resolve())
    return schema


def get_dataset(name: str, source: str | Path, version: str = "v2.1.2", *, overwrite: bool = False) -> Path:
    """Copy the data-set folder ``source`` (it holds ``schema.json``) into the cache as ``<root>/<version>/<name>``
    and return the cached ``schema.json``. An existing cached copy is kept unless ``overwrite``."""
    if not isinstance(name, str) or NAME.fullmatch(name) is None:
        raise SchemaError(f"not a CityLearn data-set name: {name!r}", column="name")
    source = Path(source)
    if not (source / "schema.json").is_file():
        raise SchemaError("not a CityLearn data-set folder (no schema.json in it)", file=source)
    target = cache_root() / version / name
    if target.exists() and overwrite:
        shutil.rmtree(target)
    if not target.exists():
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copytree(source, target)
    return target / "schema.json"


class either:  # noqa: N801 - a decorator, named as staticmethod/classmethod are
    """A method callable on the class (upstream 2.1's static ``DataSet.get_schema(name)``) or on an instance
    (2.4's ``DataSet().get_schema(name)``); on the class, ``self`` is a default ``DataSet()``."""

    def __init__(self, function: Any) -> None:
        self.function = function
        self.__doc__ = function.__doc__

    def __get__(self, instance: Any, owner: type) -> Any:
        return functools.partial(self.function, owner() if instance is None else instance)


class DataSet:
    """Upstream's data-set catalogue, read from the cache (no download). ``version``: the release folder (None:
    per name, the one release holding it, else the newest; :func:`dataset_release`). Every method works on the
    class too (CityLearn 2.1's static calls)."""

    def __init__(self, version: str | None = None) -> None:
        self.version = version

    @either
    def get_dataset_names(self) -> list[str]:
        """Names of the cached data sets (upstream 2.4's name)."""
        if self.version is not None or os.environ.get(VERSION_VAR):
            return read_dataset_names(dataset_release("", self.version))
        return sorted({n for r in set(VERSIONS.values()) for n in read_dataset_names(r)})

    @either
    def get_names(self) -> list[str]:
        """Names of the cached data sets (upstream 2.1's name)."""
        return self.get_dataset_names()

    @either
    def get_schema(self, name: str) -> dict[str, Any]:
        """The schema dict of data set ``name``, ``root_directory`` set to its folder (never one outside it)."""
        return read_dataset_schema(name, dataset_release(name, self.version))


__all__ = ["MAX_PATH", "DataSet", "cache_root", "dataset_release", "releases_holding", "dataset_schema_path", "dataset_version", "get_dataset", "is_dataset_name",
           "read_dataset_names", "read_dataset_schema"]
