"""How close the torch workloads run to this CPU's float32 limit, and what bfloat16 and threads change.

    .venv/bin/python benchmarks/precision_limits.py sac [--obs 10 --act 1 --repeats 7 --threads 1 2]
    .venv/bin/python benchmarks/precision_limits.py surrogate [--repeats 3]

``sac``: one SAC update (SB3 defaults, batch 256, [256, 256] networks) of the ``fast`` and ``torch`` back ends
in float32 (and bfloat16), at each thread count; the update's floating-point work counted from its matrix
products (:func:`sac_update_flops`); the machine's float32 limit measured on exactly those products run back
to back (:func:`sac_products`), so "achieved / limit" says how much of the update is not matrix work. All
variants alternate in one process, ``repeats`` rounds of ``updates`` updates; medians.
``surrogate``: the default trainer (``TrainConfig()``) on a synthetic FMU house's ILV table: CPU seconds, the
LSTM's floating-point work per training (:func:`lstm_training_flops`) and the same ratio against a float32
product of the LSTM's gate shape.
Prints markdown rows, the CPU (:func:`surrogates.precision.capability`) and the ``uptime`` load average.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import time

import torch

from surrogates.precision import capability

BATCH, HIDDEN = 256, 256


def sac_products(obs: int, act: int, batch: int = BATCH, hidden: int = HIDDEN) -> list[tuple[int, int, int, int]]:
    """The matrix products of one ``fast`` SAC update as (members, m, k, n), in the order the update runs them
    (pipeline/paper_sac_fast.py ``train_step``)."""
    z, x = obs + act + 1, obs + 1
    return [
        # actor on s and s' (2B rows)
        (1, 2 * batch, x, hidden), (1, 2 * batch, hidden, hidden), (1, 2 * batch, hidden, 2 * act),
        # target critics and critics, stacked (4 members)
        (4, batch, z, hidden), (4, batch, hidden, hidden), (4, batch, hidden, 1),
        # critic backward with weight gradients (2 members)
        (2, batch, hidden, hidden), (2, z, batch, hidden), (2, hidden, batch, hidden), (2, hidden, batch, 1),
        # critics on the policy's action, and back to the action
        (2, batch, z, hidden), (2, batch, hidden, hidden), (2, batch, hidden, 1),
        (2, batch, hidden, hidden), (2, batch, hidden, act),
        # actor backward
        (1, batch, 2 * act, hidden), (1, batch, hidden, hidden), (1, x, batch, hidden), (1, hidden, batch, hidden),
        (1, hidden, batch, 2 * act),
    ]


def sac_update_flops(obs: int, act: int) -> float:
    """Floating-point operations of the matrix products of one SAC update (2 m k n per product and member)."""
    return float(sum(2 * b * m * k * n for b, m, k, n in sac_products(obs, act)))


def time_products(products, dtype: torch.dtype, repeats: int, rounds: int = 20) -> float:
    """Median seconds of one pass over ``products`` (operands made once)."""
    g = torch.Generator().manual_seed(0)
    operands = [(torch.randn(b, m, k, generator=g).to(dtype), torch.randn(b, k, n, generator=g).to(dtype))
                for b, m, k, n in products]
    for a, b in operands:
        torch.bmm(a, b)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        for _ in range(rounds):
            for a, b in operands:
                torch.bmm(a, b)
        times.append((time.perf_counter() - started) / rounds)
    return statistics.median(times)


def sac(obs: int, act: int, repeats: int, updates: int, threads: list[int]) -> None:
    from pipeline.paper_sac import LeanSAC, flushed_subnormals
    from pipeline.paper_sac_fast import FastSAC

    g = torch.Generator().manual_seed(0)
    batch = (torch.rand(BATCH, obs, generator=g), torch.rand(BATCH, act, generator=g) * 2 - 1,
             torch.randn(BATCH, 1, generator=g), torch.rand(BATCH, obs, generator=g), torch.zeros(BATCH, 1))
    variants = [("fast", FastSAC, False), ("torch", LeanSAC, False)]
    if capability().native_bf16:
        variants += [("fast", FastSAC, True), ("torch", LeanSAC, True)]
    flops = sac_update_flops(obs, act)
    rows = []
    with flushed_subnormals():
        for n in threads:
            torch.set_num_threads(n)
            limit = time_products(sac_products(obs, act), torch.float32, repeats)
            agents = {(name, bf16): cls(obs, act, seed=0, bf16=bf16, threads=n) for name, cls, bf16 in variants}
            times: dict[tuple[str, bool], list[float]] = {k: [] for k in agents}
            for agent in agents.values():  # warm-up
                for _ in range(3):
                    agent.train_step(*batch)
            for _ in range(repeats):
                for key, agent in agents.items():
                    started = time.perf_counter()
                    for _ in range(updates):
                        agent.train_step(*batch)
                    times[key].append((time.perf_counter() - started) / updates)
            rows.append(f"| float32 products alone (the limit) | {n} | {limit * 1e3:.2f} | "
                        f"{flops / limit / 1e9:.1f} | 100 % |")
            for (name, bf16), values in times.items():
                t = statistics.median(values)
                rows.append(f"| {name}, {'bfloat16' if bf16 else 'float32'} | {n} | {t * 1e3:.2f} | "
                            f"{flops / t / 1e9:.1f} | {100 * limit / t:.0f} % |")
    print(f"CPU: {capability().describe()}; {uptime()}")
    print(f"SAC update, {obs} observations, {act} action(s), batch {BATCH}: {flops / 1e6:.0f} MFLOP of products\n")
    print("| variant | threads | ms per update (median) | GFLOP/s | float32 limit / time |\n|---|---|---|---|---|")
    print("\n".join(rows))


def lstm_training_flops(config, n_inputs: int, hours_trained: float) -> float:
    """Floating-point operations of the LSTM's gate products over ``hours_trained`` sample-hours of training
    (forward 2 x 4H x (in + H) per layer and hour, backward twice that: 3x in all)."""
    h = config.hidden_size
    per_hour = sum(2 * 4 * h * ((n_inputs if layer == 0 else h) + h) for layer in range(config.num_layers))
    return 3.0 * per_hour * hours_trained


def surrogate(repeats: int) -> None:
    import tempfile
    from pathlib import Path

    from surrogates.sources.fmu import simulate_ilv_fmu
    from surrogates.train import TrainConfig, train_surrogate
    from tests.surrogates.fmu.build import VARIABLE_MAP, build_room_fmu, synthetic_house

    with tempfile.TemporaryDirectory() as folder:
        fmu = build_room_fmu(Path(folder))
        table = simulate_ilv_fmu(fmu, synthetic_house(fmu, days=365, t_mean=12.0), VARIABLE_MAP, n_partial=4,
                                 seed=0, start_values={"T0": 22.0})
    config = TrainConfig(progress=False)
    cpu = []
    for _ in range(repeats):
        trained = train_surrogate(table, config)
        cpu.append(trained.cpu_seconds)
    print(f"CPU: {capability().describe()}; {uptime()}; precision {trained.precision.precision}")
    print(f"default trainer: {statistics.median(cpu):.1f} s of CPU (runs {', '.join(f'{c:.1f}' for c in cpu)})")


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("workload", choices=("sac", "surrogate"))
    parser.add_argument("--obs", type=int, default=10)
    parser.add_argument("--act", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--updates", type=int, default=20)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    if args.workload == "sac":
        sac(args.obs, args.act, args.repeats, args.updates, args.threads)
    else:
        surrogate(args.repeats)


if __name__ == "__main__":
    main()
