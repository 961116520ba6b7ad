"""A real distributed deployment: a Dask scheduler and worker processes started apart from the build (as on a
cluster of machines), one worker killed with SIGKILL mid-build and replaced; the district equals the
in-process build's (real processes on 127.0.0.1, no mocks)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

from pipeline.runners import DaskRunner

pytest.importorskip("distributed", reason="the dask extra is not installed")
ROOT = Path(__file__).resolve().parents[2]
DASK = Path(sys.executable).parent / "dask"
#: seconds a scheduler or worker may take to come up on a busy machine
START_S = 180.0


class Cluster:
    """``dask scheduler`` and ``dask worker`` processes (single-threaded, no nanny: SIGKILL ends the worker
    for good) on 127.0.0.1, their logs in ``folder``; the worker's environment makes this checkout importable."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.env = {**os.environ, "PYTHONPATH": str(ROOT), "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "warning"}
        self.processes: list[subprocess.Popen] = []
        self.workers: dict[str, subprocess.Popen] = {}
        scheduler_file = folder / "scheduler.json"
        self._spawn("scheduler", [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                  "--scheduler-file", str(scheduler_file)])
        deadline = time.monotonic() + START_S
        self.address = None
        while self.address is None:
            assert time.monotonic() < deadline, "the scheduler did not start"
            assert self.processes[0].poll() is None, (folder / "scheduler.log").read_text()
            time.sleep(0.1)
            try:
                self.address = json.loads(scheduler_file.read_text())["address"]
            except (OSError, ValueError, KeyError):  # not written yet, or half written
                continue

    def _spawn(self, name: str, command: list[str]) -> subprocess.Popen:
        log = open(self.folder / f"{name}.log", "w")  # noqa: SIM115 - closed with the process
        process = subprocess.Popen(command, cwd=ROOT, env=self.env, stdout=log, stderr=subprocess.STDOUT)
        log.close()
        self.processes.append(process)
        return process

    def start_worker(self, name: str) -> None:
        self.workers[name] = self._spawn(name, [str(DASK), "worker", self.address, "--nthreads", "1",
                                                "--no-nanny", "--name", name, "--no-dashboard"])

    def wait_for_workers(self, client, n: int) -> None:
        client.wait_for_workers(n, timeout=START_S)

    def kill(self, name: str) -> None:
        self.workers[name].send_signal(signal.SIGKILL)
        self.workers[name].wait()

    def stop(self) -> None:
        for process in reversed(self.processes):  # only the processes this object started
            if process.poll() is None:
                process.kill()
                process.wait()


@contextmanager
def cluster(folder: Path, workers: int = 2):
    """A scheduler and ``workers`` workers ``w1``, ``w2``, ..., connected; stopped on exit."""
    from distributed import Client

    folder.mkdir(parents=True, exist_ok=True)
    running = Cluster(folder)
    try:
        for i in range(1, workers + 1):
            running.start_worker(f"w{i}")
        with Client(running.address) as client:
            if workers:
                running.wait_for_workers(client, workers)
            yield running, client
    finally:
        running.stop()


def kill_mid_task(running: Cluster, client, prefix: str, done: threading.Event) -> dict:
    """Watch the scheduler until a worker runs a task whose key starts with ``prefix``; SIGKILL that worker
    (after 1 s: the task is well under way) and start a replacement. Returns what it did."""
    record: dict = {}
    deadline = time.monotonic() + 1800
    while not done.is_set() and time.monotonic() < deadline:
        busy = {address: keys for address, keys in client.processing().items()
                if any(str(k).startswith(prefix) for k in keys)}
        if busy:
            address, keys = next(iter(busy.items()))
            name = client.scheduler_info()["workers"][address]["name"]
            time.sleep(1.0)
            running.kill(name)
            running.start_worker(f"{name}-replacement")
            record.update(killed=name, keys=[str(k) for k in keys])
            return record
        time.sleep(0.05)
    return record


def run_and_note(folder: str, label: str, seconds: float) -> tuple[str, int]:
    """A task: append this worker's pid to ``folder/<label>.runs`` (one line per run), sleep ``seconds``,
    then note ``done``; returns (label, pid)."""
    runs = Path(folder) / f"{label}.runs"
    with open(runs, "a") as handle:
        handle.write(f"{os.getpid()}\n")
    time.sleep(seconds)
    (Path(folder) / f"{label}.done").write_text(str(os.getpid()))
    return label, os.getpid()


def _wait(condition, what: str, seconds: float = START_S) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def test_results_come_home_when_done_and_a_killed_task_runs_again_on_a_replacement(tmp_path):
    """Two workers: ``slow`` (12 s) on one, ``fast`` on the other. Once ``fast`` is done its worker is killed:
    its result is already in this process (fetched when done), so ``fast`` runs once. Then the worker running
    ``slow`` is killed mid-task and a replacement started: ``slow`` runs again there, and the map returns
    both results in the order of the calls."""
    notes = tmp_path / "notes"
    notes.mkdir()
    with cluster(tmp_path / "cluster") as (running, client):
        pids = {name: process.pid for name, process in running.workers.items()}
        calls = {"slow": (str(notes), "slow", 12.0), "fast": (str(notes), "fast", 0.0)}
        result: dict = {}
        mapper = threading.Thread(target=lambda: result.update(DaskRunner(running.address).map(
            "t", run_and_note, calls)), daemon=True)
        mapper.start()
        _wait(lambda: (notes / "fast.done").is_file() and (notes / "slow.runs").is_file(), "the tasks did not start")
        by_pid = {pid: name for name, pid in pids.items()}
        fast_worker = by_pid[int((notes / "fast.done").read_text())]
        slow_worker = by_pid[int((notes / "slow.runs").read_text().split()[0])]
        if fast_worker == slow_worker:
            pytest.skip("the scheduler put both tasks on one worker")
        time.sleep(1.0)                                    # the result of fast reaches the map meanwhile
        running.kill(fast_worker)
        running.kill(slow_worker)                          # slow is mid-task (12 s)
        assert not (notes / "slow.done").exists()
        running.start_worker("replacement")
        mapper.join(timeout=600)
        assert not mapper.is_alive(), "the map did not finish after the replacement joined"
        replacement = running.workers["replacement"].pid
    assert list(result) == ["slow", "fast"]
    assert result["slow"] == ("slow", replacement) and result["fast"][0] == "fast"
    assert (notes / "fast.runs").read_text().split() == [str(pids[fast_worker])]           # ran once
    assert (notes / "slow.runs").read_text().split() == [str(pids[slow_worker]), str(replacement)]


def _config(tmp_path: Path, cache: str):
    """The synthetic fixture district (2 buildings x 3 days) with tiny csv-table surrogates (a few seconds of
    training each: a task long enough to be killed in), its own surrogate cache. Precision float32 (whatever
    the CPU multiplies natively): the digests compared must not depend on the machine's recorded choice."""
    from pipeline.config import read_build_config
    from tests.pipeline.builder.test_build import _short_config

    path = _short_config(tmp_path, source="csv", epochs=1)
    try:
        config = read_build_config(path)
    finally:
        path.unlink(missing_ok=True)
    surrogate = config.surrogate.model_copy(update={"pretrain_steps": 300, "long_chunk_epochs": 0,
                                                    "precision": "float32"})
    return config.model_copy(update={"surrogate": surrogate, "cache_dir": tmp_path / cache})


@pytest.mark.slow  # 46 s at load 2, 3-6 min at load 11-13 (shared 2 cores): two builds, a cluster
def test_a_worker_killed_mid_build_is_replaced_and_the_district_equals_the_in_process_one(tmp_path):
    from pipeline.builder.driver import build_district_local, run_build
    from pipeline.builder.manifest import district_digest

    with cluster(tmp_path / "cluster") as (running, client):
        done = threading.Event()
        record: dict = {}
        watcher = threading.Thread(target=lambda: record.update(kill_mid_task(running, client, "surrogate-",
                                                                                done)), daemon=True)
        watcher.start()
        try:
            folder = run_build(_config(tmp_path, "cache_dask"), tmp_path / "dask", DaskRunner(running.address))
        finally:
            done.set()
            watcher.join()
        assert record.get("killed") in ("w1", "w2"), "no worker was killed mid-task"
        assert running.workers[record["killed"]].returncode == -signal.SIGKILL
        running.wait_for_workers(client, 2)
        names = {w["name"] for w in client.scheduler_info()["workers"].values()}
        assert f"{record['killed']}-replacement" in names and record["killed"] not in names
    local = build_district_local(_config(tmp_path, "cache_local"), tmp_path / "local")   # its own training
    assert district_digest(folder) == district_digest(local)
    for name in ("schema.json", "Building_1.pth", "Building_2.pth", "Building_1.csv"):
        assert (folder / name).read_bytes() == (local / name).read_bytes(), name


def _cli_config(tmp_path: Path) -> Path:
    """:func:`_config` as a TOML file (the fixture district's folder, so its relative paths resolve)."""
    from tests.pipeline.builder.test_build import _short_config

    path = _short_config(tmp_path, source="csv", epochs=1)
    extra = 'epochs = 1\npretrain_steps = 300\nlong_chunk_epochs = 0\nprecision = "float32"'
    path.write_text(path.read_text().replace("epochs = 1", extra))
    return path


@pytest.mark.slow  # 63 s at load 2, 9 min at load 12: Prefect's API server, a cluster, two builds
def test_districtgen_build_dask_address_survives_a_killed_worker(tmp_path):
    """``districtgen build CONFIG --dask tcp://127.0.0.1:PORT`` (the Prefect flow on prefect-dask) against a
    scheduler and two workers started apart; one worker SIGKILLed while it trains, a replacement started: the
    build succeeds and its district digest equals the in-process build's."""
    from pipeline.builder.driver import build_district_local
    from pipeline.builder.manifest import district_digest
    from pipeline.config import read_build_config

    toml = _cli_config(tmp_path)
    try:
        with cluster(tmp_path / "cluster") as (running, client):
            env = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_HOME": str(tmp_path / "prefect")}
            env.pop("PREFECT_API_URL", None)
            build = subprocess.Popen([sys.executable, "-m", "pipeline.cli", "build", str(toml), "-o",
                                      str(tmp_path / "dask"), "--cache-dir", str(tmp_path / "cache_dask"), "--dask",
                                      running.address, "--quiet"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
            done = threading.Event()
            record: dict = {}
            watcher = threading.Thread(target=lambda: record.update(kill_mid_task(running, client, "surrogate_files-",
                                                                                    done)), daemon=True)
            watcher.start()
            try:
                stdout, stderr = build.communicate(timeout=3000)
            finally:
                done.set()
                watcher.join()
                if build.poll() is None:
                    build.kill()
            assert build.returncode == 0, stderr[-3000:]
            assert record.get("killed") in ("w1", "w2"), "no worker was killed mid-task"
        config = read_build_config(toml)
        local = build_district_local(config.model_copy(update={"cache_dir": tmp_path / "cache_local"}),
                                     tmp_path / "local")
    finally:
        toml.unlink(missing_ok=True)
    assert district_digest(tmp_path / "dask" / config.name) == district_digest(local)


def test_a_scheduler_without_workers_is_one_line_not_a_wait_for_ever(tmp_path):
    from pipeline.flows import wait_for_a_worker
    from pipeline.prefect_server import OrchestrationError

    with cluster(tmp_path / "cluster", workers=0) as (running, client):
        with pytest.raises(OrchestrationError, match=r"no Dask worker joined the scheduler at tcp://127\.0\.0\.1:\d+ "
                                                     r"within 2 s: start `dask worker ADDRESS`"):
            wait_for_a_worker(client, running.address, seconds=2)
