"""Downloads into a local cache, with length and checksum checks. The only module here that uses the network.

Cache layout: ``<cache_dir>/<host>/<url path>`` plus a ``<file>.sha256`` sidecar written only after the
file is complete and verified. A download goes to a temporary file in the same folder and is renamed into
place only when the byte count matches ``Content-Length`` and the SHA-256 matches the expected one (when
known), so the cache never holds a partial or wrong file. A cached file whose sidecar is missing or does
not match is fetched again.
"""

from __future__ import annotations

import hashlib
import http.client
import os
import tempfile
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

from pipeline.errors import InputError

CHUNK = 1 << 20
CHECKSUM_FILE = "SHA256SUMS"


def sha256_of(path: str | Path) -> str:
    """Hex SHA-256 of a file."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(CHUNK), b""):
            digest.update(block)
    return digest.hexdigest()


def cache_path(url: str, cache_dir: str | Path) -> Path:
    """Where ``url`` is cached under ``cache_dir``."""
    parts = urllib.parse.urlsplit(url)
    host = parts.netloc.replace(":", "_") or "local"
    relative = [p for p in urllib.parse.unquote(parts.path).split("/") if p not in ("", ".", "..")]
    return Path(cache_dir, host, *relative)


def get_file(url: str, cache_dir: str | Path, *, sha256: str | None = None, timeout: float = 60.0) -> Path:
    """Return the cached copy of ``url``, downloading it first if needed.

    Raises InputError (naming the URL) for HTTP errors, truncated downloads and checksum mismatches; the
    cache is left without the file in every error case.
    """
    target = cache_path(url, cache_dir)
    sidecar = target.with_name(target.name + ".sha256")
    if target.exists() and sidecar.exists():
        recorded = sidecar.read_text().split()[0] if sidecar.read_text().strip() else ""
        actual = sha256_of(target)
        if actual == recorded and (sha256 is None or actual == sha256.lower()):
            return target
    target.unlink(missing_ok=True)
    sidecar.unlink(missing_ok=True)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    try:
        digest, size, expected = _download(url, handle, timeout)
        if expected is not None and size != expected:
            raise InputError(f"truncated download: received {size} of {expected} bytes", file=url)
        if sha256 is not None and digest != sha256.lower():
            raise InputError(f"checksum mismatch: SHA-256 {digest}, expected {sha256.lower()}", file=url)
        os.replace(temp, target)
        sidecar.write_text(f"{digest}  {target.name}\n")
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise
    return target


def get_checksums(base_url: str, cache_dir: str | Path, timeout: float = 60.0) -> dict[str, str]:
    """Expected SHA-256 per relative path from ``<base_url>/SHA256SUMS`` (``sha256sum`` format).

    Returns an empty dict when the server has no such file (HTTP 404/403): downloads are then checked for
    length only.
    """
    url = join_url(base_url, CHECKSUM_FILE)
    try:
        path = get_file(url, cache_dir, timeout=timeout)
    except InputError as error:
        if "HTTP 404" in str(error) or "HTTP 403" in str(error):
            return {}
        raise
    sums = {}
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        fields = line.split(maxsplit=1)
        if len(fields) != 2 or len(fields[0]) != 64:
            cache_path(url, cache_dir).unlink(missing_ok=True)
            raise InputError("expected '<sha256>  <relative path>'", file=url, row=number)
        sums[fields[1].strip().lstrip("*").lstrip("./")] = fields[0].lower()
    return sums


def join_url(base: str, relative: str) -> str:
    """``base`` + ``/`` + ``relative`` with each path segment quoted."""
    quoted = "/".join(urllib.parse.quote(part, safe="=") for part in relative.split("/"))
    return base.rstrip("/") + "/" + quoted


def _download(url: str, handle: int, timeout: float) -> tuple[str, int, int | None]:
    digest = hashlib.sha256()
    size = 0
    try:
        with os.fdopen(handle, "wb") as out, urllib.request.urlopen(url, timeout=timeout) as response:
            length = response.headers.get("Content-Length")
            expected = int(length) if length and length.isdigit() else None
            while True:
                try:
                    block = response.read(CHUNK)
                except http.client.IncompleteRead as error:
                    size += len(error.partial)
                    raise InputError(f"truncated download: received {size} of {expected} bytes",
                                     file=url) from None
                if not block:
                    break
                out.write(block)
                digest.update(block)
                size += len(block)
    except urllib.error.HTTPError as error:
        raise InputError(f"download failed: HTTP {error.code} {error.reason}", file=url) from None
    except (urllib.error.URLError, TimeoutError, ConnectionError, http.client.HTTPException) as error:
        raise InputError(f"download failed: {error}", file=url) from None
    return digest.hexdigest(), size, expected
