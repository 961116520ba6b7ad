"""pipeline.runners: the process pool's workers leave with their parent (real processes, no mocks)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from pipeline.builder.staging import process_alive
from pipeline.runners import InProcessRunner, ProcessRunner

ROOT = Path(__file__).resolve().parents[2]


def write_pid_and_sleep(folder: str, name: str, seconds: float) -> str:
    """A task: note this worker's pid in ``folder/name``, then sleep."""
    (Path(folder) / name).write_text(str(os.getpid()))
    time.sleep(seconds)
    return name


def alive(pid: int) -> bool:
    """:func:`pipeline.builder.staging.process_alive`, a zombie (exited, not yet reaped) counting as gone."""
    try:
        return process_alive(pid) and Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


def test_workers_run_the_calls_in_order(tmp_path):
    calls = {f"t{i}": (str(tmp_path), f"t{i}", 0.0) for i in range(3)}
    assert ProcessRunner(2).map("t", write_pid_and_sleep, calls) == {"t0": "t0", "t1": "t1", "t2": "t2"}


def test_keep_sees_each_result_here_as_it_arrives_and_only_its_return_is_held(tmp_path):
    """``keep(label, result)`` runs in the calling process, once per result, in the order results finish (the
    0.0 s task before the 2 s one on two workers), and the map returns what ``keep`` returned, in call order."""
    seen = []

    def keep(label: str, result: str) -> tuple[str, int]:
        seen.append((label, os.getpid()))
        return label, len(result)

    calls = {"slow": (str(tmp_path), "slow", 2.0), "quick": (str(tmp_path), "quick", 0.0)}
    assert ProcessRunner(2).map("t", write_pid_and_sleep, calls, keep=keep) == {"slow": ("slow", 4),
                                                                                 "quick": ("quick", 5)}
    assert seen == [("quick", os.getpid()), ("slow", os.getpid())]
    assert InProcessRunner().map("t", write_pid_and_sleep, calls, keep=keep) == {"slow": ("slow", 4),
                                                                                 "quick": ("quick", 5)}


def test_workers_leave_when_their_parent_is_killed(tmp_path):
    """SIGKILL to the process that owns the pool (its workers are mid-task, 120 s each): they are gone
    within seconds instead of running their tasks to the end."""
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(ROOT)!r})
        from pipeline.runners import InProcessRunner, ProcessRunner
        from tests.pipeline.test_runners import write_pid_and_sleep
        if __name__ == "__main__":
            calls = {{name: ({str(tmp_path)!r}, name, 120.0) for name in ("a", "b")}}
            ProcessRunner(2).map("sleep", write_pid_and_sleep, calls)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT)
    try:
        deadline = time.monotonic() + 60
        while not all((tmp_path / n).is_file() and (tmp_path / n).read_text() for n in ("a", "b")):
            assert time.monotonic() < deadline, "the workers did not start"
            assert parent.poll() is None, "the parent ended early"
            time.sleep(0.1)
        workers = [int((tmp_path / n).read_text()) for n in ("a", "b")]
        assert all(alive(pid) for pid in workers)
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 10
        while any(alive(pid) for pid in workers):
            assert time.monotonic() < deadline, "a worker outlived its parent by 10 s"
            time.sleep(0.1)
    finally:
        if parent.poll() is None:
            parent.kill()
