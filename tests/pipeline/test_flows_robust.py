"""The build's temporary Prefect server on a machine that is busy or hostile (issue 30, part 6): a build killed
while its server starts leaves no server; no free port, a port taken, a server that dies while starting and an
API lost mid-build are each one line; a build of two houses succeeds with the CPU saturated.

Real processes on 127.0.0.1 throughout: the build is a real process entering ``prefect_api()`` (or the
``districtgen`` command), the server is Prefect's, found through /proc (Linux)."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterable
from pathlib import Path

import httpx
import pytest
from prefect.settings import PREFECT_API_URL, PREFECT_SERVER_DATABASE_CONNECTION_URL, temporary_settings

from pipeline.errors import InputError
from pipeline.flows import CLIENT_RETRIES, patient_settings, prefect_api
from pipeline.prefect_server import HOST, OrchestrationError, api_loss_in_one_line, lost_connection

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "fixtures" / "synthetic_district" / "district.toml"
SERVER_MARK = "# districtgen: temporary prefect api server"   # first line of the server's and watchdog's code
WATCHDOG_MARK = "# districtgen: prefect server watchdog"

#: a build as ``districtgen build`` runs it, without the build: enter prefect_api(), say so, wait
BUILD_LIKE = """
import time
from pipeline.flows import prefect_api
with prefect_api() as url:
    print(url, flush=True)
    time.sleep(600)
"""


# ------------------------------------------------------------------------------------------------ helpers
def children(pid: int) -> dict[int, list[str]]:
    """The processes whose parent is ``pid``: {pid: argv} (Linux /proc)."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1]) == pid:
                found[int(entry.name)] = (entry / "cmdline").read_bytes().decode(errors="replace").rstrip("\0").split("\0")
        except (OSError, IndexError, ValueError):
            continue
    return found


def servers_and_watchdogs(pid: int) -> tuple[dict[int, list[str]], dict[int, list[str]]]:
    """The temporary Prefect servers and watchdogs among the children of ``pid``."""
    kids = children(pid)
    servers = {p: argv for p, argv in kids.items() if any(a.startswith(SERVER_MARK) for a in argv)}
    watchdogs = {p: argv for p, argv in kids.items() if any(a.startswith(WATCHDOG_MARK) for a in argv)}
    return servers, watchdogs


def running(pid: int) -> bool:
    """Whether ``pid`` is a live process (a zombie, exited but not yet reaped, is not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def still_running(pids: Iterable[int], within_s: float) -> list[int]:
    """The ``pids`` still running after waiting up to ``within_s`` seconds for all to end."""
    deadline = time.monotonic() + within_s
    left = [p for p in pids if running(p)]
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = [p for p in left if running(p)]
    return left


def kill_all(pids: Iterable[int]) -> None:
    for pid in pids:
        if running(pid):
            os.kill(pid, signal.SIGKILL)


def environment(tmp_path: Path, **extra: str) -> dict[str, str]:
    """This environment for a child build: the repository importable, its own PREFECT_HOME, no configured
    API server and no configured database (a user's default: the temporary server, records in memory)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_HOME": str(tmp_path / "prefect"), **extra}
    for name in ("PREFECT_API_URL", "PREFECT_SERVER_DATABASE_CONNECTION_URL"):
        if name not in extra:
            env.pop(name, None)
    return env


def two_house_config(tmp_path: Path) -> Path:
    """The cheapest two-house build: the synthetic fixture district (EULP houses 900001 and 900002) for three
    days, without surrogates; written into ``tmp_path`` with its input paths made absolute."""
    text = FIXTURE.read_text().replace("end = 2018-06-30", "end = 2018-06-03")
    text = text.replace('source = "csv"', 'source = "none"')

    def absolute(match: re.Match) -> str:
        return f'{match[1]} = "{(FIXTURE.parent / match[2]).resolve()}"'

    text = re.sub(r'^(eulp|weather|tariff|fuel_mix|ilv) = "([^"]*)"', absolute, text, flags=re.M)
    assert 'buildings = [900001, 900002]' in text and 'source = "none"' in text
    path = tmp_path / "two_houses.toml"
    path.write_text(text)
    return path


def held_ports(count: int) -> list[socket.socket]:
    """``count`` TCP sockets listening on free ports of HOST (the OS picks them)."""
    held = []
    for _ in range(count):
        holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        holder.bind((HOST, 0))
        holder.listen()
        held.append(holder)
    return held


def one_error_line(stderr: str) -> list[str]:
    """The lines of a ``districtgen`` stderr that are not progress lines (``districtgen: [  1.2 s] ...``)."""
    return [line for line in stderr.splitlines() if line.strip() and not line.startswith("districtgen: [")]


# ------------------------------------------------------------------- defect 1: killed while the server starts
@pytest.mark.parametrize("how", ["as it is", "its watchdog gone first", "its server hung"])
def test_a_build_killed_while_its_server_starts_leaves_no_server(tmp_path, how):
    """SIGKILL a process inside prefect_api() as soon as its server process exists, long before the server
    answers (the process never got its API URL): the server and the watchdog are gone within seconds.

    ``its watchdog gone first``: the watchdog is killed (or not started yet) too, so the server must stop
    itself; ``its server hung``: the server is SIGSTOPped, so only the watchdog can stop it (SIGKILL)."""
    build = subprocess.Popen([sys.executable, "-c", BUILD_LIKE], cwd=ROOT, env=environment(tmp_path),
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    seen: set[int] = set()
    try:
        deadline = time.monotonic() + 120
        servers: dict[int, list[str]] = {}
        watchdogs: dict[int, list[str]] = {}
        while time.monotonic() < deadline and build.poll() is None:
            servers, watchdogs = servers_and_watchdogs(build.pid)
            seen |= set(servers) | set(watchdogs)
            if servers and (how == "its watchdog gone first" or watchdogs):
                break
            time.sleep(0.01)  # the server takes seconds to import before it could answer
        assert servers, "the temporary server process was never seen"
        if how == "its watchdog gone first":
            os.kill(build.pid, signal.SIGSTOP)         # it starts no watchdog now
            watchdogs = servers_and_watchdogs(build.pid)[1]
            seen |= set(watchdogs)
            kill_all(watchdogs)
        elif how == "its server hung":
            os.kill(next(iter(servers)), signal.SIGSTOP)
        build.kill()
        build.wait()
        assert build.stdout.read() == ""              # killed before the server answered
        assert still_running(seen, 20.0) == [], f"outlived the killed build ({how}): {seen}"
    finally:
        if build.poll() is None:
            build.kill()
            build.wait()
        kill_all(seen)


# ------------------------------------------------------------------ defect 3: the server cannot start
def test_all_ports_in_use_is_one_line_naming_host_and_ports():
    """Every port the server may use is taken: one line at once naming the host and the ports (it was "did
    not answer within 600 s"), no process started."""
    held = held_ports(2)
    ports = [holder.getsockname()[1] for holder in held]
    try:
        started = time.monotonic()
        with temporary_settings(restore_defaults={PREFECT_API_URL}), pytest.raises(OrchestrationError) as caught:
            with prefect_api(ports=ports):
                pytest.fail("no server can start")
        elapsed = time.monotonic() - started
    finally:
        for holder in held:
            holder.close()
    message = str(caught.value)
    assert "\n" not in message and "did not answer" not in message
    assert f"on {HOST}" in message and "in use" in message and all(str(p) in message for p in ports), message
    assert elapsed < 5.0
    assert servers_and_watchdogs(os.getpid()) == ({}, {})


def test_a_server_that_dies_while_starting_is_one_line_naming_host_port_and_error(tmp_path, monkeypatch):
    """The server exits during startup (its database cannot be opened): as soon as it has exited, one line
    naming host, port, its exit status and its own error line, read from its stderr; nothing left."""
    (tmp_path / "afile").write_text("")
    url = f"sqlite+aiosqlite:///{tmp_path / 'afile' / 'prefect.db'}"  # a folder that is a file
    monkeypatch.setenv("PREFECT_SERVER_DATABASE_CONNECTION_URL", url)  # the user's own database
    started = time.monotonic()
    with (temporary_settings({PREFECT_SERVER_DATABASE_CONNECTION_URL: url}, restore_defaults={PREFECT_API_URL}),
          pytest.raises(OrchestrationError) as caught):
        with prefect_api():
            pytest.fail("the server cannot start")
    message = str(caught.value)
    assert "\n" not in message and "did not answer" not in message
    assert re.search(rf"server on {re.escape(HOST)}:\d+ exited during startup \(exit status \d+: ", message)
    assert "unable to open database file" in message, message
    assert time.monotonic() - started < 120
    assert servers_and_watchdogs(os.getpid()) == ({}, {})


@pytest.mark.slow  # the server must get through its startup (20-40 s here) before it binds the port
def test_a_port_taken_while_the_server_starts_is_one_line_naming_it():
    """Another program takes the server's port while the server starts (it binds only when started): the
    server exits; with no other port free, one line naming host and port, "address already in use"."""
    with socket.socket() as probe:
        probe.bind((HOST, 0))
        port = probe.getsockname()[1]
    taken: list[socket.socket] = []
    done = threading.Event()

    def take_the_port() -> None:
        while not done.is_set() and not taken:
            for argv in servers_and_watchdogs(os.getpid())[0].values():
                if argv[-1] == str(port):
                    holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                    holder.bind((HOST, port))
                    holder.listen()
                    taken.append(holder)
            time.sleep(0.01)

    thief = threading.Thread(target=take_the_port)
    thief.start()
    try:
        with temporary_settings(restore_defaults={PREFECT_API_URL}), pytest.raises(OrchestrationError) as caught:
            with prefect_api(ports=[port]):
                pytest.fail("the port was taken")
    finally:
        done.set()
        thief.join()
        for holder in taken:
            holder.close()
    assert taken, "the server was never seen"
    message = str(caught.value)
    assert "\n" not in message and f"could not listen on {HOST}:{port}: address already in use" in message
    assert servers_and_watchdogs(os.getpid()) == ({}, {})


# ------------------------------------------------------------------------ defect 2: the API lost mid-build
def test_the_client_retries_patiently_unless_the_user_chose(monkeypatch):
    monkeypatch.delenv("PREFECT_CLIENT_MAX_RETRIES", raising=False)
    chosen = {setting.name: value for setting, value in patient_settings().items()}
    assert chosen["PREFECT_CLIENT_MAX_RETRIES"] == CLIENT_RETRIES > 5      # Prefect's default: 5
    assert chosen["PREFECT_API_REQUEST_TIMEOUT"] == 300.0
    monkeypatch.setenv("PREFECT_CLIENT_MAX_RETRIES", "1")
    assert "PREFECT_CLIENT_MAX_RETRIES" not in {setting.name for setting in patient_settings()}


def test_a_refused_api_connection_is_found_behind_wrappers_and_becomes_one_line():
    """A real refused connection to an API URL, wrapped as Prefect and anyio wrap it (a cause, a context, an
    exception group), is recognised; it becomes one line saying a rerun resumes from the cache. Another
    server's failure, an unrelated error and an input error pass unchanged."""
    with socket.socket() as probe:
        probe.bind((HOST, 0))
        port = probe.getsockname()[1]                      # closed again: nothing listens there
    api = f"http://{HOST}:{port}/api"
    with pytest.raises(httpx.ConnectError) as refused:
        httpx.get(f"{api}/flow_runs/", timeout=5)
    try:
        try:
            raise refused.value
        except httpx.ConnectError:
            raise RuntimeError("Flow run crashed") from None   # only the context links them
    except RuntimeError as crash:
        by_context = crash
    by_cause = RuntimeError("task failed")
    by_cause.__cause__ = refused.value
    grouped = ExceptionGroup("task group", [ValueError("other"), by_cause])
    for error in (refused.value, by_context, by_cause, grouped):
        assert lost_connection(error, api) is refused.value
    assert lost_connection(by_cause, f"http://{HOST}:1/api") is None
    assert lost_connection(ValueError("x"), api) is None

    with pytest.raises(OrchestrationError) as caught, api_loss_in_one_line(api):
        raise grouped
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"lost the connection to the Prefect API at {api} ")
    assert "ConnectError" in message and "rerun the same command to resume" in message and "cache" in message
    for error in (ValueError("unrelated"), InputError("bad input", file="x.toml")):
        with pytest.raises(type(error)) as passed, api_loss_in_one_line(api):
            raise error
        assert passed.value is error


@pytest.mark.slow  # two builds through Prefect, each starting a server (about 2-3 minutes here)
def test_an_api_lost_mid_build_is_one_line_and_a_rerun_builds(tmp_path):
    """SIGKILL the build's Prefect server while the build runs (its staging folder exists): after the client's
    retries (1 here, set by the user), one line, exit 2, no traceback, nothing left; the same command again
    builds the district."""
    config, out = two_house_config(tmp_path), tmp_path / "out"
    command = [sys.executable, "-m", "pipeline.cli", "build", str(config), "-o", str(out)]
    env = environment(tmp_path, PREFECT_CLIENT_MAX_RETRIES="1")
    build = subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed: list[int] = []

    def kill_the_server() -> None:
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline and build.poll() is None and not killed:
            if out.is_dir() and any(p.name.startswith(".default.building-") for p in out.iterdir()):
                for pid in servers_and_watchdogs(build.pid)[0]:
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
            time.sleep(0.02)

    killer = threading.Thread(target=kill_the_server)
    killer.start()
    try:
        stdout, stderr = build.communicate(timeout=900)
    finally:
        killer.join()
        if build.poll() is None:
            build.kill()
    assert killed, "the server was never killed"
    lines = one_error_line(stderr)
    assert build.returncode == 2 and len(lines) == 1, stderr
    assert lines[0].startswith("districtgen: error: lost the connection to the Prefect API at http://127.0.0.1:")
    assert "killed by SIGKILL" in lines[0] and "rerun the same command to resume" in lines[0]
    assert "Traceback" not in stderr and "Traceback" not in stdout
    assert children(build.pid) == {}
    rerun = subprocess.run([*command, "--quiet"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert rerun.returncode == 0, rerun.stderr
    assert (out / "default" / "schema.json").is_file()


# ---------------------------------------------------------------------------- a saturated CPU (stress)
BUSY = "import os\nparent = os.getppid()\nwhile os.getppid() == parent:\n    pass\n"  # ends with its parent


@pytest.mark.slow  # a build through Prefect with every core busy: a few minutes
def test_a_two_house_build_succeeds_through_prefect_on_a_saturated_cpu(tmp_path):
    """Two busy-looping processes per core (at least 4: 4 on a 2-core machine) while ``districtgen build``
    builds two houses through Prefect (its temporary server, the flow, tasks): it succeeds."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    config, out = two_house_config(tmp_path), tmp_path / "out"
    busy: list[subprocess.Popen] = []
    try:
        for _ in range(max(4, 2 * cores)):
            busy.append(subprocess.Popen([sys.executable, "-c", BUSY]))
        started = time.monotonic()
        build = subprocess.run([sys.executable, "-m", "pipeline.cli", "build", str(config), "-o", str(out),
                                "--quiet"], cwd=ROOT, env=environment(tmp_path), capture_output=True, text=True,
                               timeout=1800)
        elapsed = time.monotonic() - started
    finally:
        for process in busy:
            process.kill()
            process.wait()
    assert build.returncode == 0, build.stderr
    assert (out / "default" / "schema.json").is_file() and "Traceback" not in build.stderr
    print(f"two houses through Prefect with {len(busy)} busy processes on {cores} cores: {elapsed:.0f} s")


def test_preload_imports_in_a_thread_and_leaves_a_failed_import_to_the_build(capsys):
    """The build's imports run beside the server's start; one that fails says nothing there (the build's own
    import raises it as one line) and stops the preload."""
    from pipeline.flows import preload

    sys.modules.pop("wave", None)
    sys.modules.pop("tabnanny", None)
    thread = preload(["wave", "districtgen_no_such_module", "tabnanny"])
    thread.join(30)
    assert not thread.is_alive() and thread.daemon
    assert "wave" in sys.modules
    assert "districtgen_no_such_module" not in sys.modules and "tabnanny" not in sys.modules
    assert capsys.readouterr().err == ""
