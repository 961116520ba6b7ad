"""SAC back ends for the paper side by side: training throughput and final test-period cost.

    .venv/bin/python benchmarks/paper_speed.py throughput [--episodes 5 --repeats 3]
    .venv/bin/python benchmarks/paper_speed.py quality [--episodes 150 --seeds 0 1 --backends torch sbx] [--cores 2]
        [--precision float32]
    .venv/bin/python benchmarks/paper_speed.py collection [--repeats 3]
    .venv/bin/python benchmarks/paper_speed.py revision --against REV [--episodes 2 --repeats 3]

``throughput``: each back end trains SAC (SB3 defaults) on rlc-b1-c-bess_pv of the default district for
``episodes`` train-period episodes, round-robin over the back ends ``repeats`` times; the median
environment+training steps per second of each. ``quality``: each back end's full benchmark run (training
``episodes`` episodes, then the deterministic test period) per seed: B1's test-period cost and the seconds.
``revision``: the ``fast`` back end of the working tree against the one of git revision ``REV``
(``pipeline/paper/sac/fast.py`` loaded from ``git show``), alternating, steps per CPU second of each.
Prints markdown rows and the ``uptime`` load average (for benchmarks/README.md).
"""

from __future__ import annotations

import argparse
import functools
import statistics
import subprocess
import time
from pathlib import Path

SCHEMA = Path("artifacts/default/schema.json")
BENCH = "rlc-b1-c-bess_pv"


def load() -> tuple:
    from pipeline.paper.benchmarks import BENCHMARKS, load_district

    return load_district(SCHEMA), next(b for b in BENCHMARKS if b.id == BENCH)


def throughput(backends: list[str], episodes: int, repeats: int, threads: int = 1) -> None:
    from citylearn_env import CityLearnEnv
    from citylearn_env.wrappers import NormalizedActionWrapper, NormalizedObservationWrapper
    from pipeline.paper.benchmarks import TRAIN_DAYS, benchmark_schema
    from pipeline.paper.sac.train import train_sac

    district, bench = load()
    config = benchmark_schema(district, bench, (0, TRAIN_DAYS * 24 - 1))
    rates: dict[str, list[float]] = {b: [] for b in backends}
    cpu_rates: dict[str, list[float]] = {b: [] for b in backends}
    for backend in backends:  # warm-up: imports, JIT compilation
        train_sac(NormalizedActionWrapper(NormalizedObservationWrapper(CityLearnEnv(config))), 1, 0, backend, threads)
    for _ in range(repeats):
        for backend in backends:
            env = NormalizedActionWrapper(NormalizedObservationWrapper(CityLearnEnv(config)))
            trained = train_sac(env, episodes, 0, backend, threads)
            rates[backend].append(trained.steps / trained.seconds)
            cpu_rates[backend].append(trained.steps / trained.cpu_seconds)
            print(f"{backend} ({trained.precision.precision}): {rates[backend][-1]:.0f} steps/s wall, "
                  f"{cpu_rates[backend][-1]:.0f} per CPU s", flush=True)
    from surrogates.precision import capability

    print(f"CPU: {capability().describe()}; {uptime()}")
    print("| back end | steps/s wall (median; runs) | steps per CPU second (median; runs) | "
          "150 episodes at the CPU rate [s] |\n|---|---|---|---|")
    for backend, values in rates.items():
        cpu = statistics.median(cpu_rates[backend])
        print(f"| {backend} | {statistics.median(values):.0f} ({', '.join(f'{v:.0f}' for v in values)}) | "
              f"{cpu:.0f} ({', '.join(f'{v:.0f}' for v in cpu_rates[backend])}) | "
              f"{150 * (TRAIN_DAYS * 24 - 1) / cpu:.0f} |")


def collection(repeats: int) -> None:
    """Data collection alone: the wrapped environment stepped with random [0, 1] actions (steps per CPU s)."""
    import numpy as np

    from citylearn_env import CityLearnEnv
    from citylearn_env.wrappers import NormalizedActionWrapper, NormalizedObservationWrapper
    from pipeline.paper.benchmarks import TRAIN_DAYS, benchmark_schema

    district, bench = load()
    env = NormalizedActionWrapper(NormalizedObservationWrapper(
        CityLearnEnv(benchmark_schema(district, bench, (0, TRAIN_DAYS * 24 - 1)))))
    rng = np.random.default_rng(0)
    rates = []
    for _ in range(repeats):
        env.reset(seed=0)
        steps, cpu, done = 0, time.process_time(), False
        while not done:
            done = env.step(rng.uniform(0.0, 1.0, env.action_space.shape))[2]
            steps += 1
        rates.append(steps / (time.process_time() - cpu))
    print(uptime())
    print(f"environment alone: {statistics.median(rates):.0f} steps per CPU second (median of {repeats})")


def revision(against: str, episodes: int, repeats: int) -> None:
    import tempfile

    from revisions import import_source, source_at

    import pipeline.paper.sac.fast as current
    from citylearn_env import CityLearnEnv
    from citylearn_env.wrappers import NormalizedActionWrapper, NormalizedObservationWrapper
    from pipeline.paper.benchmarks import TRAIN_DAYS, benchmark_schema
    from pipeline.paper.sac.train import flushed_subnormals

    with tempfile.TemporaryDirectory() as folder:
        previous = import_source("paper_sac_fast_at_revision", source_at(against, "pipeline/paper/sac/fast.py"),
                                 Path(folder))
    district, bench = load()
    config = benchmark_schema(district, bench, (0, TRAIN_DAYS * 24 - 1))
    rates: dict[str, list[float]] = {against: [], "working tree": []}
    for _ in range(repeats):
        for name, module in ((against, previous), ("working tree", current)):
            env = NormalizedActionWrapper(NormalizedObservationWrapper(CityLearnEnv(config)))
            env.reset(seed=0)
            agent = module.FastSAC(env.observation_space.shape[0], env.action_space.shape[0], seed=0)
            steps = episodes * (env.unwrapped.episode_length - 1)
            with flushed_subnormals():
                cpu = time.process_time()
                agent.learn(env, steps, 0)
                rates[name].append(steps / (time.process_time() - cpu))
            print(f"{name}: {rates[name][-1]:.1f} steps per CPU s", flush=True)
    print(uptime())
    for name, values in rates.items():
        print(f"| fast at {name} | {statistics.median(values):.0f} ({', '.join(f'{v:.0f}' for v in values)}) |")


#: the float32 limit's rate is sampled every this many training steps (the host's speed drifts by minutes)
PROBE_EVERY = 250


class LimitProbes:
    """The float32 rate of the limit's (256 x 256) x (256 x 256) product (:func:`surrogates.precision.matmul_probe`,
    as ``precision_limits.py sac`` times it), sampled through a training run: every :data:`PROBE_EVERY`
    environment steps of a wrapped training env, 4 products are timed; the probes' own seconds are kept apart
    so they can be taken off the training time."""

    def __init__(self) -> None:
        import torch
        from precision_limits import BATCH, HIDDEN

        from surrogates.precision import matmul_probe

        self.product = functools.partial(matmul_probe("limit", ((1, BATCH, HIDDEN, HIDDEN),)).run, torch.float32)
        self.flops = 2.0 * BATCH * HIDDEN * HIDDEN
        self.rates: list[float] = []
        self.seconds = 0.0
        self.steps = 0

    def step(self) -> None:
        """One environment step: every :data:`PROBE_EVERY`-th samples the rate."""
        self.steps += 1
        if self.steps % PROBE_EVERY:
            return
        started = time.perf_counter()
        self.product()  # operands back into cache
        timed = time.perf_counter()
        for _ in range(4):
            self.product()
        ended = time.perf_counter()
        self.rates.append(4 * self.flops / (ended - timed))
        self.seconds += ended - started

    def wrap_training(self, train_sac):
        """``train_sac`` with its env stepping the probes and its seconds net of them."""
        import dataclasses

        import gymnasium

        probes = self

        class Probed(gymnasium.Wrapper):
            def step(self, action):
                probes.step()
                return self.env.step(action)

        def probed(env, *args, **kwargs):
            before = probes.seconds
            trained = train_sac(Probed(env), *args, **kwargs)
            spent = probes.seconds - before
            return dataclasses.replace(trained, seconds=trained.seconds - spent, cpu_seconds=trained.cpu_seconds - spent)
        return probed


def quality(backends: list[str], episodes: int, seeds: list[int], threads: int | None, cores: int,
            precision: str = "auto") -> None:
    """Each back end's full benchmark run per seed, and the float32 limit of its training: the FLOPs of its
    gradient steps (:func:`precision_limits.sac_update_flops`) at the float32 rate of the update's dominant
    (256 x 256) x (256 x 256) product, sampled through the training (:class:`LimitProbes`, median; the probes'
    time is taken off the training's) with the threads the run used."""
    import torch
    from precision_limits import sac_update_flops

    import pipeline.paper.benchmarks as benchmarks
    from citylearn_env import CityLearnEnv
    from citylearn_env.wrappers import NormalizedObservationWrapper
    from pipeline.paper.benchmarks import TRAIN_DAYS, RunOptions, benchmark_schema, run_benchmark
    from pipeline.paper.sac.lean import LEARNING_STARTS
    from surrogates.precision import capability

    district, bench = load()
    print(f"CPU: {capability().describe()}; {uptime()}")
    print("| back end | precision | threads | seed | episodes | B1 test cost $ | train wall s | train CPU s | "
          "total s | float32 limit s | train wall / limit |\n|---|---|---|---|---|---|---|---|---|---|---|")
    plain = benchmarks.train_sac
    for seed in seeds:
        for backend in backends:
            probes = LimitProbes()
            benchmarks.train_sac = probes.wrap_training(plain)
            started = time.perf_counter()
            options = RunOptions(sac_episodes=episodes, sac=backend, sac_threads=threads, cores=cores,
                                 precision=precision)
            try:
                r = run_benchmark(district, bench, seed=seed, options=options)
            finally:
                benchmarks.train_sac = plain
            total = time.perf_counter() - started - probes.seconds
            torch.set_num_threads(r["sac_threads"])
            updates = episodes * (TRAIN_DAYS * 24 - 1) - LEARNING_STARTS
            wrapped = NormalizedObservationWrapper(CityLearnEnv(benchmark_schema(district, bench, (0, 23))))
            dims = wrapped.observation_space.shape[0], wrapped.action_space.shape[0]
            limit = updates * sac_update_flops(*dims) / statistics.median(probes.rates)
            print(f"| {backend} | {r['precision']} | {r['sac_threads']} | {seed} | {episodes} | {r['cost']:.3f} | "
                  f"{r['train_seconds']:.0f} | {r['train_cpu_seconds']:.0f} | {total:.0f} | {limit:.0f} | "
                  f"{r['train_seconds'] / limit:.2f} |", flush=True)
    print(uptime())


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def main() -> None:
    from surrogates.precision import PRECISIONS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("part", choices=("throughput", "quality", "collection", "revision"))
    parser.add_argument("--against", default="HEAD", help="git revision of the anchor (revision)")
    parser.add_argument("--backends", nargs="+", default=["fast", "torch", "torch-bf16", "sbx", "sb3"])
    parser.add_argument("--episodes", type=int)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--threads", type=int, help="torch threads per training (throughput: default 1; quality: "
                                                    "default chosen as the paper does from --cores)")
    parser.add_argument("--cores", type=int, default=1, help="cores one run may use (quality)")
    parser.add_argument("--precision", default="auto", choices=PRECISIONS,
                        help="the SAC update's numeric mode (quality)")
    args = parser.parse_args()
    if args.part == "collection":
        collection(args.repeats)
    elif args.part == "revision":
        revision(args.against, args.episodes or 2, args.repeats)
    elif args.part == "throughput":
        throughput(args.backends, args.episodes or 5, args.repeats, args.threads or 1)
    else:
        quality(args.backends, args.episodes or 150, args.seeds, args.threads, args.cores, args.precision)


if __name__ == "__main__":
    main()
