"""Agents with upstream's API (mirrors ``citylearn.agents.base``: ``Agent``, ``BaselineAgent``).

An agent reads its environment's observation and action names and spaces (lists of lists, one entry per agent),
returns actions from :meth:`Agent.predict` (a random sample of the action space here), keeps the action history
(``agent.actions``) and runs whole episodes with :meth:`Agent.learn`.
"""

from __future__ import annotations

import logging
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.base import Environment

LOGGER = logging.getLogger(__name__)


class Agent(Environment):
    """Base agent: random actions. ``env`` is a compat environment, possibly wrapped; ``random_seed`` (default
    the environment's) is the only other keyword read, others are accepted and ignored, as upstream."""

    def __init__(self, env: gym.Env, **kwargs: Any) -> None:
        self.env = env
        base = env.unwrapped
        self.observation_names: list[list[str]] = getattr(env, "observation_names", base.observation_names)
        self.action_names: list[list[str]] = base.action_names
        self.observation_space: list[gym.spaces.Box] = env.observation_space
        self.action_space: list[gym.spaces.Box] = env.action_space
        self.episode_time_steps: int = base.time_steps
        self.building_metadata: list[dict[str, Any]] = base.get_metadata()["buildings"]
        super().__init__(seconds_per_time_step=base.seconds_per_time_step,
                         random_seed=kwargs.get("random_seed", base.random_seed), episode_tracker=base.episode_tracker)
        self.reset()

    @property
    def action_dimension(self) -> list[int]:
        """Number of actions of each agent."""
        return [s.shape[0] for s in self.action_space]

    @property
    def actions(self) -> list[list[list[Any]]]:
        """Action history per agent: ``actions[i][t]`` is agent i's actions chosen at time step t."""
        return self._actions

    @actions.setter
    def actions(self, actions: list[list[Any]]) -> None:
        for i in range(len(self.action_space)):
            self._actions[i][self.time_step] = actions[i]

    def learn(self, episodes: int | None = None, deterministic: bool | None = None,
              deterministic_finish: bool | None = None, logging_level: int | None = None) -> None:
        """Run ``episodes`` (default 1) episodes, calling :meth:`update` after each step unless deterministic
        (``deterministic_finish``: the last episode is deterministic)."""
        episodes = 1 if episodes is None else episodes
        LOGGER.setLevel(30 if logging_level is None else logging_level)
        for episode in range(episodes):
            exploit = bool(deterministic) or (bool(deterministic_finish) and episode >= episodes - 1)
            observations, _ = self.env.reset()
            self.episode_time_steps = self.env.unwrapped.time_steps
            rewards, terminated = [], False
            while not terminated:
                actions = self.predict(observations, deterministic=exploit)
                next_observations, reward, terminated, truncated, _ = self.env.step(actions)
                rewards.append(reward)
                if not exploit:
                    self.update(observations, actions, reward, next_observations, terminated=terminated,
                                truncated=truncated)
                observations = list(next_observations)
            summary = np.array(rewards, dtype=float)
            LOGGER.info("Completed episode %d/%d, reward sum %s", episode + 1, episodes, summary.sum(axis=0))

    def predict(self, observations: list[list[float]], deterministic: bool | None = None) -> list[list[float]]:
        """Actions for the current time step: random samples of the action spaces."""
        actions = [list(s.sample()) for s in self.action_space]
        self.actions = actions
        self.next_time_step()
        return actions

    def update(self, *args: Any, **kwargs: Any) -> None:
        """Learn from a transition (nothing here; kept so every agent has the same API)."""

    def next_time_step(self) -> None:
        super().next_time_step()
        for history in self._actions:
            history.append([])

    def reset(self) -> None:
        super().reset()
        self._actions: list[list[list[Any]]] = [[[]] for _ in self.action_space]


class BaselineAgent(Agent):
    """Business as usual: every action of the environment is switched off (no storage use, devices serve the
    data set's loads), so a new environment is needed for another agent, as upstream."""

    def __init__(self, env: gym.Env, **kwargs: Any) -> None:
        env.unwrapped.deactivate_actions()
        super().__init__(env, **kwargs)

    def predict(self, observations: list[list[float]], deterministic: bool | None = None) -> list[list[float]]:
        """No actions: one empty list per agent."""
        actions: list[list[float]] = [[] for _ in self.action_names]
        self.actions = actions
        self.next_time_step()
        return actions


__all__ = ["Agent", "BaselineAgent"]
