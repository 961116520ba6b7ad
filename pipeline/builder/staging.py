"""The build's staging folder: written beside the district and renamed into place only when complete.
"""

from __future__ import annotations

import ctypes
import errno
import functools
import glob
import json
import os
import re
import shutil
import signal
import stat
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from pipeline.config import NAME_PATTERN, BuildConfig
from pipeline.errors import InputError


class staging:
    """Context manager: a hidden sibling folder ``.<name>.building-<pid>`` that replaces ``root/<name>`` only
    on success. It only ever creates, renames or deletes what a build created:

    * ``root`` must be a folder (created if missing); ``root/<name>`` may be replaced only when it is a
      districtgen build of the same name (a folder with a ``manifest.json`` naming it), never a symlink;
    * the staging folder is created mode 0700 and must hold no symbolic link when it is put in place
      (:func:`check_no_links`), so every file written into it stays inside it;
    * each staging folder has an ownership mark beside it (``.<name>.building-<pid>.districtgen``, JSON with the
      pid); a staging folder whose mark names a process that is gone (a killed build) is deleted on the next
      build of that name, as is every other leftover of a killed writer (:func:`clean_leftovers`);
    * the new version replaces the old in one atomic step (:func:`swap_in`).

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
        clean_leftovers(self.root, self.name, finished=os.getpid())  # a killed build's, or this process's own
        try:
            write_new_file(self.mark, json.dumps({"pid": os.getpid(), "district": self.name}))
            self.tmp.mkdir(mode=PRIVATE_MODE)  # nobody else can plant a link in it, whatever the umask
        except OSError as error:
            self.mark.unlink(missing_ok=True)
            raise InputError(f"cannot write into the output folder: {error.strerror or error}", file=self.root,
                             column="output_root") from None
        self.signals = exit_on_signals()
        self.signals.__enter__()  # SIGTERM / SIGHUP end the build through __exit__: the staging copy is deleted
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
        check_not_inside(self.final.resolve(), column="output_root")
        if (self.final.exists() or self.final.is_symlink()) and not is_build(self.final, self.name):
            raise InputError("exists and is not a districtgen build of this name: not replaced (move it away or "
                             "choose another name)", file=self.final, column="name")

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None:
                check_no_links(self.tmp)
                swap_in(self.tmp, self.final)
        except InputError:
            shutil.rmtree(self.tmp, ignore_errors=True)  # links are removed, never followed
            raise
        finally:
            if exc_type is not None:
                shutil.rmtree(self.tmp, ignore_errors=True)
            self.mark.unlink(missing_ok=True)
            self.signals.__exit__(None, None, None)


@contextmanager
def exit_on_signals() -> Iterator[None]:
    """Within the block, SIGTERM and SIGHUP raise :class:`SystemExit` (status 128 + the signal), so ``finally``
    blocks and context managers clean up as on Ctrl-C; the previous handlers are restored after it. Only in the
    main thread (elsewhere signals cannot be handled: nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def leave(signum, frame):
        raise SystemExit(128 + signum)

    previous = {sig: signal.signal(sig, leave) for sig in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def copy_district(folder: Path, work: Path) -> None:
    """Copy a district ``folder`` to ``work`` (links copied as links, never followed); a failed copy (a full
    disk, a file that cannot be read) is one :class:`InputError` naming the folder, and nothing of ``work`` is
    left."""
    try:
        shutil.copytree(folder, work, symlinks=True)
    except (OSError, shutil.Error) as error:
        shutil.rmtree(work, ignore_errors=True)
        reason = error.strerror if isinstance(error, OSError) and error.strerror else _first_reason(error)
        raise InputError(f"cannot copy the district to {work.name} beside it: {reason}", file=folder) from None


def _first_reason(error: shutil.Error | OSError) -> str:
    """The first cause of a :class:`shutil.Error` (a list of (source, destination, reason)), in one line."""
    causes = error.args[0] if error.args and isinstance(error.args[0], list) else []
    text = str(causes[0][2]) if causes and len(causes[0]) == 3 else str(error)
    return text.splitlines()[0][:200] if text else type(error).__name__


def check_not_inside(folder: Path, column: str | None = None) -> None:
    """Refuse (one line) to replace ``folder`` (resolved) while the current directory is inside it: the swap
    would pull the directory away from under the user (the build and ``surrogate install``)."""
    here = Path.cwd().resolve()
    if here == folder or folder in here.parents:
        raise InputError("the current directory is inside the district, which this replaces: run it from "
                         "outside the district", file=folder, column=column)


def check_no_links(folder: Path) -> None:
    """Refuse (one line) to put in place a district that holds a symbolic link: every file a writer creates is
    a regular file inside the folder it created, so a link there was planted."""
    for root, dirs, files in os.walk(folder):
        for name in (*dirs, *files):
            if os.path.islink(os.path.join(root, name)):
                link = Path(root, name)
                raise InputError(f"a symbolic link appeared in the new district ({link.relative_to(folder)}): "
                                 "not put in place", file=link)


def write_new_file(path: Path, text: str | bytes) -> None:
    """Create ``path`` with ``text``: never through a symlink and never over an existing file (O_EXCL |
    O_NOFOLLOW; a planted link or file is an OSError, nothing written elsewhere)."""
    handle = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
    with os.fdopen(handle, "wb" if isinstance(text, bytes) else "w") as stream:
        stream.write(text)


def write_same_file(path: Path, data: str | bytes) -> None:
    """:func:`write_new_file`, or nothing when ``path`` is already a regular file (not a link) holding exactly
    ``data``: a per-building task run again (its worker lost after writing) writes the same bytes; any other
    file there is an error."""
    try:
        write_new_file(path, data)
    except FileExistsError:
        raw = data.encode() if isinstance(data, str) else data
        if not (stat.S_ISREG(os.lstat(path).st_mode) and path.read_bytes() == raw):
            raise


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


#: the mode of a staging folder while it is written (0755 once complete: manifest.make_world_readable)
PRIVATE_MODE = 0o700
#: called with the label of each step of :func:`swap_in` before it runs; None in use (the fault-injection
#: tests set it to kill the process at one step)
STEP_HOOK: Callable[[str], None] | None = None


def at_step(label: str) -> None:
    """Mark the start of one file-system step of a writer (calls :data:`STEP_HOOK` when set)."""
    if STEP_HOOK is not None:
        STEP_HOOK(label)
#: Linux renameat2(2): relative paths from the current directory, swap both names in one step
AT_FDCWD, RENAME_EXCHANGE = -100, 2
#: what a killed writer of district ``<name>`` may leave beside it: its staging folder (a build), its working
#: copy (``surrogate install``) or the old version it renamed aside (the two-rename fallback)
LEFTOVER = r"\.{name}\.(building|install|old)-(\d+)"


@functools.cache
def _renameat2() -> Callable[..., int] | None:
    """The C library's ``renameat2`` (looked up once), or None where it has none."""
    rename = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None)
    if rename is not None:
        rename.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    return rename


def exchange(a: Path, b: Path) -> bool:
    """Swap the names of two existing paths in ONE atomic step (Linux ``renameat2`` with
    ``RENAME_EXCHANGE``); False, nothing changed, where the C library, kernel or file system lacks it."""
    rename = _renameat2()
    if rename is None:
        return False
    if rename(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def swap_in(new: Path, final: Path, step: Callable[[str], None] | None = None) -> None:
    """Put the folder ``new`` (a sibling) under the name ``final`` so that at every instant ``final`` is the
    whole old district or the whole new one (a kill at any point, the next writer cleans the rest). Every
    writer of a district (the build, ``surrogate install``) replaces it through here.

    * no ``final`` yet: one ``rename``;
    * else one atomic exchange of the two names (:func:`exchange`), then the old version, now under ``new``'s
      name, is deleted;
    * where the OS has no exchange: the old one is renamed aside to ``.<name>.old-<pid>``, the new one in (a
      kill between the two leaves no ``final`` until the next writer puts the old one back,
      :func:`clean_leftovers`), the old one deleted; the old one is put back when the second rename fails.

    ``step(label)`` is called before each file-system step (``"rename"``, ``"exchange"``, ``"delete old"``,
    ``"rename aside"``; default :data:`STEP_HOOK`): the fault-injection tests kill the process there."""
    step = step or at_step
    if not final.exists() and not final.is_symlink():
        step("rename")
        new.rename(final)
        return
    step("exchange")
    if exchange(new, final):
        step("delete old")
        shutil.rmtree(new, ignore_errors=True)
        return
    old = final.with_name(f".{final.name}.old-{os.getpid()}")
    step("rename aside")
    final.rename(old)
    try:
        step("rename")
        new.rename(final)
    except OSError:
        old.rename(final)
        raise
    step("delete old")
    shutil.rmtree(old, ignore_errors=True)


def clean_leftovers(root: Path, name: str, finished: int | None = None) -> list[Path]:
    """Delete what killed writers of district ``name`` left in ``root``, recognised by name AND content: a
    ``.<name>.(building|install|old)-<pid>`` folder of a process that is gone (or of pid ``finished``, the
    caller's own, done with it) which holds a districtgen build of ``name`` (a manifest naming it) or is a
    build's marked staging folder; and ownership marks left without their folder. When ``root/<name>`` is
    missing (a kill between the fallback's two renames) the newest old version is put back first. Returns
    what was deleted."""
    pattern = re.compile(LEFTOVER.format(name=re.escape(name)))
    found = []
    for folder in root.glob(f".{glob.escape(name)}.*-*"):
        match = pattern.fullmatch(folder.name)
        gone = match is not None and (int(match.group(2)) == finished or not process_alive(int(match.group(2))))
        if gone and not folder.is_symlink() and folder.is_dir():
            found.append((match.group(1), folder))
    for mark in root.glob(f".{glob.escape(name)}.building-*.districtgen"):  # a mark without its folder
        match = pattern.fullmatch(mark.name[: -len(".districtgen")])
        folder = mark.with_name(mark.name[: -len(".districtgen")])
        if match and not folder.exists() and not mark.is_symlink() and (
                int(match.group(2)) == finished or not process_alive(int(match.group(2)))):
            mark.unlink(missing_ok=True)
    final = root / name
    olds = sorted((f for kind, f in found if kind == "old" and is_build(f, name)), key=lambda f: f.stat().st_mtime)
    if olds and not final.exists() and not final.is_symlink():
        olds[-1].rename(final)
        found = [(k, f) for k, f in found if f != olds[-1]]
    deleted = []
    for kind, folder in found:
        marked = kind == "building" and folder.with_name(folder.name + ".districtgen").is_file()
        if is_build(folder, name) or marked:
            shutil.rmtree(folder, ignore_errors=True)
            folder.with_name(folder.name + ".districtgen").unlink(missing_ok=True)
            deleted.append(folder)
    return deleted
