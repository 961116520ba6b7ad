"""Upstream's tabular Q-learning (mirrors ``citylearn.agents.q_learning.TabularQLearning``) for the discrete
spaces of :class:`citylearn_env.compat.wrappers.TabularQLearningWrapper` (one ``Discrete`` observation and action
per agent).

Defaults as upstream: ``epsilon`` 1.0, ``minimum_epsilon`` 0.01, ``epsilon_decay`` 1e-4, ``learning_rate`` 0.05,
``discount_factor`` 0.90, ``q_init_value`` NaN. At agent time step t (counted over all episodes) the agent
exploits (greedy over the non-NaN Q values of its observation; a random action when all are NaN) when
deterministic or when ``RandomState(random_seed + t).random() > epsilon``, else explores with a random action;
then ``epsilon = max(minimum_epsilon, epsilon_init · exp(-epsilon_decay · episode))``, episode = t // episode
length. ``update`` applies ``Q ← Q + learning_rate·(r + discount_factor·b - Q)`` (NaN Q read as 0) and counts the
visit as exploration or exploitation.

**Upstream quirk kept.** Upstream's bootstrap b is the *index* of the best next action (``nanargmax``), not its
value (0 when all next values are NaN). The compat agent does the same unless its environment runs the
``"corrected"`` preset or ``corrected_bootstrap=True`` is given: then b is the best next Q value.
Random actions come from seeded private copies of the action spaces (upstream's are unseeded).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.agents.base import Agent
from citylearn_env.compat.agents.sac import seeded_copies
from citylearn_env.settings import PRESETS


def best_action(q_row: np.ndarray) -> int | None:
    """Index of the largest non-NaN value of ``q_row``; None when all are NaN."""
    if np.all(np.isnan(q_row)):
        return None
    return int(np.nanargmax(q_row))


class TabularQLearning(Agent):
    """Epsilon-greedy tabular Q-learning (see the module docstring)."""

    def __init__(self, env: gym.Env, epsilon: float | None = None, minimum_epsilon: float | None = None,
                 epsilon_decay: float | None = None, learning_rate: float | None = None,
                 discount_factor: float | None = None, q_init_value: float | None = None,
                 corrected_bootstrap: bool | None = None, **kwargs: Any) -> None:
        super().__init__(env, **kwargs)
        self.epsilon = 1.0 if epsilon is None else epsilon
        self.epsilon_init = self.epsilon
        self.minimum_epsilon = 0.01 if minimum_epsilon is None else minimum_epsilon
        self.epsilon_decay = 0.0001 if epsilon_decay is None else epsilon_decay
        self.learning_rate = 0.05 if learning_rate is None else learning_rate
        self.discount_factor = 0.90 if discount_factor is None else discount_factor
        self.q_init_value = np.nan if q_init_value is None else q_init_value
        if corrected_bootstrap is None:
            corrected_bootstrap = getattr(env.unwrapped, "settings", None) == PRESETS["corrected"]
        self.corrected_bootstrap = bool(corrected_bootstrap)
        self.samplers = seeded_copies(self.action_space, self.random_seed)
        shapes = [(o.n, a.n) for o, a in zip(self.observation_space, self.action_space, strict=True)]
        self.q = [np.ones(s) * self.q_init_value for s in shapes]
        self.q_exploration = [np.zeros(s) for s in shapes]
        self.q_exploitation = [np.zeros(s) for s in shapes]
        self.explored = False

    def predict(self, observations: list[list[int]], deterministic: bool | None = None) -> list[list[int]]:
        """One ``[action index]`` per agent (module docstring)."""
        seed = None if self.random_seed is None else self.random_seed + self.time_step
        draw = np.random.RandomState(seed)
        if bool(deterministic) or draw.random() > self.epsilon:
            actions = self.exploit(observations)
            self.explored = False
        else:
            actions = [[s.sample()] for s in self.samplers]
            self.explored = True
        episode = int(self.time_step / self.episode_time_steps)
        self.epsilon = max(self.minimum_epsilon, self.epsilon_init * np.exp(-self.epsilon_decay * episode))
        self.actions = actions
        self.next_time_step()
        return actions

    def exploit(self, observations: list[list[int]]) -> list[list[int]]:
        """The greedy action of each agent's observation (random while its Q values are all NaN)."""
        actions = []
        for i, o in enumerate(observations):
            a = best_action(self.q[i][o[0]])
            actions.append([self.samplers[i].sample() if a is None else a])
        return actions

    def update(self, observations: list[list[int]], actions: list[list[int]], reward: list[float],
               next_observations: list[list[int]], terminated: bool | None = None, truncated: bool | None = None,
               done: bool | None = None) -> None:
        """The Bellman update of each agent's visited (observation, action) cell (module docstring)."""
        for i, (o, a, r, n) in enumerate(zip(observations, actions, reward, next_observations, strict=True)):
            o, n, a = o[0], n[0], a[0]
            current = self.q[i][o, a]
            current = 0.0 if math.isnan(current) else current
            best = best_action(self.q[i][n])
            if best is None:
                bootstrap = 0.0
            else:
                bootstrap = float(self.q[i][n][best]) if self.corrected_bootstrap else best
            self.q[i][o, a] = current + self.learning_rate * (r + self.discount_factor * bootstrap - current)
            counts = self.q_exploration if self.explored else self.q_exploitation
            counts[i][o, a] += 1


__all__ = ["TabularQLearning", "best_action"]
