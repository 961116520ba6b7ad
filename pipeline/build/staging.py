"""The build's staging folder: written beside the district and renamed into place only when complete.
"""

from __future__ import annotations

import glob
import json
import os
import re
import shutil
from pathlib import Path

from pipeline.config import NAME_PATTERN, BuildConfig
from pipeline.errors import InputError


class staging:
    """Context manager: a hidden sibling folder ``.<name>.building-<pid>`` that replaces ``root/<name>`` only
    on success. It only ever creates, renames or deletes what a build created:

    * ``root`` must be a folder (created if missing); ``root/<name>`` may be replaced only when it is a
      districtgen build of the same name (a folder with a ``manifest.json`` naming it), never a symlink;
    * each staging folder has an ownership mark beside it (``.<name>.building-<pid>.districtgen``, JSON with the
      pid); a staging folder whose mark names a process that is gone (a killed build) is deleted on the next
      build of that name, as is a ``.<name>.old-<pid>`` that holds a districtgen build of that name.

    Problems are one :class:`~pipeline.errors.InputError` naming the folder and key ``name``/``output_root``.
    """

    def __init__(self, config: BuildConfig, root: str | Path):

        if not isinstance(config.name, str) or not re.fullmatch(NAME_PATTERN, config.name):  # model_copy skips it
            raise InputError("not a safe district name (a slug of letters, digits, '_', '-', '.')",
                             file=config.source, column="name")
        self.root, self.name = Path(root), config.name
        self.final = self.root / config.name
        self.tmp = self.root / f".{config.name}.building-{os.getpid()}"
        self.mark = self.tmp.with_name(self.tmp.name + ".districtgen")

    def __enter__(self) -> Path:
        self.check()
        self._clean_stale()
        try:
            self.mark.write_text(json.dumps({"pid": os.getpid(), "district": self.name}))
            self.tmp.mkdir()
        except OSError as error:
            self.mark.unlink(missing_ok=True)
            raise InputError(f"cannot write into the output folder: {error.strerror or error}", file=self.root,
                             column="output_root") from None
        return self.tmp

    def check(self) -> None:
        """Create the output root if missing; refuse a root that is a file and a final folder that is not ours."""
        if self.root.exists() and not self.root.is_dir():
            raise InputError("the output folder is a file", file=self.root, column="output_root")
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError(f"cannot create the output folder: {error.strerror or error}", file=self.root,
                             column="output_root") from None
        if (self.final.exists() or self.final.is_symlink()) and not is_build(self.final, self.name):
            raise InputError("exists and is not a districtgen build of this name: not replaced (move it away or "
                             "choose another name)", file=self.final, column="name")

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is not None:
                shutil.rmtree(self.tmp, ignore_errors=True)
                return
            swap_in(self.tmp, self.final)
        finally:
            self.mark.unlink(missing_ok=True)

    def _clean_stale(self) -> None:
        """Delete what killed builds of this name left: marked staging folders of dead processes, old builds."""
        for mark in self.root.glob(f".{glob.escape(self.name)}.building-*.districtgen"):
            folder = mark.with_name(mark.name[: -len(".districtgen")])
            try:
                pid = int(json.loads(mark.read_text())["pid"])
            except (OSError, ValueError, KeyError, TypeError):
                continue
            if folder.name != f".{self.name}.building-{pid}" or (pid != os.getpid() and process_alive(pid)):
                continue
            if folder.is_dir() and not folder.is_symlink():
                shutil.rmtree(folder, ignore_errors=True)
            mark.unlink(missing_ok=True)
        for old in self.root.glob(f".{glob.escape(self.name)}.old-*"):
            if is_build(old, self.name):
                shutil.rmtree(old, ignore_errors=True)


def is_build(folder: Path, name: str) -> bool:
    """Whether ``folder`` is a real folder (no symlink) holding a districtgen build of district ``name``."""
    try:
        return (not folder.is_symlink() and folder.is_dir()
                and json.loads((folder / "manifest.json").read_text()).get("district") == name)
    except (OSError, ValueError, AttributeError):
        return False


def process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def swap_in(new: Path, final: Path) -> None:
    """Put the folder ``new`` (a sibling) under the name ``final``: the old folder (if any) is renamed aside to
    ``.<name>.old-<pid>``, the new one in, the old one deleted; the old one is put back when the second rename
    fails. Every writer of a district (the build, ``surrogate install``) replaces it through here."""
    old = final.with_name(f".{final.name}.old-{os.getpid()}")
    had_old = final.exists()
    if had_old:
        final.rename(old)
    try:
        new.rename(final)
    except OSError:
        if had_old:
            old.rename(final)
        raise
    shutil.rmtree(old, ignore_errors=True)
