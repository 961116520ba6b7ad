"""The numeric mode of every torch workload of the project, chosen per process from what the CPU does.

bfloat16 matrix products are fast only where the CPU multiplies bfloat16 natively (AVX512-BF16 or AMX on
x86-64, the BF16 extension on ARM) and oneDNN uses it; elsewhere torch emulates them and a 256 x 256 product
runs tens of times slower than in float32. So no workload assumes a CPU feature:

* :func:`capability` reads the CPU once (model name, the ISA features that matter, oneDNN's bfloat16 support);
* :func:`choose` turns a user's request (:data:`PRECISIONS`: ``auto``, ``float32``, ``bfloat16``) into the
  precision that runs. ``auto`` is bfloat16 only where oneDNN supports it natively *and* a short measurement
  of the workload's own shapes (a :class:`Probe`, about 0.1-0.3 s) shows it at least :data:`MIN_SPEEDUP`
  times faster than float32; float32 otherwise, with no measurement where bfloat16 is not native. Asking for
  ``bfloat16`` where it is emulated (or measured slower) runs it, and warns once per workload with the
  measured slowdown;
* an ``auto`` decision that needed a measurement is measured once per machine and recorded
  (:func:`recorded_choices`: ``precision.json`` in ``$DISTRICTGEN_CACHE_DIR``, else ``~/.cache/districtgen``,
  keyed by CPU, torch version, workload and threads): every later process reuses it, so two builds of one
  configuration on one machine train in one mode (a measurement under load could otherwise flip it). Delete
  the file to measure again.

Users: the ``fast`` and ``torch`` SAC back ends of the paper (:mod:`pipeline.paper.sac.train`) and the surrogate
trainer's updates (:mod:`surrogates.train`). Each records the :class:`Choice` that ran in its outputs.
"""

from __future__ import annotations

import functools
import json
import os
import platform
import statistics
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from citylearn_env.errors import InputError

if TYPE_CHECKING:  # torch is imported where it is used: the CLI reads PRECISIONS without it
    import torch

PRECISIONS = ("auto", "float32", "bfloat16")
#: ``auto`` picks bfloat16 only when the measured check finds it at least this many times faster: below it
#: the gain does not pay for the rounding (and a borderline measurement would flip between runs)
MIN_SPEEDUP = 1.15
#: /proc/cpuinfo flags (x86-64 ``flags``, ARM ``Features``) that decide matrix-product speed
RELEVANT_ISA = ("avx2", "fma", "avx512f", "avx512_bf16", "amx_tile", "amx_bf16", "amx_fp16", "asimd", "sve",
                "bf16", "i8mm")


@dataclass(frozen=True)
class Capability:
    """What this CPU offers: ``cpu`` model name, the :data:`RELEVANT_ISA` features it has, torch's dispatch
    level (``torch.backends.cpu.get_cpu_capability()``, e.g. ``AVX2``, ``AVX512``) and whether oneDNN
    multiplies bfloat16 natively here."""

    cpu: str
    isa: tuple[str, ...]
    dispatch: str
    native_bf16: bool
    #: x86 ``cpu family`` / ``model`` numbers (e.g. ``family 25 model 1``: Zen 3), where the model name is vague
    family: str = ""

    def describe(self) -> str:
        """One line for logs and benchmark tables, e.g.
        ``AMD EPYC, family 25 model 1 (avx2 fma; torch AVX2; bfloat16 emulated)``."""
        family = f", {self.family}" if self.family else ""
        return (f"{self.cpu}{family} ({' '.join(self.isa) or 'no listed ISA features'}; torch {self.dispatch}; "
                f"bfloat16 {'native' if self.native_bf16 else 'emulated'})")


@functools.cache
def capability() -> Capability:
    """This CPU's :class:`Capability` (read once per process)."""
    model, flags, numbers = platform.processor() or platform.machine(), set(), {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                key, _, value = line.partition(":")
                key = key.strip().lower()
                if key in ("model name", "cpu model", "hardware") and value.strip():
                    model = value.strip()
                elif key in ("flags", "features"):
                    flags.update(value.split())
                elif key in ("cpu family", "model") and key not in numbers:
                    numbers[key] = value.strip()
    except OSError:  # not Linux: the model from platform, features unknown
        pass
    import torch  # lazy: the torch-free CLI imports this module (PRECISIONS)

    isa = tuple(f for f in RELEVANT_ISA if f in flags)
    family = f"family {numbers['cpu family']} model {numbers['model']}" if len(numbers) == 2 else ""
    try:  # builds without oneDNN (some ARM and macOS wheels) lack the op: no native bfloat16 then
        native = bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        native = False
    return Capability(model, isa, torch.backends.cpu.get_cpu_capability(), native, family)


@dataclass(frozen=True)
class Probe:
    """A workload's measured check: ``run(dtype)`` does one representative unit of its work (a few matrix
    products or an update of its network) in ``dtype``; ``name`` keys the per-process cache and the warning."""

    name: str
    run: Callable[[torch.dtype], object]


@dataclass(frozen=True)
class Choice:
    """The precision that runs (``float32`` or ``bfloat16``), what was asked, why, and the measured speed of
    bfloat16 against float32 (float32 time / bfloat16 time; > 1: bfloat16 faster; None: not measured)."""

    precision: str
    requested: str
    reason: str
    bf16_speedup: float | None = None

    @property
    def bf16(self) -> bool:
        return self.precision == "bfloat16"

    @property
    def dtype(self) -> torch.dtype:
        import torch  # lazy: the torch-free CLI imports this module (PRECISIONS)

        return torch.bfloat16 if self.bf16 else torch.float32

    def record(self) -> dict[str, object]:
        """JSON-ready fields for results and timings files."""
        speedup = None if self.bf16_speedup is None else round(self.bf16_speedup, 3)
        return {"precision": self.precision, "precision_requested": self.requested, "precision_reason": self.reason,
                "bf16_speedup": speedup}


def check_precision(requested: str, column: str = "--precision") -> str:
    """``requested`` when it is one of :data:`PRECISIONS`, else one clear :class:`InputError` naming ``column``."""
    if requested not in PRECISIONS:
        raise InputError(f"unknown precision {requested!r}; known: {', '.join(PRECISIONS)}", column=column)
    return requested


def choose(requested: str, probe: Probe) -> Choice:
    """The :class:`Choice` for ``requested`` (:data:`PRECISIONS`) on ``probe``'s workload in this process.

    ``float32``: float32, nothing measured. ``auto``: float32 where oneDNN has no native bfloat16 (nothing
    measured), else bfloat16 when :func:`measure_speedup` finds it at least :data:`MIN_SPEEDUP` times faster.
    ``bfloat16``: bfloat16, measured where it is not native and a warning (once per workload and process)
    when it is emulated or slower than float32. The result is cached per (request, workload, threads)."""
    import torch  # lazy: the torch-free CLI imports this module (PRECISIONS)

    key = (check_precision(requested), probe.name, torch.get_num_threads())
    if key not in _CHOICES:
        _CHOICES[key] = _choose(requested, probe)
    return _CHOICES[key]


#: choices made in this process, by (request, workload name, torch threads)
_CHOICES: dict[tuple[str, str, int], Choice] = {}


def _choose(requested: str, probe: Probe) -> Choice:
    if requested == "float32":
        return Choice("float32", requested, "asked for")
    native = capability().native_bf16
    if requested == "auto" and not native:
        return Choice("float32", requested, "no native bfloat16 on this CPU")
    if requested == "auto":
        return _recorded_auto(probe)
    try:
        speedup = measure_speedup(probe)
    except RuntimeError as error:
        raise InputError(f"precision bfloat16: {probe.name} cannot run in bfloat16 here ({_first_line(error)}); "
                         "--precision auto or float32 runs it", column="precision") from None
    if not native or speedup < 1.0:
        how = "emulated" if not native else "native"
        warnings.warn(f"precision bfloat16 for {probe.name}: bfloat16 is {how} on {capability().cpu} and measured "
                      f"{1 / speedup:.1f}x slower than float32 here; --precision auto picks the faster one",
                      RuntimeWarning, stacklevel=4)
    return Choice("bfloat16", requested, "asked for" + ("" if native else " (emulated)"), speedup)


#: the file (in the cache root) that holds this machine's measured ``auto`` decisions
RECORD_FILE = "precision.json"


def record_path() -> Path:
    """Where this machine's ``auto`` decisions are recorded: ``$DISTRICTGEN_CACHE_DIR/precision.json``, else
    ``~/.cache/districtgen/precision.json``."""
    root = os.environ.get("DISTRICTGEN_CACHE_DIR") or Path.home() / ".cache" / "districtgen"
    return Path(root) / RECORD_FILE


def record_key(probe: Probe) -> str:
    """What an ``auto`` decision depends on: the CPU (model and relevant ISA), torch's version, the workload and
    the threads."""
    import torch  # lazy: the torch-free CLI imports this module (PRECISIONS)

    cpu = capability()
    return f"{cpu.describe()} | torch {torch.__version__} | {probe.name} | {torch.get_num_threads()} threads"


def recorded_choices(path: Path | None = None) -> dict[str, dict]:
    """The recorded decisions (key -> :meth:`Choice.record`); an unreadable or malformed file: none."""
    try:
        found = json.loads((path or record_path()).read_text())
    except (OSError, ValueError):
        return {}
    return {k: v for k, v in found.items() if isinstance(v, dict)} if isinstance(found, dict) else {}


def _recorded_auto(probe: Probe) -> Choice:
    """``auto`` where bfloat16 is native: the machine's recorded decision, else measured twice (the slower
    of the two speed-ups decides, so a measurement under load does not pick bfloat16) and recorded."""
    key, path = record_key(probe), record_path()
    found = recorded_choices(path).get(key)
    if found and found.get("precision") in ("float32", "bfloat16"):
        speedup = found.get("bf16_speedup")
        return Choice(found["precision"], "auto", f"recorded for this machine in {path}: {found.get('reason')}",
                      float(speedup) if isinstance(speedup, int | float) else None)
    try:
        speedup = min(measure_speedup(probe), measure_speedup(probe))
    except RuntimeError as error:  # no bfloat16 kernel for this workload in the libraries as loaded
        return Choice("float32", "auto", f"bfloat16 cannot run {probe.name} here: {_first_line(error)}")
    if speedup >= MIN_SPEEDUP:
        choice = Choice("bfloat16", "auto", f"native and measured {speedup:.2f}x faster", speedup)
    else:
        choice = Choice("float32", "auto", f"native but measured only {speedup:.2f}x faster", speedup)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        records = recorded_choices(path)
        records[key] = {"precision": choice.precision, "reason": choice.reason,
                        "bf16_speedup": round(speedup, 3)}
        temporary = path.with_name(f".{path.name}.{os.getpid()}")
        temporary.write_text(json.dumps(records, indent=1, sort_keys=True) + "\n")
        os.replace(temporary, path)
    except OSError:
        pass  # a read-only home: the decision holds for this process only
    return choice


def _first_line(error: Exception) -> str:
    return str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__


def measure_speedup(probe: Probe, repeats: int = 5, budget_s: float = 0.3) -> float:
    """float32 time / bfloat16 time of ``probe.run`` (:func:`median_times`). A library without a bfloat16
    kernel for the workload raises RuntimeError (seen: torch takes oneDNN's bfloat16 LSTM from the CPU's flags
    while oneDNN is held below that ISA by ``ONEDNN_MAX_CPU_ISA``)."""
    import torch  # lazy: the torch-free CLI imports this module (PRECISIONS)

    times = median_times({dtype: functools.partial(probe.run, dtype) for dtype in (torch.float32, torch.bfloat16)},
                         repeats, budget_s)
    return times[torch.float32] / max(times[torch.bfloat16], 1e-12)


def median_times(runs: dict, repeats: int = 5, budget_s: float = 0.3) -> dict:
    """Median seconds of each callable of ``runs`` (key -> callable): one warm-up each, then ``repeats``
    rounds alternating over them (the same machine state for all), stopping early once about ``budget_s``
    seconds are spent and two rounds are done (a slow variant, as emulated bfloat16 is, then runs fewer)."""
    times: dict = {key: [] for key in runs}
    spent = 0.0
    for run in runs.values():  # warm-up: kernels chosen, buffers allocated, thread pools started
        started = time.perf_counter()
        run()
        spent += time.perf_counter() - started
    for _ in range(repeats):
        for key, run in runs.items():
            started = time.perf_counter()
            run()
            times[key].append(time.perf_counter() - started)
        spent += sum(values[-1] for values in times.values())
        if spent > budget_s and len(next(iter(times.values()))) >= 2:
            break
    return {key: statistics.median(values) for key, values in times.items()}


def matmul_probe(name: str, products: tuple[tuple[int, int, int, int], ...]) -> Probe:
    """A :class:`Probe` of plain matrix products: for every (batch, m, k, n) of ``products``, ``batch``
    stacked (m, k) @ (k, n) products (the workload's own shapes), operands made once per dtype."""
    import torch  # lazy: the torch-free CLI imports this module (PRECISIONS)

    operands: dict[torch.dtype, list[tuple[torch.Tensor, torch.Tensor]]] = {}

    def run(dtype: torch.dtype) -> None:
        if dtype not in operands:
            g = torch.Generator().manual_seed(0)
            operands[dtype] = [(torch.randn(b, m, k, generator=g).to(dtype),
                                torch.randn(b, k, n, generator=g).to(dtype)) for b, m, k, n in products]
        for a, b in operands[dtype]:
            torch.bmm(a, b)

    return Probe(name, run)
