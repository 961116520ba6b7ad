"""Prefect's temporary API server for a build: started on a free local port with a watchdog armed before it can
answer, stopped whatever happens to the build, and every way it can fail told in one line.

:class:`TemporaryServer` launches the server (uvicorn on Prefect's app, in-memory database unless configured)
and its watchdog; :func:`start_server` picks a free port, waits for ``/health`` and turns a taken port, an exit
during startup or no answer into one :class:`OrchestrationError` line; :func:`api_loss_in_one_line` does the
same for an API lost mid-build. :func:`pipeline.flows.prefect_api` owns the server's lifetime.
"""

from __future__ import annotations

import os
import random
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO

import httpx

from pipeline.errors import InputError

#: the temporary server listens on this host, on a free port of :data:`PORTS` (Prefect's own range)
HOST = "127.0.0.1"
PORTS = range(8000, 9000)
#: launches tried when another program takes the chosen port before the server binds it
LAUNCH_ATTEMPTS = 3
#: seconds a server asked to stop (SIGTERM) gets before it is killed (SIGKILL)
STOP_GRACE_S = 5.0


class OrchestrationError(InputError):
    """Prefect or Dask could not run the build (not the inputs' fault); the CLI prints it as one line, exit 2."""


#: the temporary API server (argv: build pid, host, port). Its first act is to watch the build that started
#: it: when that process is gone -- even killed with SIGKILL while the server is still importing or starting --
#: the server stops itself (SIGTERM, then exit after 5 s).
_SERVER = """# districtgen: temporary prefect api server
import os, signal, sys, threading, time
parent, host, port = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])

def guard():
    while os.getppid() == parent:
        time.sleep(0.2)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(5.0)
    os._exit(1)

threading.Thread(target=guard, daemon=True).start()
import uvicorn
from prefect.server.api.server import create_app
uvicorn.run(create_app(ephemeral=True, final=True), host=host, port=port, log_level="error", lifespan="on")
"""

#: run by the watchdog (argv: build pid, server pid), started right after the server, from outside it (a
#: stopped or hung server cannot stop itself): polls every 0.5 s; when the build is gone, SIGTERM to the
#: server, SIGKILL after 5 s. Ends by itself when the server is gone.
_WATCHDOG = """# districtgen: prefect server watchdog
import os, signal, sys, time
parent, server = int(sys.argv[1]), int(sys.argv[2])

def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True

while os.getppid() == parent and alive(server):
    time.sleep(0.5)
if alive(server):
    os.kill(server, signal.SIGTERM)
    deadline = time.monotonic() + 5.0
    while alive(server) and time.monotonic() < deadline:
        time.sleep(0.1)
    if alive(server):
        os.kill(server, signal.SIGKILL)
"""


@dataclass
class TemporaryServer:
    """Prefect's API server started by this process: ``process`` (its stderr in ``log``, a temporary file) and
    its ``watchdog`` process, both children of this process in sessions of their own (a Ctrl-C reaches only
    the build, which stops them after sending the runs' last logs)."""

    host: str
    port: int
    process: subprocess.Popen
    watchdog: subprocess.Popen
    log: IO[bytes]

    @classmethod
    def launch(cls, host: str, port: int) -> TemporaryServer:
        """Start the server on ``host``:``port`` (not waiting for it), then its watchdog."""
        log = tempfile.TemporaryFile()
        process = subprocess.Popen([sys.executable, "-c", _SERVER, str(os.getpid()), host, str(port)],
                                   stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
                                   env=server_environment(), start_new_session=True)
        try:
            watchdog = subprocess.Popen([sys.executable, "-c", _WATCHDOG, str(os.getpid()), str(process.pid)],
                                        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL, start_new_session=True)
        except BaseException:
            process.kill()
            process.wait()
            log.close()
            raise
        return cls(host, port, process, watchdog, log)

    @property
    def api_url(self) -> str:
        """The URL of the server's API (what ``PREFECT_API_URL`` is set to)."""
        return f"http://{self.host}:{self.port}/api"

    def answering(self, timeout_s: float) -> bool:
        """Whether ``/health`` answers 200 within ``timeout_s`` seconds."""
        try:
            return httpx.get(f"{self.api_url}/health", timeout=timeout_s).status_code == 200
        except httpx.HTTPError:
            return False

    def stderr_tail(self, size: int = 65536) -> str:
        """The last ``size`` bytes the server wrote on stderr (read without moving the shared file offset)."""
        fd = self.log.fileno()
        end = os.fstat(fd).st_size
        return os.pread(fd, min(size, end), max(0, end - size)).decode(errors="replace")

    def stop(self) -> None:
        """Stop the server (SIGTERM, SIGKILL after :data:`STOP_GRACE_S`) and its watchdog; wait for both. Safe
        to call again."""
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(STOP_GRACE_S)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.watchdog.terminate()
        self.watchdog.wait()
        self.log.close()

def server_environment() -> dict[str, str]:
    """The temporary server's environment: this one, with the Prefect settings in force here (the database,
    :func:`patient_settings`) and no UI."""
    from prefect.settings import get_current_settings  # optional: Prefect (pipeline extra)

    return {**os.environ, **get_current_settings().to_environment_variables(exclude_unset=True),
            "PREFECT_UI_ENABLED": "false"}


def start_server(timeout_s: float, ports: Sequence[int] = PORTS, host: str = HOST) -> TemporaryServer:
    """Start Prefect's temporary API server on a free port of ``ports`` (tried in random order) and wait until
    ``/health`` answers, by the wall clock, up to ``timeout_s`` seconds in all.

    If another program takes the port before the server binds it, another free port is tried (up to
    :data:`LAUNCH_ATTEMPTS` launches). Raises :class:`OrchestrationError` (one line) when no port is free, the
    server exits during startup (naming host, port and the server's last error line) or does not answer in
    time; no server process is left then."""
    deadline = time.monotonic() + timeout_s
    failure = ""
    for _ in range(LAUNCH_ATTEMPTS):
        port = free_port(host, random.sample(list(ports), len(ports)))
        if port is None:
            raise OrchestrationError(failure or no_free_port_message(host, ports))
        server = TemporaryServer.launch(host, port)
        try:
            failure = wait_until_answering(server, deadline, timeout_s)
        except BaseException:  # also Ctrl-C or SIGTERM (SystemExit) while waiting: no server left behind
            server.stop()
            raise
        if not failure:
            return server
    raise OrchestrationError(failure)


def wait_until_answering(server: TemporaryServer, deadline: float, timeout_s: float) -> str:
    """Wait until ``server`` answers (returns ""), or it could not bind its port (returns the one-line reason,
    the server stopped); raise :class:`OrchestrationError` if it exits for another reason or is not answering
    at ``deadline`` (a ``time.monotonic()`` value; ``timeout_s`` is quoted in the message)."""
    while True:
        status = server.process.poll()
        if status is not None:
            text = server.stderr_tail()
            server.stop()
            message = startup_exit_message(server.host, server.port, status, text)
            if bind_failed(text):
                return message
            raise OrchestrationError(message)
        if server.answering(min(30.0, max(1.0, deadline - time.monotonic()))):
            return ""
        if time.monotonic() >= deadline:
            server.stop()
            raise OrchestrationError(
                f"Prefect's temporary API server did not answer within {timeout_s:.0f} s (a very busy machine?): "
                "retry, raise DISTRICTGEN_PREFECT_STARTUP_TIMEOUT, run a Prefect server and set PREFECT_API_URL, "
                "or build with --no-prefect")
        time.sleep(0.2)


def free_port(host: str, ports: Iterable[int]) -> int | None:
    """The first of ``ports`` a TCP socket can bind on ``host`` now, or None."""
    for port in ports:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
            try:
                probe.bind((host, port))
            except OSError:
                continue
            return port
    return None


def port_span(ports: Sequence[int]) -> str:
    """``ports`` for a message: ``8000-8999`` for a range of consecutive ports, else the ports listed."""
    if isinstance(ports, range) and ports.step == 1 and len(ports) > 1:
        return f"{ports.start}-{ports.stop - 1}"
    return ", ".join(map(str, ports))


def no_free_port_message(host: str, ports: Sequence[int]) -> str:
    """One line: no port of ``ports`` is free on ``host``."""
    return (f"no free port for Prefect's temporary API server on {host}: every port of {port_span(ports)} is in "
            "use: free one, run a Prefect server and set PREFECT_API_URL, or build with --no-prefect")


def bind_failed(stderr: str) -> bool:
    """Whether a server's stderr says it could not bind its address (the port was taken)."""
    text = stderr.lower()
    return "address already in use" in text or "error while attempting to bind" in text


def error_line(text: str, limit: int = 300) -> str:
    """The line of a process's stderr ``text`` that says what went wrong, at most ``limit`` characters, without
    terminal colour codes: the last exception line (``sqlalchemy.exc.OperationalError: ...``), else the last
    non-empty line, else ""."""
    lines = [line.strip() for line in re.sub(r"\x1b\[[0-9;]*m", "", text).splitlines() if line.strip()]
    errors = [line for line in lines if re.match(r"[A-Za-z_][\w.]*(Error|Exception)\b", line)]
    return (errors or lines or [""])[-1][:limit]


def exit_status_text(status: int, stderr: str = "") -> str:
    """A process's end for people, with its last stderr line if any: ``exit status 3: <line>``, ``killed by
    SIGKILL, signal 9``."""
    if status >= 0:
        ended = f"exit status {status}"
    else:
        try:
            ended = f"killed by {signal.Signals(-status).name}, signal {-status}"
        except ValueError:
            ended = f"killed by signal {-status}"
    line = error_line(stderr, 150)
    return f"{ended}: {line}" if line else ended


def startup_exit_message(host: str, port: int, status: int, stderr: str) -> str:
    """One line for a temporary server that exited before answering: the port taken, or its last error."""
    if bind_failed(stderr):
        return (f"Prefect's temporary API server could not listen on {host}:{port}: address already in use "
                "(another program took the port): retry, run a Prefect server and set PREFECT_API_URL, or build "
                "with --no-prefect")
    return (f"Prefect's temporary API server on {host}:{port} exited during startup "
            f"({exit_status_text(status, stderr)}): run a Prefect server and set PREFECT_API_URL, or build with "
            "--no-prefect")


# ---------------------------------------------------------------------------------- the API lost mid-build
def exception_chain(error: BaseException) -> Iterator[BaseException]:
    """``error``, its causes and contexts, and the members of exception groups among them (each once)."""
    pending, seen = [error], set()
    while pending:
        current = pending.pop()
        if current is None or id(current) in seen:
            continue
        seen.add(id(current))
        yield current
        pending.extend([current.__cause__, current.__context__])
        if isinstance(current, BaseExceptionGroup):
            pending.extend(current.exceptions)


def lost_connection(error: BaseException, api_url: str) -> httpx.TransportError | None:
    """The transport failure (refused, reset, timed out, closed mid-answer) of a request to ``api_url`` behind
    ``error``, or None. A failure whose request is unknown counts (only Prefect's client uses httpx here)."""
    for cause in exception_chain(error):
        if isinstance(cause, httpx.TransportError):
            try:
                url = str(cause.request.url)
            except RuntimeError:  # no request attached
                return cause
            if url.startswith(api_url.rstrip("/")):
                return cause
    return None


def lost_api_message(api_url: str, cause: BaseException, server_note: str = "") -> str:
    """One line: the Prefect API at ``api_url`` was lost (``cause``; ``server_note`` on the server's fate)
    and a rerun resumes from the cache."""
    text = " ".join(str(cause).split()) or "(no message)"
    note = f"; {server_note}" if server_note else ""
    return (f"lost the connection to the Prefect API at {api_url} ({type(cause).__name__}: {text[:200]}{note}): "
            "rerun the same command to resume (trained surrogates and simulations are reused from the cache), "
            "or build with --no-prefect")


def server_fate(server: TemporaryServer | None) -> str:
    """What became of the temporary server, for :func:`lost_api_message`: "" if none or still running."""
    if server is None or server.process.poll() is None:
        return ""
    return f"the temporary server had ended ({exit_status_text(server.process.returncode, server.stderr_tail())})"


@contextmanager
def api_loss_in_one_line(api_url: str, server: TemporaryServer | None = None) -> Iterator[None]:
    """Turn a lost connection to the Prefect API at ``api_url`` inside the block into one
    :class:`OrchestrationError` line (other errors pass unchanged)."""
    try:
        yield
    except Exception as error:
        cause = lost_connection(error, api_url)
        if cause is None or isinstance(error, InputError):
            raise
        raise OrchestrationError(lost_api_message(api_url, cause, server_fate(server))) from None
