"""A content-addressed cache of trained surrogates: plain files, checked by sha256, written atomically.

Layout: ``<root>/surrogates/<key>/`` holds a trained surrogate's files (``Building_1.pth``,
``surrogates/Building_1.dynamics.json``, ``.metrics.json``, ``.png``, ``.ilv.parquet``: the training table),
``<root>/judgements/<key>/`` a judge's record (``judge.json``), ``<root>/simulations/<key>/`` a house's
EnergyPlus pass; every entry folder also holds ``entry.json``::

    {"key": "<64 hex>", "files": {"<relative path>": {"sha256": "<64 hex>", "bytes": n}, ...},
     "inputs": {... what the key was computed from, for people ...}}

``root`` is, in order: an explicit argument (build configuration ``cache_dir`` or ``districtgen build
--cache-dir``), the environment variable ``DISTRICTGEN_CACHE_DIR``, ``~/.cache/districtgen``.

An entry is used only when ``entry.json`` parses, names the same key, and every listed file exists under the
entry folder with the listed sha256; anything else is a miss and the entry is rebuilt. Entries are written to
a temporary sibling folder and renamed into place. Nothing is pickled: the cache holds bytes and JSON only.
The key is the sha256 of a canonical JSON of its parts (see :func:`cache_key`); what goes into it for a
surrogate is decided by :func:`pipeline.builder.surrogates.surrogate_cache_parts`, for a judgement by
:func:`pipeline.builder.surrogates.judge_cache_parts`.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import uuid
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from pipeline.builder.staging import write_new_file

CACHE_ENV = "DISTRICTGEN_CACHE_DIR"
ENTRY = "entry.json"


def cache_root(explicit: str | os.PathLike | None = None) -> Path:
    """The cache root: ``explicit``, else ``$DISTRICTGEN_CACHE_DIR``, else ``~/.cache/districtgen``."""
    if explicit is not None:
        return Path(explicit).expanduser()
    env = os.environ.get(CACHE_ENV)
    return Path(env).expanduser() if env else Path.home() / ".cache" / "districtgen"


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def cache_key(parts: Mapping[str, object]) -> str:
    """sha256 (hex) of the canonical JSON of ``parts`` (sorted keys, no whitespace; values JSON-able)."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return sha256_bytes(text.encode())


def files_digest(paths: Iterable[Path], base: Path) -> str:
    """sha256 over the bytes of source files (with their paths relative to ``base``), in the given order."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(str(Path(path).relative_to(base)).encode() + b"\0")
        digest.update(Path(path).read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()



def _safe_relative(name: str) -> bool:
    """A relative path inside the entry folder (no absolute path, no ``..``, no empty parts)."""
    path = PurePosixPath(name)
    return bool(name) and not path.is_absolute() and "\\" not in name and all(
        part not in ("", ".", "..") for part in path.parts) and name != ENTRY


@dataclass(frozen=True)
class FileCache:
    """Entries of plain files under ``folder/<key>/`` (``folder`` = ``<root>/surrogates`` for surrogates)."""

    folder: Path

    def get(self, key: str, owns: Callable[[str], bool] | None = None) -> dict[str, bytes] | None:
        """The verified files of entry ``key`` (relative path -> bytes), or None (absent or not intact).

        ``owns(relative path)``: which files an entry of this kind may hold; an entry listing any other (a
        district data file such as ``weather.csv``) is not intact, and is rebuilt."""
        entry = self.folder / key
        try:
            listing = json.loads((entry / ENTRY).read_text())
            files = listing["files"]
            if listing.get("key") != key or not isinstance(files, dict) or not files:
                return None
            out = {}
            for name, meta in files.items():
                if not _safe_relative(name) or (owns is not None and not owns(name)):
                    return None
                data = (entry / name).read_bytes()
                if sha256_bytes(data) != meta["sha256"]:
                    return None
                out[name] = data
            return out
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def put(self, key: str, files: Mapping[str, bytes], inputs: Mapping[str, object] | None = None) -> Path:
        """Store ``files`` as entry ``key`` (replacing a damaged one); returns the entry folder.

        Written into ``.<key>.tmp-*`` and renamed; when another process stored the same key meanwhile, its
        entry is kept and ours discarded (same key, same content).
        """
        bad = [name for name in files if not _safe_relative(name)]
        if bad:
            raise ValueError(f"cache file names must be relative paths inside the entry: {bad}")
        self.folder.mkdir(parents=True, exist_ok=True)
        final = self.folder / key
        tmp = self.folder / f".{key}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        tmp.mkdir()
        try:
            listing = {"key": key, "files": {}, "inputs": dict(inputs or {})}
            for name, data in files.items():
                path = tmp / name
                path.parent.mkdir(parents=True, exist_ok=True)
                write_new_file(path, data)  # a new file in our folder, never through a link
                listing["files"][name] = {"sha256": sha256_bytes(data), "bytes": len(data)}
            (tmp / ENTRY).write_text(json.dumps(listing, indent=2, sort_keys=True, default=str))
            if final.exists():  # damaged (we only put after a failed get): move it aside
                old = self.folder / f".{key}.old-{os.getpid()}-{uuid.uuid4().hex[:8]}"
                try:
                    final.rename(old)
                except OSError:
                    pass
                shutil.rmtree(old, ignore_errors=True)
            try:
                tmp.rename(final)
            except OSError:  # a concurrent writer won the race
                if self.get(key) is None:
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return final
