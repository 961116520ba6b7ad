"""citylearn_env: a fast, CityLearn-compatible gymnasium environment for district energy control.

>>> import gymnasium as gym, citylearn_env
>>> env = gym.make("citylearn_env/CityLearn-v0", schema="path/to/schema.json")

Importing this package does not import torch, prefect or pandas.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym

from citylearn_env.env import CityLearnEnv
from citylearn_env.errors import SchemaError
from citylearn_env.example import write_example_district
from citylearn_env.schema import load_schema
from citylearn_env.vector import CityLearnVectorEnv

__all__ = ["CityLearnEnv", "SchemaError", "load_schema", "make_example_env"]
__version__ = "0.1.0"


def _on_example(factory: Callable[[Path], Any], n_buildings: int, hours: int, seed: int) -> Any:
    """``factory(schema_path)`` on the example district written to a temporary folder, removed afterwards
    (the environment holds every series in memory once built)."""
    with tempfile.TemporaryDirectory(prefix="citylearn_env_example_") as folder:
        return factory(write_example_district(folder, n_buildings=n_buildings, hours=hours, seed=seed))


def make_example_env(n_buildings: int = 3, hours: int = 720, seed: int = 0, **kwargs: Any) -> CityLearnEnv:
    """An environment on the synthetic example district (written to a temporary folder, removed once read)."""
    return _on_example(lambda schema: CityLearnEnv(schema, **kwargs), n_buildings, hours, seed)


def make_example_vector_env(num_envs: int = 1, n_buildings: int = 3, hours: int = 720, seed: int = 0,
                            **kwargs: Any) -> CityLearnVectorEnv:
    """``num_envs`` batched copies of the synthetic example district (:class:`citylearn_env.vector.CityLearnVectorEnv`)."""
    return _on_example(lambda schema: CityLearnVectorEnv(schema, num_envs, **kwargs), n_buildings, hours, seed)


for _id, _entry, _vector in (
        ("citylearn_env/CityLearn-v0", "citylearn_env.env:CityLearnEnv", "citylearn_env.vector:CityLearnVectorEnv"),
        ("citylearn_env/Example-v0", "citylearn_env:make_example_env", "citylearn_env:make_example_vector_env")):
    if _id not in gym.registry:
        # gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point") gives the batched vector env
        gym.register(id=_id, entry_point=_entry, vector_entry_point=_vector)
