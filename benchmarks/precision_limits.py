"""How close the torch workloads run to this CPU's float32 limit, and what bfloat16 and threads change.

    .venv/bin/python benchmarks/precision_limits.py sac [--obs 10 --act 1 --repeats 7 --threads 1 2 --bf16 --clock cpu]
    .venv/bin/python benchmarks/precision_limits.py surrogate [--repeats 3 --table ILV.parquet]
    .venv/bin/python benchmarks/precision_limits.py cache [--repeats 40]

``sac``: one SAC update (SB3 defaults, batch 256, [256, 256] networks) of the ``fast`` and ``torch`` back ends
in float32 (and bfloat16), at each thread count; the update's floating-point work counted from its matrix
products (:func:`sac_update_flops`); the limit is that work at the measured float32 rate of the update's
dominant (256 x 256) x (256 x 256) product, and the update's own products run back to back
(:func:`sac_products`) show what its shapes cost before any element-wise work. All variants alternate in one
process after a warm-up, ``repeats`` rounds of ``updates`` updates (one where bfloat16 is emulated), each round
timing the limit's product, the products alone and every variant back to back; medians, the ratios per round.
``surrogate``: the default trainer (``TrainConfig()``) on an ILV table (default: the test fixture's full-year
house): CPU seconds per phase, the LSTM's floating-point work (:func:`lstm_training_flops`) and the same ratio
against the float32 rate of the LSTM's time-batched gate product.
``cache``: the limit's own product, float32, with its operands hot (the same three matrices every call, as
the limit is timed) against cold (a ring of operand sets of :data:`COLD_RING_BYTES`, larger than any core's
L2, as the update meets its weights and activations), alternating, the ratio per round.
Prints markdown rows, the CPU (:func:`surrogates.precision.capability`) and the ``uptime`` load average.
"""

from __future__ import annotations

import argparse
import functools
import itertools
import statistics
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import torch

from surrogates.precision import capability, matmul_probe

#: --clock: wall seconds, or this process's CPU seconds (all its threads: with one thread, the time the work
#: took on a CPU shared with other processes, not the time it waited for one)
CLOCKS: dict[str, Callable[[], float]] = {"wall": time.perf_counter, "cpu": time.process_time}

BATCH, HIDDEN = 256, 256
#: seconds of products run before any is timed
WARM_UP_S = 1.0
#: ``cache``: bytes of the ring of operand sets the cold product cycles through (the Xeon's L2 is 2 MiB per core)
COLD_RING_BYTES = 32 * 2**20


def warm_up(units: list[Callable[[], object]]) -> None:
    """Run ``units`` in turn for :data:`WARM_UP_S` seconds: the first passes of a process run up to 30 % slower
    (measured on the Xeon family 6 model 207: 102 against 146 GFLOP/s)."""
    started = time.perf_counter()
    while time.perf_counter() - started < WARM_UP_S:
        for unit in units:
            unit()


def sac_products(obs: int, act: int, batch: int = BATCH, hidden: int = HIDDEN) -> list[tuple[int, int, int, int]]:
    """The matrix products of one ``fast`` SAC update as (members, m, k, n), in the order and orientation the
    update runs them (pipeline/paper/sac/fast.py ``train_step``; thin products transposed, see
    ``FastSAC._critics_forward``; the rank-2A product into the actor's last hidden layer runs element-wise in
    ``kernels.outer_mask``, its 0.26 MFLOP counted here all the same)."""
    z, x = obs + act + 1, obs + 1
    return [
        # actor on s and s' (2B rows); its output layer transposed
        (1, 2 * batch, x, hidden), (1, 2 * batch, hidden, hidden), (1, 2 * act, hidden, 2 * batch),
        # target critics and critics, stacked (4 members); output layer transposed
        (4, batch, z, hidden), (4, batch, hidden, hidden), (4, 1, hidden, batch),
        # critic backward with weight gradients (2 members)
        (2, batch, hidden, hidden), (2, z, batch, hidden), (2, hidden, batch, hidden), (2, 1, batch, hidden),
        # critics on the policy's action, and back to the action
        (2, batch, z, hidden), (2, batch, hidden, hidden), (2, 1, hidden, batch),
        (2, batch, hidden, hidden), (2, act, hidden, batch),
        # actor backward
        (1, batch, 2 * act, hidden), (1, batch, hidden, hidden), (1, x, batch, hidden), (1, hidden, batch, hidden),
        (1, 2 * act, batch, hidden),
    ]


def sac_update_flops(obs: int, act: int) -> float:
    """Floating-point operations of the matrix products of one SAC update (2 m k n per product and member)."""
    return float(sum(2 * b * m * k * n for b, m, k, n in sac_products(obs, act)))


def alternate(units: dict, counts: dict, repeats: int,
              clock: Callable[[], float] = time.perf_counter) -> dict[object, list[float]]:
    """Seconds per call of each of ``units`` in each of ``repeats`` rounds, every round running each unit
    ``counts[key]`` times back to back after a :func:`warm_up`: this machine's speed drifts by up to 1.5x
    between minutes (a VM's host), so ratios are taken per round."""
    warm_up(list(units.values()))
    times: dict[object, list[float]] = {key: [] for key in units}
    for _ in range(repeats):
        for key, unit in units.items():
            begun = clock()
            for _ in range(counts[key]):
                unit()
            times[key].append((clock() - begun) / counts[key])
    return times


def time_products(products, dtype: torch.dtype, repeats: int, rounds: int = 20,
                  clock: Callable[[], float] = time.perf_counter) -> float:
    """Median seconds of one pass over ``products`` ((batch, m, k, n) each; operands made once): the probe
    of :mod:`surrogates.precision`, :func:`warm_up`, then ``repeats`` timings of ``rounds`` passes on
    ``clock``."""
    probe = matmul_probe("products", tuple(products))
    return statistics.median(alternate({"products": functools.partial(probe.run, dtype)}, {"products": rounds},
                                       repeats, clock)["products"])


def sac(obs: int, act: int, repeats: int, updates: int, threads: list[int], bf16: bool, clock: str = "wall") -> None:
    from pipeline.paper.sac.fast import FastSAC
    from pipeline.paper.sac.lean import LeanSAC
    from pipeline.paper.sac.train import flushed_subnormals

    g = torch.Generator().manual_seed(0)
    batch = (torch.rand(BATCH, obs, generator=g), torch.rand(BATCH, act, generator=g) * 2 - 1,
             torch.randn(BATCH, 1, generator=g), torch.rand(BATCH, obs, generator=g), torch.zeros(BATCH, 1))
    variants = [("fast", FastSAC, False), ("torch", LeanSAC, False)]
    if capability().native_bf16 or bf16:  # emulated bfloat16 only when asked: each update takes seconds
        variants += [("fast", FastSAC, True), ("torch", LeanSAC, True)]
    flops = sac_update_flops(obs, act)
    now = CLOCKS[clock]
    rows = []
    with flushed_subnormals():
        for n in threads:
            torch.set_num_threads(n)
            agents = {(name, bf16): cls(obs, act, seed=0, bf16=bf16, threads=n) for name, cls, bf16 in variants}
            # every round times the limit's product, the products alone and each variant back to back
            square = matmul_probe("limit", ((1, BATCH, HIDDEN, HIDDEN),))
            products = matmul_probe("products", tuple(sac_products(obs, act)))
            units: dict[object, Callable[[], object]] = {
                "limit": functools.partial(square.run, torch.float32),
                "alone": functools.partial(products.run, torch.float32)}
            units.update({key: functools.partial(agent.train_step, *batch) for key, agent in agents.items()})
            counts = {"limit": 200, "alone": updates}
            counts.update({key: updates if capability().native_bf16 or not key[1] else 1 for key in agents})
            times = alternate(units, counts, repeats, now)
            # the limit: the update's FLOPs at the square product's rate, per round; ratios per round
            limits = [t * flops / (2 * BATCH * HIDDEN * HIDDEN) for t in times.pop("limit")]
            limit = statistics.median(limits)
            ratio = {key: statistics.median(t / lim for t, lim in zip(values, limits, strict=True))
                     for key, values in times.items()}
            rows.append(f"| the limit: all FLOPs at the (256 x 256) x (256 x 256) float32 rate | {n} | "
                        f"{limit * 1e3:.2f} | {flops / limit / 1e9:.1f} | 1.00 |")
            alone = statistics.median(times.pop("alone"))
            rows.append(f"| the update's float32 products alone | {n} | {alone * 1e3:.2f} | "
                        f"{flops / alone / 1e9:.1f} | {ratio['alone']:.2f} |")
            for (name, bf16), values in times.items():
                t = statistics.median(values)
                rows.append(f"| {name}, {'bfloat16' if bf16 else 'float32'} | {n} | {t * 1e3:.2f} | "
                            f"{flops / t / 1e9:.1f} | {ratio[(name, bf16)]:.2f} |")
    print(f"CPU: {capability().describe()}; {uptime()}; clock: {clock}")
    print(f"SAC update, {obs} observations, {act} action(s), batch {BATCH}: {flops / 1e6:.0f} MFLOP of products\n")
    print("| variant | threads | ms per update (median) | GFLOP/s | time / limit (median of rounds) |\n"
          "|---|---|---|---|---|")
    print("\n".join(rows))


def lstm_training_flops(config, n_inputs: int, hours_trained: float) -> float:
    """Floating-point operations of the LSTM's gate products over ``hours_trained`` sample-hours of training
    (forward 2 x 4H x (in + H) per layer and hour, backward twice that: 3x in all)."""
    h = config.hidden_size
    per_hour = sum(2 * 4 * h * ((n_inputs if layer == 0 else h) + h) for layer in range(config.num_layers))
    return 3.0 * per_hour * hours_trained


def surrogate(repeats: int, table_path: Path) -> None:
    """The default trainer on ``table_path``: CPU seconds of the warm start and of the closed-loop epochs, and
    their gate-product FLOPs against the float32 rate of the time-batched gate product (all hours of a batch
    at once: (batch x hours, in + H) x (in + H, 4H)), the best shape an LSTM's work can be put in."""
    import surrogates.train as trainer
    from surrogates.ilv import read_ilv
    from surrogates.model import available_inputs

    table = read_ilv(table_path)
    config = trainer.TrainConfig(progress=False)
    phases: dict[str, list[float]] = {"warm start": [], "closed-loop epochs": [], "whole training": []}

    def timed(name, fn):
        def run(*args, **kwargs):
            started = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[name] = spent.get(name, 0.0) + time.process_time() - started
        return run

    original = trainer.warm_start, trainer.closed_loop_epoch
    trainer.warm_start = timed("warm start", trainer.warm_start)
    trainer.closed_loop_epoch = timed("closed-loop epochs", trainer.closed_loop_epoch)
    try:
        for _ in range(repeats):
            spent: dict[str, float] = {}
            trained = trainer.train_surrogate(table, config)
            for name, value in spent.items():
                phases[name].append(value)
            phases["whole training"].append(trained.cpu_seconds)
    finally:
        trainer.warm_start, trainer.closed_loop_epoch = original
    n_inputs = len(available_inputs(table, config.inputs))
    train_hours = sum(s.stop - s.start for s in trained.splits["train"])
    hours = {"warm start": config.pretrain_steps * config.pretrain_batch_size * config.pretrain_sequence_hours,
             "closed-loop epochs": config.epochs * train_hours}
    hours["whole training"] = sum(hours.values())
    rows = config.pretrain_batch_size * config.pretrain_sequence_hours
    gate = 4 * config.hidden_size
    rate = 2 * rows * (n_inputs + config.hidden_size) * gate / time_products(
        [(1, rows, n_inputs + config.hidden_size, gate)], torch.float32, 7, 200)
    print(f"CPU: {capability().describe()}; {uptime()}; precision {trained.precision.precision}")
    print(f"default trainer on {table_path} ({len(table)} rows), {repeats} run(s); float32 rate of the "
          f"time-batched gate product ({rows} x {n_inputs + config.hidden_size}) x "
          f"({n_inputs + config.hidden_size} x {gate}): {rate / 1e9:.1f} GFLOP/s\n")
    print("| phase | CPU s (median; runs) | gate-product GFLOP | GFLOP/s | limit s | limit / CPU |\n"
          "|---|---|---|---|---|---|")
    for name, values in phases.items():
        cpu = statistics.median(values)
        flops = lstm_training_flops(config, n_inputs, hours[name])
        print(f"| {name} | {cpu:.1f} ({', '.join(f'{v:.1f}' for v in values)}) | {flops / 1e9:.0f} | "
              f"{flops / cpu / 1e9:.1f} | {flops / rate:.1f} | {100 * flops / rate / cpu:.0f} % |")


def cache(repeats: int, calls: int = 20) -> None:
    """The limit's (256 x 256) x (256 x 256) float32 product with hot and with cold operands (module docstring)."""
    torch.set_num_threads(1)
    g = torch.Generator().manual_seed(0)

    def operands() -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        return torch.randn(BATCH, HIDDEN, generator=g), torch.randn(HIDDEN, HIDDEN, generator=g), \
            torch.empty(BATCH, HIDDEN)

    hot = operands()
    ring = [operands() for _ in range(COLD_RING_BYTES // (4 * (2 * BATCH * HIDDEN + HIDDEN * HIDDEN)))]
    cold_sets = itertools.cycle(ring)

    def run_hot() -> None:
        torch.mm(hot[0], hot[1], out=hot[2])

    def run_cold() -> None:
        a, b, out = next(cold_sets)
        torch.mm(a, b, out=out)

    times = alternate({"hot": run_hot, "cold": run_cold}, {"hot": calls, "cold": calls}, repeats)
    flops = 2 * BATCH * HIDDEN * HIDDEN
    print(f"CPU: {capability().describe()}; {uptime()}; {len(ring)} cold operand sets ({COLD_RING_BYTES >> 20} MiB)")
    print("| operands | us per product (median) | GFLOP/s | cold / hot (median of rounds) |\n|---|---|---|---|")
    for key, values in times.items():
        ratio = statistics.median(c / h for c, h in zip(values, times["hot"], strict=True))
        t = statistics.median(values)
        print(f"| {key} | {t * 1e6:.1f} | {flops / t / 1e9:.1f} | {ratio:.3f} |")


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("workload", choices=("sac", "surrogate", "cache"))
    parser.add_argument("--obs", type=int, default=10)
    parser.add_argument("--act", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--updates", type=int, default=20)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--clock", choices=tuple(CLOCKS), default="wall",
                        help="sac: time on the wall clock or in CPU seconds of this process (see CLOCKS)")
    parser.add_argument("--bf16", action="store_true", help="sac: bfloat16 variants also where bfloat16 is "
                                                             "emulated (one update per round)")
    parser.add_argument("--table", type=Path, default=Path("tests/fixtures/synthetic_district/ilv/900001.parquet"),
                        help="ILV table of the surrogate workload (default: a full-year synthetic house)")
    args = parser.parse_args()
    if args.workload == "sac":
        sac(args.obs, args.act, args.repeats, args.updates, args.threads, args.bf16, args.clock)
    elif args.workload == "cache":
        cache(args.repeats)
    else:
        surrogate(args.repeats, args.table)


if __name__ == "__main__":
    main()
