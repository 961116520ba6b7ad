"""Progress of a build: rich bars on a terminal, plain log lines otherwise, nothing but errors when quiet.

The build reports two kinds of events to the process's *active* reporter (:func:`active`):

* stages (:func:`stage`, :func:`advance`, :func:`end`): ``site signals``, ``houses`` (simulation + training per
  house), ``ingest``, ``surrogates``, ``validate``; ``advance`` counts finished buildings of a stage;
* building steps (:func:`report`): a building's current step (``simulate``, ``train``, ...) and, for
  training, epochs done of the epoch budget (training may stop early: the bar then jumps to done).

Per-building work may run in other threads (Prefect's thread pool: they see the same reporter) or in Dask
worker processes, which have no reporter: there :func:`report` sends the event to the scheduler as a Dask
event on topic :data:`TOPIC`, and :func:`forward_dask_events` relays them to the build's reporter.
Reporters: :class:`Reporter` (quiet, the default), :class:`LogReporter` (one line per event, to stderr;
training epochs at each quarter of the budget), :class:`RichReporter` (a rich progress display on stderr).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

#: Dask event topic of building reports sent from worker processes
TOPIC = "districtgen-progress"
#: stage key (the runner's step name) -> what the display says
STAGES = {"prefect api": "Prefect API: start the temporary server", "site signals": "site signals (weather, PV, prices, carbon)", "house": "houses: simulate + train",
          "ingest": "buildings: ingest", "surrogate": "surrogates: train", "validate": "validate: no control + RBC"}


class Reporter:
    """Receives progress events and shows nothing (``--quiet``; also the default when no build is active)."""

    def stage(self, name: str, total: int | None = None) -> None:
        """A stage starts; ``total``: number of buildings it covers (None: not per building)."""

    def advance(self, name: str, label: str) -> None:
        """Building ``label`` finished stage ``name``."""

    def end(self, name: str) -> None:
        """Stage ``name`` finished."""

    def building(self, label: str, what: str, done: int | None = None, total: int | None = None) -> None:
        """Building ``label`` is at step ``what`` (``done`` of ``total`` units, e.g. epochs, when given)."""

    def close(self) -> None:
        """The build ended (successfully or not): release the display."""


class LogReporter(Reporter):
    """Plain lines ``districtgen: [  12.3 s] ...`` on ``stream`` (not a terminal: logs, CI, pipes)."""

    def __init__(self, stream: TextIO | None = None):
        self.stream = stream or sys.stderr
        self.started = time.perf_counter()
        self.counts: dict[str, list[int | None]] = {}
        self.lock = threading.Lock()

    def _line(self, text: str) -> None:
        with self.lock:
            self.stream.write(f"districtgen: [{time.perf_counter() - self.started:7.1f} s] {text}\n")
            self.stream.flush()  # not print(): Prefect's log_prints would take it into its run logs

    def stage(self, name: str, total: int | None = None) -> None:
        self.counts[name] = [0, total]
        self._line(f"{STAGES.get(name, name)}: started" + (f" ({total} buildings)" if total else ""))

    def advance(self, name: str, label: str) -> None:
        done, total = self.counts.setdefault(name, [0, None])
        self.counts[name][0] = (done or 0) + 1
        self._line(f"{STAGES.get(name, name)}: {label} done ({self.counts[name][0]}/{total or '?'})")

    def end(self, name: str) -> None:
        self._line(f"{STAGES.get(name, name)}: finished")

    def building(self, label: str, what: str, done: int | None = None, total: int | None = None) -> None:
        if done is None or total is None:
            self._line(f"{label}: {what}")
        elif done == total or done == 1 or done % max(1, total // 4) == 0:  # a few lines per building
            self._line(f"{label}: {what} {done}/{total}")


class RichReporter(Reporter):
    """A rich progress display on stderr: one bar per stage and one per building (its step and epochs)."""

    def __init__(self, console: Any = None):
        from rich.console import Console  # rich loads only for an interactive progress display
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            SpinnerColumn,
            TextColumn,
            TimeElapsedColumn,
        )

        self.progress = Progress(SpinnerColumn(), TextColumn("{task.description:<34}"), BarColumn(),
                                 MofNCompleteColumn(), TimeElapsedColumn(),
                                 console=console or Console(stderr=True), transient=False)
        self.stages: dict[str, Any] = {}
        self.buildings: dict[str, Any] = {}
        self.progress.start()

    def stage(self, name: str, total: int | None = None) -> None:
        self.stages[name] = self.progress.add_task(STAGES.get(name, name), total=total or 1)

    def advance(self, name: str, label: str) -> None:
        if name in self.stages:
            self.progress.advance(self.stages[name])
        if label in self.buildings:
            self.progress.update(self.buildings[label], description=f"  {label}: done")

    def end(self, name: str) -> None:
        if name in self.stages:
            task = self.stages[name]
            self.progress.update(task, completed=self.progress.tasks[task].total)

    def building(self, label: str, what: str, done: int | None = None, total: int | None = None) -> None:
        if label not in self.buildings:
            self.buildings[label] = self.progress.add_task(f"  {label}", total=None)
        self.progress.update(self.buildings[label], description=f"  {label}: {what}", completed=done or 0,
                             total=total)

    def close(self) -> None:
        self.progress.stop()


def make_reporter(mode: str = "auto", stream: TextIO | None = None) -> Reporter:
    """``quiet`` -> :class:`Reporter`; ``auto`` -> :class:`RichReporter` when ``stream`` (default stderr) is a
    terminal, else :class:`LogReporter`; ``plain`` / ``rich`` force one."""
    stream = stream or sys.stderr
    if mode == "quiet":
        return Reporter()
    if mode == "rich" or (mode == "auto" and stream.isatty()):
        from rich.console import Console  # rich loads only for an interactive progress display

        return RichReporter(Console(file=stream))
    return LogReporter(stream)


_ACTIVE: Reporter = Reporter()


@contextmanager
def active(reporter: Reporter) -> Iterator[Reporter]:
    """Make ``reporter`` the process's reporter for the block (every thread sees it); closed on exit."""
    global _ACTIVE
    previous, _ACTIVE = _ACTIVE, reporter
    try:
        yield reporter
    finally:
        _ACTIVE = previous
        reporter.close()


def current() -> Reporter:
    return _ACTIVE


def stage(name: str, total: int | None = None) -> None:
    _ACTIVE.stage(name, total)


def advance(name: str, label: str) -> None:
    _ACTIVE.advance(name, label)


def end(name: str) -> None:
    _ACTIVE.end(name)


def report(label: str, what: str, done: int | None = None, total: int | None = None) -> None:
    """Building ``label`` is at step ``what``; from a Dask worker (no active reporter) it is sent to the
    scheduler as an event on :data:`TOPIC` instead."""
    if type(_ACTIVE) is Reporter:
        worker = _dask_worker()
        if worker is not None:
            worker.log_event(TOPIC, {"label": label, "what": what, "done": done, "total": total})
        return
    _ACTIVE.building(label, what, done, total)


def epochs(label: str):
    """A training progress callback ``(epochs_done, epochs) -> None`` reporting building ``label``."""
    def callback(done: int, total: int) -> None:
        report(label, "train", done, total)

    return callback


def _dask_worker():
    """The Dask worker this code runs in, or None (no distributed installed, or not in a worker)."""
    module = sys.modules.get("distributed")
    if module is None:
        return None
    try:
        return module.get_worker()
    except ValueError:
        return None


def forward_dask_events(client: Any) -> None:
    """Relay building reports that Dask workers send on :data:`TOPIC` to this process's active reporter."""
    def relay(event: tuple) -> None:
        message = event[1]
        _ACTIVE.building(message["label"], message["what"], message.get("done"), message.get("total"))

    client.subscribe_topic(TOPIC, relay)
