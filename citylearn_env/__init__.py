"""citylearn_env: a fast, CityLearn-compatible gymnasium environment for district energy control.

>>> import gymnasium as gym, citylearn_env
>>> env = gym.make("citylearn_env/CityLearn-v0", schema="path/to/schema.json")

Importing this package does not import torch, prefect or pandas.
"""

from __future__ import annotations

import gymnasium as gym

from citylearn_env.env import CityLearnEnv
from citylearn_env.errors import SchemaError
from citylearn_env.schema import load_schema

__all__ = ["CityLearnEnv", "SchemaError", "load_schema", "make_example_env"]
__version__ = "0.1.0"


def make_example_env(n_buildings: int = 3, hours: int = 720, seed: int = 0, **kwargs) -> CityLearnEnv:
    """An environment on the synthetic example district (written to a temporary folder)."""
    import tempfile

    from citylearn_env.example import write_example_district

    folder = tempfile.mkdtemp(prefix="citylearn_env_example_")
    return CityLearnEnv(write_example_district(folder, n_buildings=n_buildings, hours=hours, seed=seed), **kwargs)


for _id, _entry in (("citylearn_env/CityLearn-v0", "citylearn_env.env:CityLearnEnv"),
                    ("citylearn_env/Example-v0", "citylearn_env:make_example_env")):
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=_entry)
