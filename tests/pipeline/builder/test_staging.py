"""Replacing a district is atomic (issue 30, part 1): a writer killed (SIGKILL) before any step of the swap
leaves the whole old district or the whole new one under the final name, and the next writer cleans what
the killed one left, recognised by name and content. The writer is the build's real staging folder, run in a
child process that kills itself at one step through ``staging.STEP_HOOK``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.builder.staging import clean_leftovers, exchange, swap_in

ROOT = Path(__file__).resolve().parents[3]

WRITER = """
import json, os, signal, sys
from pathlib import Path
from pipeline.builder import staging as st
from pipeline.config import parse_build_config

root, label, fallback, version = Path(sys.argv[1]), sys.argv[2], sys.argv[3] == "1", sys.argv[4]
if fallback:  # an OS or file system without an atomic exchange of two names
    st.exchange = lambda a, b: False
st.STEP_HOOK = lambda step: os.kill(os.getpid(), signal.SIGKILL) if step == label else None
config = parse_build_config({"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
                             "inputs": {"eulp": "e", "weather": "w.epw", "tariff": "t.toml", "fuel_mix": "f.xlsx",
                                        "buildings": [1]}}, file="district.toml")
with st.staging(config, root) as out:
    for i in range(20):
        (out / f"Building_{i}.csv").write_text(version * 500)
    (out / "manifest.json").write_text(json.dumps({"district": "x", "version": version}))
"""


def write(root: Path, version: str, *, kill_at: str = "-", fallback: bool = False) -> int:
    """Run the staging writer of district ``x`` in a child process; its exit status (-9: killed)."""
    done = subprocess.run([sys.executable, "-c", WRITER, str(root), kill_at, "1" if fallback else "0", version],
                          cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode in (0, -signal.SIGKILL), done.stderr
    return done.returncode


def version_of(folder: Path) -> str:
    """The version a complete district folder holds (every file agrees), else fail."""
    version = json.loads((folder / "manifest.json").read_text())["version"]
    assert all((folder / f"Building_{i}.csv").read_text() == version * 500 for i in range(20))
    return version


def test_exchange_swaps_two_folders_in_one_step(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "f").write_text("A")
    (b / "f").write_text("B")
    if not exchange(a, b):
        pytest.skip("this OS or file system has no renameat2 RENAME_EXCHANGE: the two-rename fallback applies")
    assert (a / "f").read_text() == "B" and (b / "f").read_text() == "A"


@pytest.mark.parametrize("label", ["exchange", "delete old"])
def test_a_writer_killed_at_any_step_leaves_the_old_or_the_new_district(tmp_path, label):
    assert write(tmp_path, "A") == 0
    assert write(tmp_path, "B", kill_at=label) == -signal.SIGKILL
    expected = "A" if label == "exchange" else "B"
    assert version_of(tmp_path / "x") == expected            # never neither, never a mix
    assert write(tmp_path, "C") == 0                         # the next writer cleans what the killed one left
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"] and version_of(tmp_path / "x") == "C"


def test_a_first_build_killed_before_its_rename_leaves_nothing_but_its_marked_staging(tmp_path):
    assert write(tmp_path, "A", kill_at="rename") == -signal.SIGKILL
    assert not (tmp_path / "x").exists()
    assert write(tmp_path, "B") == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"] and version_of(tmp_path / "x") == "B"


@pytest.mark.parametrize("label", ["rename aside", "rename", "delete old"])
def test_without_an_exchange_the_next_writer_restores_a_district_killed_between_two_renames(tmp_path, label):
    assert write(tmp_path, "A", fallback=True) == 0
    assert write(tmp_path, "B", kill_at=label, fallback=True) == -signal.SIGKILL
    if label == "rename":   # the fallback's one window: the old version renamed aside, the new not yet in
        assert not (tmp_path / "x").exists()
        clean_leftovers(tmp_path, "x")                        # what every writer runs first
    assert version_of(tmp_path / "x") == ("B" if label == "delete old" else "A")
    assert write(tmp_path, "C", fallback=True) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"] and version_of(tmp_path / "x") == "C"


def _dead_pid() -> int:
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def test_leftovers_are_recognised_by_content_and_owner(tmp_path):
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "manifest.json").write_text(json.dumps({"district": "x", "version": "A"}))
    folders = {}
    for key, owner, district in (("ours", _dead_pid(), "x"), ("not a district", _dead_pid(), None),
                                 ("another district", _dead_pid(), "y"), ("running writer", os.getpid(), "x")):
        folder = folders[key] = tmp_path / f".x.install-{owner}"
        folder.mkdir()
        if district is None:
            (folder / "notes.txt").write_text("mine")
        else:
            (folder / "manifest.json").write_text(json.dumps({"district": district}))
    assert clean_leftovers(tmp_path, "x") == [folders["ours"]]
    assert all(folders[k].exists() for k in ("not a district", "another district", "running writer"))


def test_swap_in_into_an_empty_place_is_one_rename(tmp_path):
    new = tmp_path / ".x.building-1"
    new.mkdir()
    (new / "manifest.json").write_text(json.dumps({"district": "x", "version": "A"}))
    steps: list[str] = []
    swap_in(new, tmp_path / "x", step=steps.append)
    assert steps == ["rename"] and not new.exists()



def _config():
    from pipeline.config import parse_build_config

    return parse_build_config({"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
                               "inputs": {"eulp": "e", "weather": "w.epw", "tariff": "t.toml", "fuel_mix": "f.xlsx",
                                          "buildings": [1]}}, file="district.toml")


def test_a_planted_link_at_the_ownership_mark_is_never_written_through(tmp_path):
    from pipeline.builder.staging import staging
    from pipeline.errors import InputError

    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    root = tmp_path / "out"
    root.mkdir()
    (root / f".x.building-{os.getpid()}.districtgen").symlink_to(outside)
    with pytest.raises(InputError, match="cannot write into the output folder"):
        with staging(_config(), root):
            pass
    assert outside.read_text() == "precious"
    assert not (root / "x").exists()


def test_a_build_run_from_inside_its_own_district_is_refused(tmp_path, monkeypatch):
    from pipeline.builder.staging import staging
    from pipeline.errors import InputError

    assert write(tmp_path, "A") == 0
    monkeypatch.chdir(tmp_path / "x")
    with pytest.raises(InputError, match="current directory is inside the district"):
        with staging(_config(), tmp_path):
            pass
    assert version_of(tmp_path / "x") == "A"


def test_the_staging_folder_is_private_whatever_the_umask_and_a_planted_link_is_never_put_in_place(tmp_path):
    """Created mode 0700 (under umask 0 too), nobody else can plant a link in it; a link that appears anyway
    (the same user) stops the swap: the final name keeps the old district, the staging folder is gone and the
    link's target is untouched."""
    from pipeline.builder.staging import staging
    from pipeline.errors import InputError

    assert write(tmp_path, "A") == 0
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    previous = os.umask(0)
    try:
        with pytest.raises(InputError, match=r"symbolic link appeared in the new district \(report/x.csv\)"):
            with staging(_config(), tmp_path) as out:
                assert os.stat(out).st_mode & 0o777 == 0o700
                (out / "report").mkdir()
                (out / "report" / "x.csv").symlink_to(outside)
                (out / "manifest.json").write_text(json.dumps({"district": "x", "version": "B"}))
    finally:
        os.umask(previous)
    assert version_of(tmp_path / "x") == "A" and outside.read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["outside.txt", "x"]


TERMINATED = """
import os, signal, sys, time
from pathlib import Path
from pipeline.builder import staging as st
from pipeline.config import parse_build_config

root, sig = Path(sys.argv[1]), getattr(signal, sys.argv[2])
config = parse_build_config({"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
                             "inputs": {"eulp": "e", "weather": "w.epw", "tariff": "t.toml", "fuel_mix": "f.xlsx",
                                        "buildings": [1]}}, file="district.toml")
with st.staging(config, root) as out:
    (out / "Building_1.csv").write_text("half a district")
    os.kill(os.getpid(), sig)
    time.sleep(30)
"""


@pytest.mark.parametrize("name", ["SIGTERM", "SIGHUP"])
def test_a_build_ended_by_sigterm_or_sighup_leaves_no_staging_copy(tmp_path, name):
    """`build --no-prefect` (no Prefect flow to catch it) ended by SIGTERM / SIGHUP: the staging folder and its
    mark are deleted, the old district stays, the status is 128 + the signal."""
    assert write(tmp_path, "A") == 0
    done = subprocess.run([sys.executable, "-c", TERMINATED, str(tmp_path), name], cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, timeout=120)
    assert done.returncode == 128 + getattr(signal, name), done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"] and version_of(tmp_path / "x") == "A"


def test_a_copy_that_fills_the_disk_is_one_line_and_leaves_nothing(tmp_path):
    """`surrogate install`'s working copy on a full disk (a 1 MiB tmpfs): one line naming the district and the
    reason, no partial copy."""
    from pipeline.builder.staging import copy_district
    from pipeline.errors import InputError

    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)], capture_output=True).returncode:
        pytest.skip("mounting a small tmpfs needs privileges this machine does not give")
    try:
        district = disk / "x"
        district.mkdir()
        for i in range(3):
            (district / f"Building_{i}.csv").write_bytes(os.urandom(300_000))
        with pytest.raises(InputError) as caught:
            copy_district(district, disk / ".x.install-1")
        line = str(caught.value)
        assert "\n" not in line and len(line) < 400 and "No space left on device" in line and str(district) in line
        assert sorted(p.name for p in disk.iterdir()) == ["x"]
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)
