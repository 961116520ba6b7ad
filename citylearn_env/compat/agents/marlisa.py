"""Upstream's MARLISA (mirrors ``citylearn.agents.marlisa.MARLISA``): SAC per agent whose observations are
standardised then compressed by PCA, with upstream's defaults (``hidden_dimension`` [400, 300], ``batch_size``
100, ``regression_buffer_capacity`` 3e4, ``regression_frequency`` 2500, ``pca_compression`` 1.0, ``iterations`` 2;
CityLearn 2.5: ``start_regression_time_step`` = ``start_training_time_step`` - 1, ``information_sharing`` False;
CityLearn 2.1.2: ``start_regression_time_step`` 2, ``information_sharing`` True, so a 2.1 program gets the one
line below unless it passes ``information_sharing=False``).

As upstream without information sharing: transitions reach the replay buffer only once the regression phase has
started twice (``start_regression_time_step`` passed on two updates); at ``start_training_time_step`` with
``batch_size`` transitions the buffer is standardised (as SAC), a PCA of ``int(pca_compression · encoded
observations)`` components is fitted to it and every observation is transformed by it from then on.

Not mirrored: ``information_sharing=True`` (the demand regression and coordination variables; one line says so).
scikit-learn (the ``pipeline`` extra) provides the PCA; missing, it is one line.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.agents.rlc import require_torch
from citylearn_env.compat.agents.sac import SAC
from citylearn_env.errors import SchemaError

SKLEARN_MISSING = "citylearn_env.compat: MARLISA needs scikit-learn: pip install 'districtgen[pipeline]'"
COORDINATION_VARIABLES = 2


class MARLISA(SAC):
    """MARLISA without information sharing (see the module docstring)."""

    def __init__(self, env: gym.Env, regression_buffer_capacity: int | None = None,
                 start_regression_time_step: int | None = None, regression_frequency: int | None = None,
                 information_sharing: bool | None = None, pca_compression: float | None = None,
                 iterations: int | None = None, **kwargs: Any) -> None:
        mirror = getattr(env.unwrapped, "mirror", None)
        old = mirror is not None and mirror.version == "2.1"
        if information_sharing or (information_sharing is None and old):
            raise SchemaError("MARLISA with information_sharing=True is not mirrored (docs/compat.md)",
                              column="information_sharing")
        try:
            from sklearn.decomposition import PCA
        except ImportError:
            raise ModuleNotFoundError(SKLEARN_MISSING) from None
        for name, default in (("hidden_dimension", [400, 300]), ("batch_size", 100)):
            if kwargs.get(name) is None:
                kwargs[name] = default
        self.information_sharing = False
        super().__init__(env, **kwargs)
        self.regression_buffer_capacity = 3e4 if regression_buffer_capacity is None else regression_buffer_capacity
        default = 2 if old else self.start_training_time_step - 1
        start = default if start_regression_time_step is None else start_regression_time_step
        if start >= self.start_training_time_step:
            raise SchemaError(f"must be < start_training_time_step ({self.start_training_time_step}), got {start}",
                              column="start_regression_time_step")
        self.start_regression_time_step = start
        self.regression_frequency = 2500 if regression_frequency is None else regression_frequency
        self.pca_compression = 1.0 if pca_compression is None else pca_compression
        self.iterations = 2 if iterations is None else iterations
        self.pca_flag = [False] * len(self.action_dimension)
        self.regression_flag = [0] * len(self.action_dimension)
        self.pca = [PCA(n_components=int(self.pca_compression * len(self.get_encoded_observations(i, s.low))))
                    for i, s in enumerate(self.observation_space)]

    @property
    def coordination_variables_history(self) -> list[list[list[float]]]:
        """Coordination variables of the previous and current step (zeros without information sharing)."""
        return [[[0.0] * COORDINATION_VARIABLES for _ in self.action_space] for _ in range(2)]

    def update(self, observations: list[list[float]], actions: list[Any], reward: list[float],
               next_observations: list[list[float]], done: bool | None = None, terminated: bool | None = None,
               truncated: bool | None = None) -> None:
        """Push (after the regression phase began twice) and train each agent (module docstring)."""
        flag = bool(terminated if done is None else done)
        for i, (o, a, r, n) in enumerate(zip(observations, actions, reward, next_observations, strict=True)):
            if self.regression_flag[i] > 1:
                o, n = self.get_encoded_observations(i, o), self.get_encoded_observations(i, n)
                if self.pca_flag[i]:
                    o, n = self.compress(i, o), self.compress(i, n)
                    r = self.get_normalized_reward(i, r)
                self.replay_buffer[i].push(o, a, r, n, flag)
            if self.time_step >= self.start_regression_time_step and (
                    self.regression_flag[i] < 2 or self.time_step % self.regression_frequency == 0):
                self.regression_flag[i] = min(self.regression_flag[i] + 1, 2)
            if self.time_step >= self.start_training_time_step and self.batch_size <= len(self.replay_buffer[i]):
                if not self.pca_flag[i]:
                    self.fit_compression(i)
                for _ in range(self.update_per_time_step):
                    self.gradient_step(i)

    def compress(self, i: int, encoded: np.ndarray) -> np.ndarray:
        """Encoded observations standardised then PCA-transformed."""
        return self.pca[i].transform(self.get_normalized_observations(i, encoded).reshape(1, -1))[0]

    def fit_compression(self, i: int) -> None:
        """Statistics and PCA of agent ``i``'s buffer; the buffer rewritten with them."""
        buffer = self.replay_buffer[i]
        x = np.array([t[0] for t in buffer.buffer], dtype=float)
        self.norm_mean[i] = np.nanmean(x, axis=0)
        self.norm_std[i] = np.nanstd(x, axis=0) + 1e-5
        self.pca[i].fit(self.get_normalized_observations(i, x))
        r = np.array([t[2] for t in buffer.buffer], dtype=float)
        self.r_norm_mean[i] = np.nanmean(r, dtype=float)
        self.r_norm_std[i] = np.nanstd(r, dtype=float) / self.reward_scaling + 1e-5
        buffer.buffer = [(np.hstack(self.compress(i, o)), a, self.get_normalized_reward(i, r),
                          np.hstack(self.compress(i, n)), d) for o, a, r, n, d in buffer.buffer]
        self.pca_flag[i] = True
        self.normalized[i] = True

    def get_post_exploration_prediction(self, observations: list[list[float]], deterministic: bool) -> list[Any]:
        """The policy's actions on compressed observations (lists of floats, as upstream)."""
        torch = require_torch()
        actions = []
        for i, o in enumerate(observations):
            x = self.compress(i, self.get_encoded_observations(i, o))
            sample = self.policy_net[i].sample(torch.FloatTensor(x).unsqueeze(0).to(self.device))
            actions.append(list((sample[2] if deterministic else sample[0]).detach().cpu().numpy()[0]))
        return actions


__all__ = ["MARLISA"]
