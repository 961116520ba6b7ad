"""Soft actor-critic for the paper's learning benchmarks, with stable-baselines3's SAC defaults.

The paper trains SB3's ``SAC("MlpPolicy", env)`` (all defaults) on normalised observations and [0, 1]
actions. Four interchangeable back ends run that same algorithm with those same settings:

* ``sb3`` -- stable-baselines3 itself (the paper's code path);
* ``sbx`` -- sbx-rl, the JAX re-implementation of SB3 by its maintainers (same defaults);
* ``torch`` -- :class:`LeanSAC` below: the same update, written for one CPU thread without SB3's per-step
  machinery (the two critics as one batched ensemble, no critic weight gradients in the actor step, one
  fused Adam per network);
* ``fast`` (the default) -- :class:`pipeline.paper_sac_fast.FastSAC`: the same update with hand-written
  gradients (checked against autograd's to 1e-6 in float32), no autograd graph;
* ``torch-bf16`` -- ``torch`` asked to run in bfloat16 (the same as ``--sac torch --precision bfloat16``).

``torch`` and ``fast`` run in the precision :func:`sac_precision` chooses (:mod:`surrogates.precision`):
float32, or bfloat16 matrix products (parameters, optimiser state, losses and element-wise steps stay
float32) where the CPU multiplies bfloat16 natively and a measurement of the update's own product shapes
finds it faster. sb3 and sbx run in float32.

The SB3 defaults reproduced by :class:`LeanSAC` (stable_baselines3/sac/sac.py and policies.py, 2.x):
actor and both critics MLPs [256, 256] with ReLU; squashed diagonal Gaussian, log-std clamped to
[-20, 2], log-prob correction ``log(1 - tanh(u)^2 + 1e-6)``; Adam (torch defaults) at 3e-4 for actor,
critics and the entropy coefficient; entropy coefficient learned from 1.0 toward a target entropy of
-(action dimension); replay buffer 1e6, batch 256, tau 0.005, gamma 0.99, one gradient step per
environment step after 100 uniform-random warm-up steps; the critic is updated before the actor, which
then uses the updated critic; target networks updated every step. Terminal steps do not bootstrap.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from citylearn_env.errors import InputError
from surrogates.precision import Choice, check_precision, choose, matmul_probe, median_times

BACKENDS = ("fast", "torch", "torch-bf16", "sbx", "sb3")
#: the libraries' back ends (sb3: torch float32; sbx: JAX float32) take no precision setting
LIBRARY_PRECISION = Choice("float32", "float32", "sb3 and sbx run in float32")

#: SB3 SAC defaults (the paper used SAC with no hyperparameter changes)
HIDDEN = 256
LEARNING_RATE = 3e-4
BATCH_SIZE = 256
BUFFER_SIZE = 1_000_000
TAU = 0.005
GAMMA = 0.99
LEARNING_STARTS = 100
LOG_STD_MIN, LOG_STD_MAX = -20.0, 2.0
SQUASH_EPSILON = 1e-6


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
    import torch

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
    import torch

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
    import torch

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
    from pipeline.paper_sac_fast import FastSAC

    obs_dim, act_dim = env.observation_space.shape[0], env.action_space.shape[0]
    choice = sac_precision("bfloat16" if backend == "torch-bf16" else precision, obs_dim, act_dim, threads)
    agent = (FastSAC if backend == "fast" else LeanSAC)(obs_dim, act_dim, seed=seed, bf16=choice.bf16,
                                                        threads=threads)
    agent.learn(env, steps, seed)
    return agent.act, choice


def _train_library(env, steps: int, seed: int, backend: str, threads: int) -> Callable[[np.ndarray], np.ndarray]:
    """SB3 or SBX ``SAC("MlpPolicy", env)`` with defaults (``threads`` torch threads for SB3)."""
    if backend == "sb3":
        import torch
        from stable_baselines3 import SAC

        torch.set_num_threads(threads)
        from stable_baselines3.common.logger import Logger

        model = SAC("MlpPolicy", env, seed=seed, device="cpu", verbose=0, learning_starts=LEARNING_STARTS)
        model.set_logger(Logger(None, []))  # SB3's default logger leaves an empty SB3-<time> folder in /tmp
    else:
        try:
            from sbx import SAC
        except ImportError:
            raise InputError("the sbx back end needs sbx-rl: pip install 'districtgen[rl-fast]'",
                             column="--sac") from None
        model = SAC("MlpPolicy", env, seed=seed, verbose=0, learning_starts=LEARNING_STARTS)
    model.learn(total_timesteps=steps)

    def act(obs: np.ndarray) -> np.ndarray:
        return np.asarray(model.predict(obs, deterministic=True)[0], dtype=np.float64)

    return act


class LeanSAC:
    """SB3's SAC update for one CPU thread (see the module docstring for the settings reproduced).

    Actions are learned in [-1, 1] (tanh-squashed) and given to the environment in [0, 1] (as SB3 rescales
    onto a [0, 1] Box). ``bf16``: bfloat16 matrix products under ``torch.autocast``.
    """

    def __init__(self, obs_dim: int, act_dim: int, *, seed: int = 0, bf16: bool = False, threads: int = 1):
        import torch

        torch.set_num_threads(threads)
        self.torch = torch
        self.generator = torch.Generator().manual_seed(seed)
        torch.manual_seed(seed)
        self.obs_dim, self.act_dim, self.bf16 = obs_dim, act_dim, bf16
        self.actor = [*_linear(obs_dim, HIDDEN), *_linear(HIDDEN, HIDDEN), *_linear(HIDDEN, 2 * act_dim)]
        # mu and log_std heads of SB3 are two Linear(256, A): initialised separately, stored side by side
        mu_w, mu_b = _linear(HIDDEN, act_dim)
        ls_w, ls_b = _linear(HIDDEN, act_dim)
        with torch.no_grad():
            self.actor[4].copy_(torch.cat([mu_w, ls_w], dim=1))
            self.actor[5].copy_(torch.cat([mu_b, ls_b], dim=1))
        self.critic = _ensemble(obs_dim + act_dim, 2)
        self.critic_target = [p.detach().clone() for p in self.critic]
        self.log_ent_coef = torch.zeros(1, requires_grad=True)
        self.target_entropy = -float(act_dim)
        self._make_optimizers()

    def _make_optimizers(self) -> None:
        """torch's fused Adam (SB3's optimiser and learning rate) for actor, critics and entropy coefficient."""
        adam = dict(lr=LEARNING_RATE, fused=True)
        self.actor_opt = self.torch.optim.Adam(self.actor, **adam)
        self.critic_opt = self.torch.optim.Adam(self.critic, **adam)
        self.ent_opt = self.torch.optim.Adam([self.log_ent_coef], **adam)

    # ------------------------------------------------------------------ networks
    def _autocast(self):
        return self.torch.autocast("cpu", dtype=self.torch.bfloat16, enabled=self.bf16)

    def _actor_params(self, obs):
        torch = self.torch
        w1, b1, w2, b2, w3, b3 = self.actor
        with self._autocast():
            h = torch.relu(torch.addmm(b1, obs, w1))
            h = torch.relu(torch.addmm(b2, h, w2))
            out = torch.addmm(b3, h, w3).float()
        mu, log_std = out[:, :self.act_dim], out[:, self.act_dim:]
        return mu, log_std.clamp(LOG_STD_MIN, LOG_STD_MAX)

    def _sample(self, obs):
        """Squashed Gaussian sample and its log-probability (SB3's SquashedDiagGaussianDistribution)."""
        mu, log_std = self._actor_params(obs)
        noise = self.torch.randn(mu.shape, generator=self.generator)
        return squashed_gaussian(mu, log_std, noise)[:2]

    def _q(self, params, obs, action):
        """Both critics at once: (2, batch, 1)."""
        torch = self.torch
        w1, b1, w2, b2, w3, b3 = params
        x = torch.cat([obs, action], dim=1).expand(2, -1, -1)
        with self._autocast():
            h = torch.relu(torch.baddbmm(b1, x, w1))
            h = torch.relu(torch.baddbmm(b2, h, w2))
            return torch.baddbmm(b3, h, w3).float()

    # ------------------------------------------------------------------ update
    def train_step(self, obs, action, reward, next_obs, done) -> None:
        """One SB3 SAC gradient step on a batch (float32 tensors; reward and done shaped (batch, 1))."""
        torch = self.torch
        action_pi, log_prob = self._sample(obs)
        ent_coef = self.log_ent_coef.detach().exp()  # read before its own update, as SB3 does
        ent_loss = -(self.log_ent_coef * (log_prob + self.target_entropy).detach()).mean()
        self.ent_opt.zero_grad(set_to_none=True)
        ent_loss.backward()
        self.ent_opt.step()
        with torch.no_grad():
            next_action, next_log_prob = self._sample(next_obs)
            next_q = self._q(self.critic_target, next_obs, next_action).min(dim=0).values
            next_q = next_q - ent_coef * next_log_prob.unsqueeze(1)
            target = reward + (1.0 - done) * GAMMA * next_q
        current = self._q(self.critic, obs, action)
        critic_loss = 0.5 * ((current - target.unsqueeze(0)) ** 2).mean(dim=(1, 2)).sum()
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        frozen = [p.detach() for p in self.critic]
        q_pi = self._q(frozen, obs, action_pi).min(dim=0).values
        actor_loss = (ent_coef * log_prob.unsqueeze(1) - q_pi).mean()
        self.actor_opt.zero_grad(set_to_none=True)
        actor_loss.backward()
        self.actor_opt.step()
        with torch.no_grad():
            torch._foreach_lerp_(self.critic_target, [p.detach() for p in self.critic], TAU)

    # ------------------------------------------------------------------ rollout
    def learn(self, env, steps: int, seed: int) -> None:
        """``steps`` environment steps on ``env`` ([0, 1] actions), one gradient step each after warm-up."""
        torch = self.torch
        rng = np.random.default_rng(seed)
        capacity = min(BUFFER_SIZE, steps)
        # the replay buffer: one NumPy table (cheap per-step writes; columns s | s' | a | r | done), sampled
        # with one gather through a shared-memory torch view
        o, a = self.obs_dim, self.act_dim
        replay = np.zeros((capacity, 2 * o + a + 2), dtype=np.float32)
        table = torch.from_numpy(replay)
        obs, _ = env.reset(seed=seed)
        for t in range(steps):
            if t < LEARNING_STARTS:
                squashed = rng.uniform(-1.0, 1.0, self.act_dim)
            else:
                squashed = self.explore(obs)
            next_obs, reward, terminated, truncated, _ = env.step((squashed + 1.0) / 2.0)
            i = t % capacity
            row = replay[i]
            row[:o], row[o:2 * o], row[2 * o:2 * o + a] = obs, next_obs, squashed
            row[-2], row[-1] = reward, terminated
            obs = env.reset()[0] if terminated or truncated else next_obs
            if t + 1 > LEARNING_STARTS:
                idx = torch.randint(0, min(t + 1, capacity), (BATCH_SIZE,), generator=self.generator)
                batch = table[idx]
                self.train_step(batch[:, :o], batch[:, 2 * o:2 * o + a], batch[:, -2:-1], batch[:, o:2 * o],
                                batch[:, -1:])

    def explore(self, obs: np.ndarray) -> np.ndarray:
        """A stochastic action in [-1, 1] for one observation (the rollout's draw)."""
        torch = self.torch
        with torch.no_grad():
            return self._sample(torch.as_tensor(obs, dtype=torch.float32)[None])[0][0].numpy()

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Deterministic action in [0, 1]: (tanh(mu) + 1) / 2."""
        torch = self.torch
        with torch.no_grad():
            mu, _ = self._actor_params(torch.as_tensor(np.asarray(obs, dtype=np.float32))[None])
        return (torch.tanh(mu)[0].double().numpy() + 1.0) / 2.0


def squashed_gaussian(mu, log_std, noise):
    """tanh(mu + exp(log_std) noise) and its log-probability (N,) with SB3's squashing correction
    log(1 - a^2 + 1e-6); also returns exp(log_std) and 1 - a^2 (what a hand-written gradient needs)."""
    import torch

    std = log_std.exp()
    action = torch.tanh(mu + std * noise)
    one_minus_a2 = 1 - action.square()
    log_prob = (-0.5 * noise.square() - log_std - 0.5 * math.log(2 * math.pi)).sum(1)
    log_prob = log_prob - torch.log(one_minus_a2 + SQUASH_EPSILON).sum(1)
    return action, log_prob, std, one_minus_a2


def _linear(n_in: int, n_out: int):
    """torch.nn.Linear's default initialisation, as (weight (in, out), bias (1, out)) leaf tensors."""
    import torch

    layer = torch.nn.Linear(n_in, n_out)
    return [layer.weight.detach().t().contiguous().requires_grad_(True),
            layer.bias.detach()[None].clone().requires_grad_(True)]


def _ensemble(n_in: int, members: int):
    """``members`` independent [n_in, 256, 256, 1] MLPs stacked as (members, in, out) weights."""
    import torch

    layers = [[_linear(a, b) for a, b in ((n_in, HIDDEN), (HIDDEN, HIDDEN), (HIDDEN, 1))] for _ in range(members)]
    params = []
    for k in range(3):
        params.append(torch.stack([m[k][0].detach() for m in layers]).requires_grad_(True))
        params.append(torch.stack([m[k][1].detach() for m in layers]).requires_grad_(True))
    return params
