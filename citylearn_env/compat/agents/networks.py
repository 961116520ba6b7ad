"""Networks and replay buffer of upstream's SAC (mirrors ``citylearn.rl``). Imports torch: import this module
only through :func:`citylearn_env.compat.agents.rlc.require_torch`.

Layers are created in upstream's order (so a seeded torch draws the same initial weights): the policy's two
hidden layers, mean and log-std heads (heads re-drawn uniform in ±``init_w``); the critic's three linear layers,
then two LayerNorms (last layer re-drawn uniform in ±``init_w``).
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.distributions import Normal
from torch.nn import functional


class PolicyNetwork(nn.Module):
    """Squashed Gaussian policy: actions ``tanh(x)·scale + bias`` with scale and bias from the action space's
    bounds times ``action_scaling_coef``; log-std clamped to [``log_std_min``, ``log_std_max``]."""

    def __init__(self, num_inputs: int, num_actions: int, action_space: Any, action_scaling_coef: float,
                 hidden_dim: Sequence[int] = (400, 300), init_w: float = 3e-3, log_std_min: float = -20,
                 log_std_max: float = 2, epsilon: float = 1e-6) -> None:
        super().__init__()
        self.log_std_min, self.log_std_max, self.epsilon = log_std_min, log_std_max, epsilon
        self.linear1 = nn.Linear(num_inputs, hidden_dim[0])
        self.linear2 = nn.Linear(hidden_dim[0], hidden_dim[1])
        self.mean_linear = nn.Linear(hidden_dim[1], num_actions)
        self.log_std_linear = nn.Linear(hidden_dim[1], num_actions)
        for head in (self.mean_linear, self.log_std_linear):
            head.weight.data.uniform_(-init_w, init_w)
            head.bias.data.uniform_(-init_w, init_w)
        low, high = action_space.low, action_space.high
        self.action_scale = torch.FloatTensor(action_scaling_coef * (high - low) / 2.0)
        self.action_bias = torch.FloatTensor(action_scaling_coef * (high + low) / 2.0)

    def forward(self, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and clamped log-std of the pre-squash Gaussian."""
        hidden = functional.relu(self.linear2(functional.relu(self.linear1(state))))
        log_std = torch.clamp(self.log_std_linear(hidden), min=self.log_std_min, max=self.log_std_max)
        return self.mean_linear(hidden), log_std

    def sample(self, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """A reparameterised action, its log-probability (tanh-corrected, summed over actions) and the
        deterministic (squashed mean) action."""
        mean, log_std = self.forward(state)
        gaussian = Normal(mean, log_std.exp())
        x = gaussian.rsample()
        y = torch.tanh(x)
        log_prob = gaussian.log_prob(x)
        log_prob -= torch.log(self.action_scale * (1 - y.pow(2)) + self.epsilon)
        action = y * self.action_scale + self.action_bias
        return action, log_prob.sum(1, keepdim=True), torch.tanh(mean) * self.action_scale + self.action_bias

    def to(self, device: Any) -> PolicyNetwork:  # type: ignore[override]
        self.action_scale = self.action_scale.to(device)
        self.action_bias = self.action_bias.to(device)
        return super().to(device)


class SoftQNetwork(nn.Module):
    """Critic Q(s, a): two ReLU layers each followed by a LayerNorm, then a linear output."""

    def __init__(self, num_inputs: int, num_actions: int, hidden_size: Sequence[int] = (400, 300),
                 init_w: float = 3e-3) -> None:
        super().__init__()
        self.linear1 = nn.Linear(num_inputs + num_actions, hidden_size[0])
        self.linear2 = nn.Linear(hidden_size[0], hidden_size[1])
        self.linear3 = nn.Linear(hidden_size[1], 1)
        self.ln1 = nn.LayerNorm(hidden_size[0])
        self.ln2 = nn.LayerNorm(hidden_size[1])
        self.linear3.weight.data.uniform_(-init_w, init_w)
        self.linear3.bias.data.uniform_(-init_w, init_w)

    def forward(self, state: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        x = self.ln1(functional.relu(self.linear1(torch.cat([state, action], 1))))
        return self.linear3(self.ln2(functional.relu(self.linear2(x))))


class ReplayBuffer:
    """Ring buffer of ``(observation, action, reward, next observation, done)`` tuples of at most ``capacity``.

    Minibatches are drawn with ``random.sample`` as upstream, from this buffer's own ``random.Random(seed)``
    (upstream draws from the unseeded global generator, so its minibatches cannot be reproduced)."""

    def __init__(self, capacity: int, seed: int | None = None) -> None:
        self.capacity = capacity
        self.buffer: list[tuple[Any, ...]] = []
        self.position = 0
        self.rng = random.Random(seed)

    def push(self, state: Any, action: Any, reward: float, next_state: Any, done: bool) -> None:
        if len(self.buffer) < self.capacity:
            self.buffer.append(())
        self.buffer[self.position] = (state, action, reward, next_state, done)
        self.position = int((self.position + 1) % self.capacity)

    def sample(self, batch_size: int) -> tuple[np.ndarray, ...]:
        """``batch_size`` distinct transitions, stacked field by field."""
        batch = self.rng.sample(self.buffer, batch_size)
        return tuple(np.stack(field) for field in zip(*batch, strict=True))

    def __len__(self) -> int:
        return len(self.buffer)


__all__ = ["PolicyNetwork", "ReplayBuffer", "SoftQNetwork"]
