"""Soft actor-critic for the paper's learning benchmarks, with stable-baselines3's SAC defaults.

The paper trains SB3's ``SAC("MlpPolicy", env)`` (all defaults) on normalised observations and [0, 1]
actions. Four interchangeable back ends run that same algorithm with those same settings:

* ``sb3`` -- stable-baselines3 itself (the paper's code path);
* ``sbx`` -- sbx-rl, the JAX re-implementation of SB3 by its maintainers (same defaults);
* ``torch`` -- :class:`pipeline.paper.sac.lean.LeanSAC`: the same update, written for one CPU thread without SB3's per-step
  machinery (the two critics as one batched ensemble, no critic weight gradients in the actor step, one
  fused Adam per network);
* ``fast`` (the default) -- :class:`pipeline.paper.sac.fast.FastSAC`: the same update with hand-written
  gradients (checked against autograd's to 1e-5 in float32), no autograd graph;
* ``torch-bf16`` -- ``torch`` asked to run in bfloat16 (the same as ``--sac torch --precision bfloat16``).

``torch`` and ``fast`` run in the precision :func:`sac_precision` chooses (:mod:`surrogates.precision`):
float32, or bfloat16 matrix products (parameters, optimiser state, losses and element-wise steps stay
float32) where the CPU multiplies bfloat16 natively and a measurement of the update's own product shapes
finds it faster. sb3 and sbx run in float32.

The SB3 defaults reproduced by :class:`~pipeline.paper.sac.lean.LeanSAC` (stable_baselines3/sac/sac.py and policies.py, 2.x):
actor and both critics MLPs [256, 256] with ReLU; squashed diagonal Gaussian, log-std clamped to
[-20, 2], log-prob correction ``log(1 - tanh(u)^2 + 1e-6)``; Adam (torch defaults) at 3e-4 for actor,
critics and the entropy coefficient; entropy coefficient learned from 1.0 toward a target entropy of
-(action dimension); replay buffer 1e6, batch 256, tau 0.005, gamma 0.99, one gradient step per
environment step after 100 uniform-random warm-up steps; the critic is updated before the actor, which
then uses the updated critic; target networks updated every step. Terminal steps do not bootstrap.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from citylearn_env.errors import InputError
from pipeline.paper.sac.fast import FastSAC
from pipeline.paper.sac.lean import BATCH_SIZE, HIDDEN, LEARNING_STARTS, LeanSAC
from surrogates.precision import Choice, check_precision, choose, matmul_probe, median_times

BACKENDS = ("fast", "torch", "torch-bf16", "sbx", "sb3")


#: the libraries' back ends (sb3: torch float32; sbx: JAX float32) take no precision setting
LIBRARY_PRECISION = Choice("float32", "float32", "sb3 and sbx run in float32")


@dataclass(frozen=True)
class TrainedPolicy:
    """A trained agent: ``act(normalised_obs) -> action in [0, 1]`` (deterministic), plus training facts:
    environment steps, wall-clock seconds and CPU seconds of this process (all its threads)."""

    act: Callable[[np.ndarray], np.ndarray]
    backend: str
    steps: int
    seconds: float
    cpu_seconds: float
    precision: Choice


def train_sac(env, episodes: int, seed: int, backend: str = "fast", threads: int = 1,
              precision: str = "auto") -> TrainedPolicy:
    """Train SAC on ``env`` (normalised observations, [0, 1] actions, a gymnasium Env) for ``episodes``
    full episodes; return the deterministic policy. ``backend``: one of :data:`BACKENDS`; ``threads``: torch
    threads (the torch back ends and SB3); ``precision``: ``auto``, ``float32`` or ``bfloat16`` for the
    ``fast`` and ``torch`` back ends (:func:`sac_precision`)."""
    if backend not in BACKENDS:
        raise InputError(f"unknown SAC back end {backend!r}; known: {', '.join(BACKENDS)}", column="--sac")
    check_precision(precision)
    env.reset(seed=seed)
    steps = max(episodes, 1) * (env.unwrapped.episode_length - 1)
    start, cpu = time.perf_counter(), time.process_time()
    with flushed_subnormals():
        act, choice = _train(env, steps, seed, backend, threads, precision)
    return TrainedPolicy(act, backend, steps, time.perf_counter() - start, time.process_time() - cpu, choice)


def sac_precision(requested: str, obs_dim: int, act_dim: int, threads: int = 1) -> Choice:
    """The precision a ``fast`` / ``torch`` SAC update runs in here (:func:`surrogates.precision.choose`),
    measured on the update's own matrix products: the two critics (stacked) and the actor on a batch, the
    hidden layers (H x H) and the first layers (inputs x H)."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    torch.set_num_threads(threads)
    products = ((2, BATCH_SIZE, HIDDEN, HIDDEN), (2, BATCH_SIZE, obs_dim + act_dim + 1, HIDDEN),
                (2, BATCH_SIZE, HIDDEN, HIDDEN), (2, HIDDEN, BATCH_SIZE, HIDDEN))
    return choose(requested, matmul_probe(f"SAC update ({obs_dim} observations, {act_dim} actions)", products))


@contextmanager
def flushed_subnormals() -> Iterator[None]:
    """Subnormal floats flushed to zero while training, restored after (a process-wide CPU setting that
    other code, e.g. hypothesis, must not inherit). Late in training Adam's second moments and the gradients
    reach subnormals, and x86 arithmetic on them is ~100x slower (measured on ``fast``: 182 -> 250 steps per
    CPU second); every torch back end gets the same setting."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    torch.set_flush_denormal(True)
    try:
        yield
    finally:
        torch.set_flush_denormal(False)


#: a second torch thread is used for one SAC training only when it measures at least this much faster
THREAD_GAIN = 1.2


def sac_threads(cores: int) -> tuple[int, str]:
    """Torch threads for one SAC training that may use ``cores`` cores, and why: 1 where ``cores`` is 1;
    else ``cores`` when a short measurement of the update's dominant product (two critics' (256 x 256) x
    (256 x 256) layers) at ``cores`` threads against 1 finds it at least :data:`THREAD_GAIN` times faster,
    else 1. The measurement sees the machine as it is: on a busy machine, extra OpenMP threads wait for
    descheduled partners and measure slower. Cached per process."""
    if cores <= 1:
        return 1, "one core per task"
    return _measured_threads(cores)


@functools.cache
def _measured_threads(cores: int) -> tuple[int, str]:
    import torch  # torch: the CLI imports this module; torch loads on first use

    before = torch.get_num_threads()
    probe = matmul_probe("SAC threads", ((4, BATCH_SIZE, HIDDEN, HIDDEN),))

    def on(threads: int) -> Callable[[], None]:
        def run() -> None:
            torch.set_num_threads(threads)
            probe.run(torch.float32)
        return run

    try:
        times = median_times({1: on(1), cores: on(cores)}, repeats=5, budget_s=1.0)
    finally:
        torch.set_num_threads(before)
    gain = times[1] / times[cores]
    if gain >= THREAD_GAIN:
        return cores, f"{cores} threads measured {gain:.2f}x faster than 1"
    return 1, f"{cores} threads measured only {gain:.2f}x faster than 1"


def _train(env, steps: int, seed: int, backend: str, threads: int,
           precision: str) -> tuple[Callable[[np.ndarray], np.ndarray], Choice]:
    """The training loop of ``backend``; returns the deterministic policy and the precision that ran."""
    if backend in ("sb3", "sbx"):
        return _train_library(env, steps, seed, backend, threads), LIBRARY_PRECISION

    obs_dim, act_dim = env.observation_space.shape[0], env.action_space.shape[0]
    choice = sac_precision("bfloat16" if backend == "torch-bf16" else precision, obs_dim, act_dim, threads)
    agent = (FastSAC if backend == "fast" else LeanSAC)(obs_dim, act_dim, seed=seed, bf16=choice.bf16,
                                                        threads=threads)
    agent.learn(env, steps, seed)
    return agent.act, choice


def _train_library(env, steps: int, seed: int, backend: str, threads: int) -> Callable[[np.ndarray], np.ndarray]:
    """SB3 or SBX ``SAC("MlpPolicy", env)`` with defaults (``threads`` torch threads for SB3)."""
    if backend == "sb3":
        import torch  # torch: the CLI imports this module; torch loads on first use
        from stable_baselines3 import SAC

        torch.set_num_threads(threads)
        from stable_baselines3.common.logger import Logger  # optional extra: rl

        model = SAC("MlpPolicy", env, seed=seed, device="cpu", verbose=0, learning_starts=LEARNING_STARTS)
        model.set_logger(Logger(None, []))  # SB3's default logger leaves an empty SB3-<time> folder in /tmp
    else:
        try:
            from sbx import SAC  # optional extra: rl-fast
        except ImportError:
            raise InputError("the sbx back end needs sbx-rl: pip install 'districtgen[rl-fast]'",
                             column="--sac") from None
        model = SAC("MlpPolicy", env, seed=seed, verbose=0, learning_starts=LEARNING_STARTS)
    model.learn(total_timesteps=steps)

    def act(obs: np.ndarray) -> np.ndarray:
        return np.asarray(model.predict(obs, deterministic=True)[0], dtype=np.float64)

    return act
