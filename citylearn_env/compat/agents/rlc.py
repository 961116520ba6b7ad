"""Base of upstream's learning agents (mirrors ``citylearn.agents.rlc.RLC``): hyperparameters with upstream's
defaults, observation encoders and seeding.

Defaults: ``hidden_dimension`` [256, 256], ``discount`` 0.99, ``tau`` 5e-3, ``alpha`` 0.2, ``lr`` 3e-4,
``batch_size`` 256, ``replay_buffer_capacity`` 1e5, ``action_scaling_coefficienct`` 0.5 (upstream's spelling; the
correctly spelled keyword is ignored upstream, so here too, with one warning line), ``reward_scaling`` 5.0,
``update_per_time_step`` 2. When training starts follows the CityLearn version the environment mirrors:

* 2.1 (CityLearn 2.1.2): ``standardize_start_time_step`` (default: the episode length - 1) and
  ``end_exploration_time_step`` (default: the episode length); setting ``random_seed`` seeds torch;
* 2.5: ``start_training_time_step`` (default 6000) and ``end_exploration_time_step`` (default 7000); setting
  ``random_seed`` seeds numpy's global generator and torch.

The other version's keyword is ignored, as that upstream ignores it, with one warning line. Either way the value
is held as ``start_training_time_step`` (``standardize_start_time_step`` is the same attribute).
"""

from __future__ import annotations

import logging
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.agents.base import Agent
from citylearn_env.compat.agents.encoders import Encoder, default_encoders, encode
from citylearn_env.errors import SchemaError

LOGGER = logging.getLogger(__name__)

TORCH_MISSING = ("citylearn_env.compat: upstream's learning agents need torch: pip install torch==2.13.0 "
                 "(CPU build) then pip install 'districtgen[rl]'")


def require_torch() -> Any:
    """The torch module; one ModuleNotFoundError line naming the install when it is missing."""
    try:
        import torch
    except ImportError:
        raise ModuleNotFoundError(TORCH_MISSING) from None
    return torch


DEFAULTS: dict[str, Any] = {
    "hidden_dimension": [256, 256], "discount": 0.99, "tau": 5e-3, "alpha": 0.2, "lr": 3e-4, "batch_size": 256,
    "replay_buffer_capacity": 1e5, "start_training_time_step": 6000, "end_exploration_time_step": 7000,
    "action_scaling_coefficient": 0.5, "reward_scaling": 5.0, "update_per_time_step": 2,
}


class RLC(Agent):
    """Base reinforcement-learning controller (see the module docstring for keywords and defaults)."""

    def __init__(self, env: gym.Env, hidden_dimension: list[int] | None = None, discount: float | None = None,
                 tau: float | None = None, alpha: float | None = None, lr: float | None = None,
                 batch_size: int | None = None, replay_buffer_capacity: float | None = None,
                 start_training_time_step: int | None = None, end_exploration_time_step: int | None = None,
                 action_scaling_coefficienct: float | None = None, reward_scaling: float | None = None,
                 update_per_time_step: int | None = None, standardize_start_time_step: int | None = None,
                 **kwargs: Any) -> None:
        require_torch()
        mirror = getattr(env.unwrapped, "mirror", None)
        #: the CityLearn version whose agent is mirrored ("2.1" or "2.5")
        self.citylearn_version = "2.5" if mirror is None else mirror.version
        old = self.citylearn_version == "2.1"
        if "action_scaling_coefficient" in kwargs:
            LOGGER.warning("citylearn_env.compat: action_scaling_coefficient is ignored, as upstream (its keyword is "
                           "spelled action_scaling_coefficienct)")
        ignored = start_training_time_step if old else standardize_start_time_step
        if ignored is not None:
            LOGGER.warning("citylearn_env.compat: %s is ignored, as CityLearn %s ignores it (its keyword is %s)",
                           "start_training_time_step" if old else "standardize_start_time_step",
                           self.citylearn_version, "standardize_start_time_step" if old else "start_training_time_step")
        super().__init__(env, **kwargs)
        start = standardize_start_time_step if old else start_training_time_step
        given = dict(hidden_dimension=hidden_dimension, discount=discount, tau=tau, alpha=alpha, lr=lr,
                     batch_size=batch_size, replay_buffer_capacity=replay_buffer_capacity,
                     start_training_time_step=start, end_exploration_time_step=end_exploration_time_step,
                     action_scaling_coefficient=action_scaling_coefficienct, reward_scaling=reward_scaling,
                     update_per_time_step=update_per_time_step)
        defaults = dict(DEFAULTS)
        if old:
            defaults.update(start_training_time_step=self.episode_time_steps - 1,
                            end_exploration_time_step=self.episode_time_steps)
        for name, value in given.items():
            setattr(self, name, defaults[name] if value is None else value)
        if not isinstance(self.update_per_time_step, int) or isinstance(self.update_per_time_step, bool):
            raise SchemaError(f"expected an int, got {self.update_per_time_step!r}", column="update_per_time_step")
        self.encoders: list[list[Encoder]] = self.set_encoders()

    @property
    def random_seed(self) -> int:
        """The agent's seed; setting it seeds numpy's global generator and torch (as upstream)."""
        return self._random_seed

    @random_seed.setter
    def random_seed(self, seed: int) -> None:
        self._random_seed = seed
        if getattr(self, "citylearn_version", "2.5") != "2.1":
            np.random.seed(seed)  # noqa: NPY002 - upstream 2.2+ seeds the global generator
        require_torch().manual_seed(seed)

    @property
    def standardize_start_time_step(self) -> int:
        """CityLearn 2.1.2's name of :attr:`start_training_time_step`."""
        return self.start_training_time_step

    @property
    def observation_dimension(self) -> list[int]:
        """Number of encoded observations of each agent."""
        return [len(encode(e, np.ones(len(s.low)))) for e, s in zip(self.encoders, self.observation_space,
                                                                     strict=True)]

    def set_encoders(self) -> list[list[Encoder]]:
        """One encoder per observation of each agent (:func:`~.encoders.default_encoders`)."""
        scaled = self.citylearn_version != "2.1"  # CityLearn 2.1.2's periodic encoding is unscaled
        return [default_encoders(n, s, scaled) for n, s in zip(self.observation_names, self.observation_space,
                                                               strict=True)]


__all__ = ["DEFAULTS", "RLC", "TORCH_MISSING", "require_torch"]
