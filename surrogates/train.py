"""Training of one building's LSTM surrogate on an ILV table.

Objective: the model is trained the way the environment runs it. After many cheap teacher-forced updates
whose temperature history is perturbed by noise (warm start, :func:`warm_start`: they fit the hour-to-hour
response without copying the temperature input: whole 48-h sequences with the state carried), each
training sample is a chunk of a reference run (one warm-up hour, the model's lookback, + ``chunk_hours``
predicted hours) rolled out closed-loop with the stateful sliding window of :func:`surrogates.model.rollout`
from zero state, and the loss is the mean squared
error of the whole rollout (normalised indoor temperature), back-propagated through the feedback; the last
epochs use longer chunks at a low rate (multi-day drift). Chunk offsets are re-drawn every epoch so chunk
boundaries move. The weights of the epoch with the lowest closed-loop validation RMSE (degC) are kept.

Splits, by reference run and time (see :func:`split_segments`); min-max bounds come from the training rows
only; windows never cross a run boundary because every sample lies inside one run.
"""

from __future__ import annotations

import copy
import functools
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import pandas as pd
import torch
from tqdm.auto import tqdm

from citylearn_env.errors import InputError
from surrogates.config import TrainConfig, recipe
from surrogates.generic import generic_state
from surrogates.ilv import OPTIONAL_COLUMNS, validate_ilv
from surrogates.model import (
    LSTMModel,
    Normalization,
    available_inputs,
    feature_matrix,
    rollout,
    seeded_model,
    torch_threads,
)
from surrogates.optim import FlatAdam
from surrogates.precision import Choice, Probe, choose

ROLES = ("train", "validation", "test")
#: progress units of the warm start (one per tenth of its updates), before the closed-loop epochs' units
WARM_START_UNITS = 10


@dataclass(frozen=True)
class Segment:
    """Rows ``start:stop`` of the sorted ILV table, all in one reference run."""

    reference: int
    start: int
    stop: int


@dataclass
class Trained:
    """A trained surrogate and what is needed to export and evaluate it."""

    model: LSTMModel
    normalization: Normalization
    inputs: list[str]
    config: TrainConfig
    splits: dict[str, list[Segment]]
    history: list[dict] = field(default_factory=list)
    best_epoch: int = 0
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    #: the numeric mode the updates ran in (``config.precision`` is what was asked for)
    precision: Choice | None = None

    def summary(self) -> dict:
        config = self.config.record()
        config["inputs"] = list(self.inputs)
        ran = self.precision.record() if self.precision is not None else {}
        return {"config": config, "best_epoch": self.best_epoch, "train_seconds": round(self.seconds, 2),
                "train_cpu_seconds": round(self.cpu_seconds, 2), **ran,
                "history": self.history,
                "splits": {role: [asdict(s) for s in segs] for role, segs in self.splits.items()}}


def run_segments(table: pd.DataFrame) -> dict[int, Segment]:
    """One segment per reference run of a validated (sorted) table."""
    refs = table["reference"].to_numpy()
    out = {}
    for ref in np.unique(refs):
        rows = np.flatnonzero(refs == ref)
        out[int(ref)] = Segment(int(ref), int(rows[0]), int(rows[-1]) + 1)
    return out


def _by_month(table: pd.DataFrame, segment: Segment) -> dict[str, list[Segment]]:
    """Calendar months of a run to train/validation/test in turn (Jan train, Feb val, Mar test, ...);
    runs shorter than three months are cut in three equal time blocks."""
    months = table["month"].to_numpy()[segment.start:segment.stop]
    roles: dict[str, list[Segment]] = {r: [] for r in ROLES}
    change = np.flatnonzero(np.diff(months) != 0) + 1
    bounds = [0, *change.tolist(), len(months)]
    if len(bounds) - 1 >= 3:
        blocks = list(zip(bounds[:-1], bounds[1:], strict=True))
        keys = [int(months[a]) - 1 for a, _ in blocks]
    else:
        third = len(months) // 3
        blocks = [(0, third), (third, 2 * third), (2 * third, len(months))]
        keys = [0, 1, 2]
    for (a, b), key in zip(blocks, keys, strict=True):
        roles[ROLES[key % 3]].append(Segment(segment.reference, segment.start + a, segment.start + b))
    return roles


def split_segments(table: pd.DataFrame, use_free_float: bool = False, use_ideal: bool = False,
                   test_runs: int = 1) -> dict[str, list[Segment]]:
    """Train/validation/test segments.

    * partial-load runs (reference >= 2): with ``test_runs + 2`` or more, the last ``test_runs`` are test,
      the one before validation, the others train (``test_runs=0``: the caller tests on other runs); with
      fewer, the first trains and the last tests;
    * the ideal run (0) and, when partial runs are too few to fill a role, every run are split by calendar
      month (Jan/Apr/Jul/Oct train, Feb/May/Aug/Nov validation, Mar/Jun/Sep/Dec test);
    * the ideal run's training months are dropped unless ``use_ideal`` (its loads only mirror the weather,
      and leaving them out improved held-out partial-load RMSE on the benchmark houses);
    * the free-float run (1) trains when ``use_free_float``; by default it is left out: its temperatures
      (up to 40 degC in Austin) widen the min-max range and made held-out partial-load runs worse.
    """
    runs = run_segments(table)
    partial = sorted(r for r in runs if r >= 2)
    roles: dict[str, list[Segment]] = {r: [] for r in ROLES}
    by_month = [0] if 0 in runs else []
    if len(partial) >= test_runs + 2:
        held = len(partial) - test_runs
        roles["test"].extend(runs[r] for r in partial[held:])
        roles["validation"].append(runs[partial[held - 1]])
        roles["train"].extend(runs[r] for r in partial[:held - 1])
    elif len(partial) == 2:
        roles["train"].append(runs[partial[0]])
        roles["test"].append(runs[partial[1]])
    else:
        by_month.extend(partial)
    for ref in by_month:
        for role, segments in _by_month(table, runs[ref]).items():
            if role != "train" or ref != 0 or use_ideal:
                roles[role].extend(segments)
    if 1 in runs and use_free_float:
        roles["train"].append(runs[1])
    return roles


def within_months(table: pd.DataFrame, splits: dict[str, list[Segment]],
                  months: Sequence[int]) -> dict[str, list[Segment]]:
    """``splits`` cut to the rows of the calendar ``months``: each segment becomes its runs of consecutive rows
    in those months (a run's January and December are two segments: a sample never jumps a gap)."""
    inside = np.isin(table["month"].to_numpy(), list(months))
    out: dict[str, list[Segment]] = {}
    for role, segments in splits.items():
        out[role] = []
        for seg in segments:
            keep = np.concatenate([[False], inside[seg.start:seg.stop], [False]]).astype(np.int8)
            edges = np.flatnonzero(np.diff(keep))
            out[role].extend(Segment(seg.reference, seg.start + int(a), seg.start + int(b))
                             for a, b in zip(edges[::2], edges[1::2], strict=True))
    return out


def _chunks(x: np.ndarray, segments: Sequence[Segment], length: int, offset_rng: np.random.Generator | None,
            step: int) -> np.ndarray:
    """Cut windows of ``length`` rows, ``step`` apart, from every segment; random start offset per segment."""
    pieces = []
    for seg in segments:
        n = seg.stop - seg.start
        if n < length:
            continue
        offset = int(offset_rng.integers(0, min(step, n - length + 1))) if offset_rng is not None else 0
        for start in range(seg.start + offset, seg.stop - length + 1, step):
            pieces.append(x[start:start + length])
    return np.stack(pieces).astype(np.float32) if pieces else np.zeros((0, length, x.shape[1]), np.float32)


def check_trainable(table: pd.DataFrame, splits: dict[str, list[Segment]], config: TrainConfig) -> None:
    """Clear errors before any training: enough rows in the training and validation segments."""
    need = config.lookback + config.chunk_hours
    for role in ("train", "validation"):
        longest = max((s.stop - s.start for s in splits[role]), default=0)
        if longest < need if role == "train" else longest < config.lookback + 24:
            raise InputError(f"no {role} segment is long enough (longest {longest} h, need "
                             f"{need if role == 'train' else config.lookback + 24} h); supply longer runs or "
                             "more reference runs (0 = ideal, >= 2 partial loads)", column="reference")


def train_surrogate(table: pd.DataFrame, config: TrainConfig | None = None,
                    source: object = "<ILV table>", progress: Callable[[int, int], None] | None = None) -> Trained:
    """Validate ``table``, split it, and train one LSTM; deterministic on CPU for a given ``config.seed``
    (default: the build's recipe, :func:`surrogates.config.recipe`), also with other trainings running in other threads of the process: every
    draw comes from the config's seed through local generators, none from torch's global random state, and
    torch runs ``config.threads`` intra-op threads in the calling thread (:func:`torch_threads`).

    ``progress``: optional ``progress(done, total)`` in units of :func:`progress_units` (a tenth of the warm
    start's updates, then one per closed-loop epoch), called after each unit (progress bars)."""
    config = config or recipe()
    table = validate_ilv(table, source=source)
    inputs = available_inputs(table, config.inputs)
    # the contract's optional columns (set point, non-shiftable load) are used where the table has them
    missing = [n for n in config.inputs if n not in inputs and n not in OPTIONAL_COLUMNS]
    if missing:
        raise InputError("input not in the ILV table", file=source, column=missing[0])
    splits = split_segments(table, config.use_free_float, config.use_ideal, config.test_runs)
    if config.months:
        splits = within_months(table, splits, config.months)
        if not splits["train"]:
            raise InputError(f"no training rows in the months {','.join(map(str, config.months))} (the season the "
                             "model is to serve): give a table that covers them, or train on every month (the "
                             "build's [surrogate] season_margin = 6)", file=source, column="months")
    check_trainable(table, splits, config)
    started = time.perf_counter()
    with torch_threads(config.threads):
        return _fit(table, inputs, splits, config, started, progress, update_precision(config))


def progress_units(config: TrainConfig) -> int:
    """Progress units of one training: :data:`WARM_START_UNITS` for the warm start (when it runs), then one
    per closed-loop epoch."""
    return (WARM_START_UNITS if config.pretrain_steps > 0 else 0) + config.epochs


def update_precision(config: TrainConfig) -> Choice:
    """The precision ``config``'s updates run in on this CPU (:func:`surrogates.precision.choose`), measured
    on the warm start's own update: a teacher-forced ``pretrain_sequence_hours`` sequence batch of
    ``pretrain_batch_size`` through this network size, forward and backward, on ``config.threads`` threads.
    Cached per process, so the build's cache key and the trainer see the same choice."""
    shape = (config.num_layers, config.hidden_size, len(config.inputs), config.pretrain_batch_size,
             config.pretrain_sequence_hours)
    with torch_threads(config.threads):
        return choose(config.precision, _update_probe(*shape))


@functools.cache
def _update_probe(layers: int, hidden: int, n_inputs: int, batch: int, hours: int) -> Probe:
    generator = torch.Generator().manual_seed(0)
    rows = torch.rand(batch, hours, n_inputs, generator=generator)
    model = seeded_model(n_inputs, hidden, layers, 0)  # global random state untouched (other threads train)
    weights = model.flat_weights()

    def run(dtype: torch.dtype) -> None:
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=dtype == torch.bfloat16):
            prediction = model.sequence(rows, weights)
        prediction.float().square().mean().backward()

    return Probe(f"surrogate update (LSTM {layers} x {hidden}, batch {batch} x {hours} h)", run)


def _fit(table, inputs, splits, config: TrainConfig, started: float, progress=None,
         precision: Choice | None = None) -> Trained:
    precision = precision or update_precision(config)
    config = replace(config, precision=precision.precision)  # what runs, for the updates below
    cpu_clock = training_cpu_clock(config.threads)
    cpu_started = cpu_clock()
    rng = np.random.default_rng(config.seed)
    norm, x = _normalised(table, inputs, splits["train"])
    scale = float(norm.maximum[-1] - norm.minimum[-1])
    val = _validation_chunks(x, splits["validation"], config)
    # local generator, not torch.manual_seed: the global stream is shared with concurrent trainings (threads)
    model = seeded_model(len(inputs), config.hidden_size, config.num_layers, config.seed)
    generic = generic_state(inputs, config.hidden_size, config.num_layers) if config.start == "generic" else None
    if generic is not None:  # else (no generic model of this size): the seeded random start
        model.load_state_dict(generic)
    run_starts = {run.start for run in run_segments(table).values()}
    anchors = [seg for seg in splits["train"] if seg.start in run_starts]  # training segments starting a run
    optimizer = FlatAdam(model, config.learning_rate if generic is None else config.generic_learning_rate)
    bar = _progress(config)
    warm = WARM_START_UNITS if config.pretrain_steps > 0 else 0
    total = progress_units(config)

    def tick(done: int) -> None:
        _advance(bar, progress, done, total)

    warm_start(model, optimizer, x, splits["train"], config, rng, anchors, tick)
    best, best_epoch, history = _closed_loop_phase(model, x, splits["train"], val, config, rng, scale,
                                                   started, lambda epoch: tick(warm + epoch), bar)
    if bar is not None:
        bar.close()
    model.load_state_dict(best)
    model.eval()
    return Trained(model, norm, inputs, config, splits, history, best_epoch, time.perf_counter() - started,
                   cpu_clock() - cpu_started, precision)


def training_cpu_clock(threads: int) -> Callable[[], float]:
    """The CPU clock [s] that measures one training: with one torch thread every update runs in the calling
    thread, so its own CPU time (``time.thread_time``) is the training's cost even while other trainings or
    work run in other threads of the process (the build trains two houses at once in a thread pool, where the
    process's CPU time counted both); with more threads, the process's CPU time."""
    return time.thread_time if threads == 1 else time.process_time


def _normalised(table: pd.DataFrame, inputs: Sequence[str],
                train: Sequence[Segment]) -> tuple[Normalization, np.ndarray]:
    """Min-max bounds of the training rows and every row of ``table``'s inputs normalised by them."""
    raw = feature_matrix(table, inputs)
    train_rows = np.concatenate([np.arange(s.start, s.stop) for s in train])
    norm = Normalization.fit(raw[train_rows])
    return norm, norm.apply(raw)


def _validation_chunks(x: np.ndarray, segments: Sequence[Segment], config: TrainConfig) -> torch.Tensor:
    """Closed-loop validation samples: chunks of ``validation_hours`` (+ lookback warm-up) of the validation
    segments, or each long-enough segment whole (the shortest length) when none is that long."""
    val = _chunks(x, segments, config.lookback + config.validation_hours, None, config.validation_hours)
    if len(val) == 0:  # short validation segments: use each whole
        shortest = min(s.stop - s.start for s in segments if s.stop - s.start >= config.lookback + 24)
        val = _chunks(x, segments, shortest, None, shortest)
    return torch.from_numpy(val)


def _closed_loop_phase(model: LSTMModel, x: np.ndarray, segments: Sequence[Segment], val: torch.Tensor,
                       config: TrainConfig, rng: np.random.Generator, scale: float, started: float,
                       tick: Callable[[int], None], bar: tqdm | None) -> tuple[dict, int, list[dict]]:
    """The closed-loop epochs after the warm start, with a fresh Adam (the warm start's moments made the first
    closed-loop epochs diverge): ``chunk_hours`` chunks at ``finetune_learning_rate``, then the last
    ``long_chunk_epochs`` on ``long_chunk_hours`` chunks at ``long_chunk_learning_rate``. The weights'
    exponential moving average is validated after every epoch; returns the best epoch's averaged weights, that
    epoch and the history (RMSE in degC: ``scale`` is the training temperature range). ``tick(epochs_done)``
    after each epoch; ``bar`` shows the last epoch's RMSE."""
    optimizer = FlatAdam(model, config.finetune_learning_rate)
    averaged = copy.deepcopy(model)
    lr = config.finetune_learning_rate
    longest = max(s.stop - s.start for s in segments)  # check_trainable: >= lookback + chunk_hours
    hours = min(config.chunk_hours, longest - config.lookback)
    best, best_rmse, best_epoch, history, updates = None, math.inf, 0, [], 0
    for epoch in range(config.epochs):
        if epoch == config.long_start:
            hours = min(config.long_chunk_hours, longest - config.lookback)
            lr = config.long_chunk_learning_rate
        optimizer.lr = lr
        train_rmse, updates = closed_loop_epoch(model, optimizer, x, segments, config, hours, rng, averaged,
                                                updates)
        train_rmse *= scale
        val_rmse = _validation_rmse(averaged, val, config.lookback) * scale
        history.append({"epoch": epoch, "chunk_hours": hours, "learning_rate": lr,
                        "train_rmse_c": round(train_rmse, 4), "val_closed_loop_rmse_c": round(val_rmse, 4),
                        "seconds": round(time.perf_counter() - started, 2)})
        if bar is not None:
            bar.set_postfix(train=f"{train_rmse:.3f}C", val=f"{val_rmse:.3f}C")
        tick(epoch + 1)
        if val_rmse < best_rmse:
            best, best_rmse, best_epoch = copy.deepcopy(averaged.state_dict()), val_rmse, epoch
        if config.max_seconds and time.perf_counter() - started > config.max_seconds:
            break
    return best, best_epoch, history


def _bf16(config: TrainConfig) -> bool:
    """Whether the updates run in bfloat16 (``config.precision`` resolved by :func:`update_precision`)."""
    return config.precision == "bfloat16"


def _autocast(config: TrainConfig) -> torch.autocast:
    """bfloat16 autocast on CPU when the updates run in bfloat16 (a no-op context otherwise)."""
    return torch.autocast("cpu", dtype=torch.bfloat16, enabled=_bf16(config))


def _validation_rmse(model: LSTMModel, val: torch.Tensor, lookback: int) -> float:
    """Closed-loop RMSE (normalised units) of ``model`` over the validation chunks, float32, no autograd."""
    model.eval()
    with torch.inference_mode():
        pred = rollout(model, val, lookback, closed_loop=True)
        return float(torch.sqrt(torch.mean((pred - val[:, lookback:, -1]) ** 2)))


def ema_update(averaged: Sequence[torch.Tensor], values: Sequence[torch.Tensor], decay: float) -> None:
    """In place ``mean = decay * mean + (1 - decay) * value`` for every tensor pair (two multi-tensor ops;
    the same arithmetic, hence bits, as ``mean.mul_(decay).add_(value, alpha=1 - decay)`` per tensor)."""
    with torch.no_grad():
        torch._foreach_mul_(averaged, decay)
        torch._foreach_add_(averaged, values, alpha=1.0 - decay)


def closed_loop_epoch(model: LSTMModel, optimizer: FlatAdam, x: np.ndarray, segments: Sequence[Segment],
                      config: TrainConfig, hours: int, rng: np.random.Generator, averaged: LSTMModel,
                      updates: int) -> tuple[float, int]:
    """One epoch of closed-loop training on chunks of ``hours`` predicted hours (+ lookback warm-up), batch
    size scaled so each update sees about ``batch_size x chunk_hours`` predicted hours; ``averaged`` follows
    the weights as an exponential moving average (``config.ema_decay`` per update, debiased over the first of
    all ``updates`` so far). Returns the RMSE of the normalised temperature over the epoch and the update
    count after it."""
    chunks = torch.from_numpy(_chunks(x, segments, config.lookback + hours, rng, hours))
    order = torch.from_numpy(rng.permutation(len(chunks)))
    batch_size = max(16, config.batch_size * config.chunk_hours // hours)
    model.train()
    parameters, means = list(model.parameters()), list(averaged.parameters())
    losses = []
    for k in range(0, len(chunks), batch_size):
        batch = chunks[order[k:k + batch_size]]
        with _autocast(config):
            prediction = rollout(model, batch, config.lookback, closed_loop=True)
        loss = torch.mean((prediction.float() - batch[:, config.lookback:, -1]) ** 2)
        optimizer.zero_grad()
        loss.backward()
        optimizer.clip_grad_norm(1.0)
        optimizer.step()
        updates += 1
        # debiased start: the average follows closely over the first updates
        ema_update(means, parameters, min(config.ema_decay, (1 + updates) / (10 + updates)))
        losses.append(float(loss.detach()))
    return math.sqrt(float(np.mean(losses))), updates


def warm_start(model: LSTMModel, optimizer: FlatAdam, x: np.ndarray, segments: Sequence[Segment], config: TrainConfig,
               rng: np.random.Generator, anchors: Sequence[Segment] = (),
               tick: Callable[[int], None] | None = None) -> None:
    """Teacher-forced warm start (fast, batched): brings the weights near a good one-step predictor before
    the closed-loop stateful fine-tuning. Every temperature of the history but the first
    ``pretrain_clean_hours`` of a sample is perturbed by ``pretrain_noise`` drawn afresh per update (robustness
    to the fed-back errors of closed loop).

    The stateful sliding window of one row (lookback 1) is a plain recurrent model, so whole sequences of
    ``pretrain_sequence_hours`` are teacher-forced in one LSTM call (:meth:`LSTMModel.sequence`; state from
    zero at each sequence's start, every hour predicted, offsets re-drawn on every pass, gradients clipped at
    norm 1); every pass also holds the first sequence of each segment in ``anchors``
    (:func:`warm_start_sequences`).

    Row ``t`` of a sample holds the exogenous inputs of hour ``t+1`` and the temperature of hour ``t``.
    ``tick(k)`` after each k-th tenth of the updates (:data:`WARM_START_UNITS`): the build's progress line
    moves during what is most of the training time."""
    if config.pretrain_steps < 1:
        return
    longest = max(s.stop - s.start for s in segments)  # check_trainable: >= 1 + chunk_hours
    hours = min(config.pretrain_sequence_hours, longest - 1)

    def draw() -> torch.Tensor:
        return torch.from_numpy(warm_start_sequences(x, segments, hours, rng, anchors))

    weights = model.flat_weights()
    model.train()
    marks = {max(1, round(config.pretrain_steps * k / WARM_START_UNITS)): k for k in range(1, WARM_START_UNITS + 1)}
    for done, batch in enumerate(_batches(draw, config.pretrain_batch_size, config.pretrain_steps, rng), 1):
        temps = perturb_history(batch[:, :-1, -1:], config.pretrain_noise, config.pretrain_clean_hours, rng)
        rows = torch.cat([batch[:, 1:, :-1], temps], dim=2)
        with _autocast(config):
            prediction = model.sequence(rows, weights)
        loss = torch.mean((prediction.float() - batch[:, 1:, -1]) ** 2)
        optimizer.zero_grad()
        loss.backward()
        optimizer.clip_grad_norm(1.0)
        optimizer.step()
        if tick is not None and done in marks:
            tick(marks[done])


def warm_start_sequences(x: np.ndarray, segments: Sequence[Segment], hours: int, rng: np.random.Generator,
                         anchors: Sequence[Segment] = ()) -> np.ndarray:
    """One pass of the warm start's samples, (n, hours + 1, inputs) float32: sequences of
    ``hours + 1`` rows, ``hours`` apart, from every segment at a random offset, then the first sequence of
    each segment of ``anchors`` (long enough)."""
    samples = _chunks(x, segments, hours + 1, rng, hours)
    starts = [x[seg.start:seg.start + hours + 1] for seg in anchors if seg.stop - seg.start > hours]
    return np.concatenate([samples, np.stack(starts).astype(np.float32)]) if starts else samples


def perturb_history(temps: torch.Tensor, std: float, clean_hours: int, rng: np.random.Generator) -> torch.Tensor:
    """``temps`` (samples, hours, 1; normalised temperatures) plus Gaussian noise of standard deviation
    ``std`` (normalised units) on every hour but the first ``clean_hours`` of each sample. The noise is drawn
    for the whole shape whatever ``clean_hours`` is, so the random stream does not depend on it; ``std`` 0
    draws nothing and returns ``temps``."""
    if std <= 0:
        return temps
    noise = rng.normal(0.0, std, temps.shape).astype(np.float32)
    noise[:, :clean_hours] = 0.0
    return temps + torch.from_numpy(noise)


def _batches(draw: Callable[[], torch.Tensor], batch_size: int, steps: int,
             rng: np.random.Generator) -> Iterator[torch.Tensor]:
    """``steps`` batches of ``batch_size`` samples: passes over ``draw()`` (called at the start of each pass),
    each pass in a new random order."""
    done = 0
    while done < steps:
        samples = draw()
        order = torch.from_numpy(rng.permutation(len(samples)))
        for k in range(0, len(samples), batch_size):
            if done == steps:
                return
            done += 1
            yield samples[order[k:k + batch_size]]


def _progress(config: TrainConfig) -> tqdm | None:
    """The training's progress bar in :func:`progress_units` (None without ``config.progress``)."""
    if not config.progress:
        return None
    return tqdm(total=progress_units(config), desc="surrogate", unit="step", leave=False)


def _advance(bar: tqdm | None, progress: Callable[[int, int], None] | None, done: int, total: int) -> None:
    """Unit ``done`` of ``total`` reached: on the progress bar and to the caller's ``progress(done, total)``."""
    if bar is not None:
        bar.update(done - bar.n)
    if progress is not None:
        progress(done, total)
