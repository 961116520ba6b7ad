"""SB3's SAC update written for one CPU thread (the ``torch`` back end, and the base of ``fast``): the two
critics as one batched ensemble, no critic weight gradients in the actor step, one fused Adam per network.
The settings reproduced are listed in :mod:`pipeline.paper.sac.train`.
"""

from __future__ import annotations

import math

import numpy as np

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


class LeanSAC:
    """SB3's SAC update for one CPU thread (see the module docstring for the settings reproduced).

    Actions are learned in [-1, 1] (tanh-squashed) and given to the environment in [0, 1] (as SB3 rescales
    onto a [0, 1] Box). ``bf16``: bfloat16 matrix products under ``torch.autocast``.
    """

    def __init__(self, obs_dim: int, act_dim: int, *, seed: int = 0, bf16: bool = False, threads: int = 1):
        import torch  # torch: the CLI imports this module; torch loads on first use

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
    import torch  # torch: the CLI imports this module; torch loads on first use

    std = log_std.exp()
    action = torch.tanh(mu + std * noise)
    one_minus_a2 = 1 - action.square()
    log_prob = (-0.5 * noise.square() - log_std - 0.5 * math.log(2 * math.pi)).sum(1)
    log_prob = log_prob - torch.log(one_minus_a2 + SQUASH_EPSILON).sum(1)
    return action, log_prob, std, one_minus_a2


def _linear(n_in: int, n_out: int):
    """torch.nn.Linear's default initialisation, as (weight (in, out), bias (1, out)) leaf tensors."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    layer = torch.nn.Linear(n_in, n_out)
    return [layer.weight.detach().t().contiguous().requires_grad_(True),
            layer.bias.detach()[None].clone().requires_grad_(True)]


def _ensemble(n_in: int, members: int):
    """``members`` independent [n_in, 256, 256, 1] MLPs stacked as (members, in, out) weights."""
    import torch  # torch: the CLI imports this module; torch loads on first use

    layers = [[_linear(a, b) for a, b in ((n_in, HIDDEN), (HIDDEN, HIDDEN), (HIDDEN, 1))] for _ in range(members)]
    params = []
    for k in range(3):
        params.append(torch.stack([m[k][0].detach() for m in layers]).requires_grad_(True))
        params.append(torch.stack([m[k][1].detach() for m in layers]).requires_grad_(True))
    return params
