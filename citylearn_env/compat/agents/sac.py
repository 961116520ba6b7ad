"""Upstream's soft actor-critic, one learner per agent (mirrors ``citylearn.agents.sac``: ``SAC``, ``SACRBC``,
``SACHourRBC``, ``SACBasicRBC``, ``SACOptimizedRBC``, ``SACBasicBatteryRBC``).

The algorithm, step by step as upstream (so a seeded run draws the same numbers):

* ``predict``: up to ``end_exploration_time_step`` (agent time steps, counted over all episodes) actions are
  uniform samples of the action space times ``action_scaling_coefficient`` (or an RBC's actions for the
  ``SACRBC`` family); afterwards the policy's sample (its squashed mean when deterministic), on encoded then
  standardised observations.
* ``update``: observations encoded (``net_electricity_consumption`` dropped), the transition pushed; from
  ``start_training_time_step`` on, once the buffer holds ``batch_size`` transitions, the buffer is standardised
  once (observation mean and std + 1e-5, reward mean and std/``reward_scaling`` + 1e-5, from the buffer then)
  and every later transition with the same statistics; then ``update_per_time_step`` gradient steps: Smooth-L1
  critic losses against ``r + (1 - done)·discount·(min target Q - alpha·log π)``, both critics stepped, then the
  policy loss ``mean(alpha·log π - min Q)``, then Polyak averaging of the targets with ``tau``. ``alpha`` is fixed.
* Seeds: numpy's global generator and torch from ``random_seed`` (upstream); exploration samples from a seeded
  copy of each action space and minibatches from a seeded ``random.Random`` per buffer, where upstream draws from
  unseeded generators (so upstream's runs with random exploration are not reproducible, these are).

Torch (the ``rl`` extra) is imported when an agent is built; missing, it is one line naming the install.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.agents.encoders import Encoder, RemoveFeature, encode
from citylearn_env.compat.agents.rbc import RBC, BasicBatteryRBC, BasicRBC, OptimizedRBC
from citylearn_env.compat.agents.rlc import RLC, require_torch


def seeded_copies(spaces: list[gym.Space], seed: int | None) -> list[gym.Space]:
    """Private copies of ``spaces`` seeded ``seed``, ``seed + 1`` ... (the environment's spaces are untouched)."""
    copies = [copy.deepcopy(s) for s in spaces]
    for i, space in enumerate(copies):
        space.seed(None if seed is None else int(seed) + i)
    return copies


class SAC(RLC):
    """Soft actor-critic per agent (see the module docstring); keywords and defaults of :class:`~.rlc.RLC`."""

    def __init__(self, env: gym.Env, **kwargs: Any) -> None:
        super().__init__(env, **kwargs)
        torch = require_torch()
        from citylearn_env.compat.agents.networks import ReplayBuffer

        n = len(self.action_space)
        self.normalized = [False] * n
        self.soft_q_criterion = torch.nn.SmoothL1Loss()
        self.device = torch.device("cpu")
        self.replay_buffer = [ReplayBuffer(int(self.replay_buffer_capacity), seed=self.random_seed)
                              for _ in range(n)]
        self.samplers = seeded_copies(self.action_space, self.random_seed)
        self.norm_mean: list[Any] = [None] * n
        self.norm_std: list[Any] = [None] * n
        self.r_norm_mean: list[Any] = [None] * n
        self.r_norm_std: list[Any] = [None] * n
        self.set_networks()

    def set_encoders(self) -> list[list[Encoder]]:
        """Upstream's encoders, ``net_electricity_consumption`` removed."""
        encoders = super().set_encoders()
        for names, row in zip(self.observation_names, encoders, strict=True):
            for j, name in enumerate(names):
                if name == "net_electricity_consumption":
                    row[j] = RemoveFeature()
        return encoders

    def set_networks(self, internal_observation_count: int | None = None) -> None:
        """Critics, targets (copies of the critics), policy and Adam optimisers of every agent, in upstream's
        order of creation."""
        torch = require_torch()
        from citylearn_env.compat.agents.networks import PolicyNetwork, SoftQNetwork

        extra = internal_observation_count or 0
        self.soft_q_net1, self.soft_q_net2, self.target_soft_q_net1, self.target_soft_q_net2 = [], [], [], []
        self.policy_net, self.soft_q_optimizer1, self.soft_q_optimizer2, self.policy_optimizer = [], [], [], []
        self.target_entropy = []
        for i, actions in enumerate(self.action_dimension):
            inputs = self.observation_dimension[i] + extra
            critics = [SoftQNetwork(inputs, actions, self.hidden_dimension).to(self.device) for _ in range(4)]
            for target, source in ((critics[2], critics[0]), (critics[3], critics[1])):
                for t, p in zip(target.parameters(), source.parameters(), strict=True):
                    t.data.copy_(p.data)
            self.soft_q_net1.append(critics[0])
            self.soft_q_net2.append(critics[1])
            self.target_soft_q_net1.append(critics[2])
            self.target_soft_q_net2.append(critics[3])
            policy = PolicyNetwork(inputs, actions, self.action_space[i], self.action_scaling_coefficient,
                                   self.hidden_dimension).to(self.device)
            self.policy_net.append(policy)
            self.soft_q_optimizer1.append(torch.optim.Adam(critics[0].parameters(), lr=self.lr))
            self.soft_q_optimizer2.append(torch.optim.Adam(critics[1].parameters(), lr=self.lr))
            self.policy_optimizer.append(torch.optim.Adam(policy.parameters(), lr=self.lr))
            self.target_entropy.append(-np.prod(self.action_space[i].shape).item())

    # ------------------------------------------------------------------ acting
    def predict(self, observations: list[list[float]], deterministic: bool | None = None) -> list[Any]:
        """Exploration actions up to ``end_exploration_time_step``, then the policy's (module docstring)."""
        if self.time_step > self.end_exploration_time_step or bool(deterministic):
            actions = self.get_post_exploration_prediction(observations, bool(deterministic))
        else:
            actions = self.get_exploration_prediction(observations)
        self.actions = actions
        self.next_time_step()
        return actions

    def get_post_exploration_prediction(self, observations: list[list[float]], deterministic: bool) -> list[Any]:
        """The policy's actions (float32 arrays): its sample, or its squashed mean when ``deterministic``."""
        torch = require_torch()
        actions = []
        for i, o in enumerate(observations):
            x = self.get_normalized_observations(i, self.get_encoded_observations(i, o))
            sample = self.policy_net[i].sample(torch.FloatTensor(x).unsqueeze(0).to(self.device))
            actions.append((sample[2] if deterministic else sample[0]).detach().cpu().numpy()[0])
        return actions

    def get_exploration_prediction(self, observations: list[list[float]]) -> list[list[float]]:
        """Uniform action-space samples times ``action_scaling_coefficient``."""
        return [list(self.action_scaling_coefficient * s.sample()) for s in self.samplers]

    # ------------------------------------------------------------------ learning
    def get_encoded_observations(self, index: int, observations: list[float]) -> np.ndarray:
        return encode(self.encoders[index], observations)

    def get_normalized_observations(self, index: int, observations: Any) -> np.ndarray:
        return (np.array(observations, dtype=float) - self.norm_mean[index]) / self.norm_std[index]

    def get_normalized_reward(self, index: int, reward: float) -> float:
        return (reward - self.r_norm_mean[index]) / self.r_norm_std[index]

    def update(self, observations: list[list[float]], actions: list[Any], reward: list[float],
               next_observations: list[list[float]], done: bool | None = None, terminated: bool | None = None,
               truncated: bool | None = None) -> None:
        """Push each agent's transition and train it (module docstring). ``done`` (CityLearn 2.1) or
        ``terminated`` (2.2+) ends the episode."""
        flag = bool(terminated if done is None else done)
        for i, (o, a, r, n) in enumerate(zip(observations, actions, reward, next_observations, strict=True)):
            o, n = self.get_encoded_observations(i, o), self.get_encoded_observations(i, n)
            if self.normalized[i]:
                o, n = self.get_normalized_observations(i, o), self.get_normalized_observations(i, n)
                r = self.get_normalized_reward(i, r)
            buffer = self.replay_buffer[i]
            buffer.push(o, a, r, n, flag)
            if self.time_step >= self.start_training_time_step and self.batch_size <= len(buffer):
                if not self.normalized[i]:
                    self.standardize(i)
                for _ in range(self.update_per_time_step):
                    self.gradient_step(i)

    def standardize(self, i: int) -> None:
        """Agent ``i``'s observation and reward statistics from its buffer; the buffer rewritten with them."""
        buffer = self.replay_buffer[i]
        x = np.array([t[0] for t in buffer.buffer], dtype=float)
        self.norm_mean[i] = np.nanmean(x, axis=0)
        self.norm_std[i] = np.nanstd(x, axis=0) + 1e-5
        r = np.array([t[2] for t in buffer.buffer], dtype=float)
        self.r_norm_mean[i] = np.nanmean(r, dtype=float)
        self.r_norm_std[i] = np.nanstd(r, dtype=float) / self.reward_scaling + 1e-5
        buffer.buffer = [(np.hstack(self.get_normalized_observations(i, o).reshape(1, -1)[0]), a,
                          self.get_normalized_reward(i, r), np.hstack(self.get_normalized_observations(i, n)
                                                                      .reshape(1, -1)[0]), d)
                         for o, a, r, n, d in buffer.buffer]
        self.normalized[i] = True

    def gradient_step(self, i: int) -> None:
        """One critic, policy and target update of agent ``i`` on a minibatch."""
        torch = require_torch()
        o, a, r, n, d = (torch.FloatTensor(v).to(self.device) for v in self.replay_buffer[i].sample(self.batch_size))
        r, d = r.unsqueeze(1), d.unsqueeze(1)
        q1, q2 = self.soft_q_net1[i], self.soft_q_net2[i]
        with torch.no_grad():
            next_actions, next_log_pi, _ = self.policy_net[i].sample(n)
            target_q = torch.min(self.target_soft_q_net1[i](n, next_actions),
                                 self.target_soft_q_net2[i](n, next_actions)) - self.alpha * next_log_pi
            q_target = r + (1 - d) * self.discount * target_q
        q1_loss = self.soft_q_criterion(q1(o, a), q_target)
        q2_loss = self.soft_q_criterion(q2(o, a), q_target)
        for loss, optimizer in ((q1_loss, self.soft_q_optimizer1[i]), (q2_loss, self.soft_q_optimizer2[i])):
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        new_actions, log_pi, _ = self.policy_net[i].sample(o)
        policy_loss = (self.alpha * log_pi - torch.min(q1(o, new_actions), q2(o, new_actions))).mean()
        self.policy_optimizer[i].zero_grad()
        policy_loss.backward()
        self.policy_optimizer[i].step()
        for target, source in ((self.target_soft_q_net1[i], q1), (self.target_soft_q_net2[i], q2)):
            for t, p in zip(target.parameters(), source.parameters(), strict=True):
                t.data.copy_(t.data * (1.0 - self.tau) + p.data * self.tau)


class SACRBC(SAC):
    """SAC exploring with a rule-based controller's actions (``rbc``; default an :class:`RBC`, random)."""

    def __init__(self, env: gym.Env, rbc: RBC | None = None, **kwargs: Any) -> None:
        super().__init__(env, **kwargs)
        self.rbc = self.default_rbc(env, **kwargs) if rbc is None else rbc

    def default_rbc(self, env: gym.Env, **kwargs: Any) -> RBC:
        return RBC(env, **kwargs)

    def get_exploration_prediction(self, observations: list[list[float]]) -> list[list[float]]:
        return self.rbc.predict(observations)


class SACOptimizedRBC(SACRBC):
    """SAC exploring with :class:`OptimizedRBC`."""

    def default_rbc(self, env: gym.Env, **kwargs: Any) -> RBC:
        return OptimizedRBC(env, **kwargs)


class SACHourRBC(SACOptimizedRBC):
    """Upstream's ``SACHourRBC`` explores with :class:`OptimizedRBC` too."""


class SACBasicRBC(SACRBC):
    """SAC exploring with :class:`BasicRBC`."""

    def default_rbc(self, env: gym.Env, **kwargs: Any) -> RBC:
        return BasicRBC(env, **kwargs)


class SACBasicBatteryRBC(SACRBC):
    """SAC exploring with :class:`BasicBatteryRBC`."""

    def default_rbc(self, env: gym.Env, **kwargs: Any) -> RBC:
        return BasicBatteryRBC(env, **kwargs)


__all__ = ["SAC", "SACBasicBatteryRBC", "SACBasicRBC", "SACHourRBC", "SACOptimizedRBC", "SACRBC", "seeded_copies"]
