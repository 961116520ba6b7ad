"""Helpers to run the environment on the golden CityLearn 2.1.2 scenarios of ../shared/reference."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from citylearn_env import CityLearnEnv
from citylearn_env.settings import CITYLEARN_2_1, Behaviour
from tests.conftest import DATASET, GOLDEN, need_shared


def golden_schema(scenario: str) -> dict:
    need_shared(GOLDEN / scenario, DATASET)
    schema = json.loads((GOLDEN / scenario / "schema_used.json").read_text())
    schema["root_directory"] = str(DATASET)
    return schema


def run_scenario(scenario: str, *, settings: Behaviour = CITYLEARN_2_1,
                 schema: dict | str | None = None) -> CityLearnEnv:
    """Run the scenario's exact action table through a fresh env with ``settings`` (default: the CityLearn
    2.1 preset, for golden-trace parity); return the env at the episode end."""
    env = CityLearnEnv(schema if schema is not None else golden_schema(scenario), settings=settings)
    actions = pd.read_csv(GOLDEN / scenario / "actions.csv")
    columns = [f"{env.building_names[b]}__{name}" for name, b in env.action_pairs]
    table = actions[columns].to_numpy() if columns else np.zeros((len(actions), 0))
    env.reset()
    observations = [env.flat_observations()[env.layout.central_index].copy()]
    for row in table:
        obs, *_ = env.step(row)
        observations.append(env.flat_observations()[env.layout.central_index].copy())
    env.recorded_observations = np.array(observations)
    return env


def trace_matrix(scenario: str, column: str, buildings) -> np.ndarray:
    trace = pd.read_parquet(GOLDEN / scenario / "trace.parquet", columns=["building", "time_step", column])
    return trace.pivot(index="building", columns="time_step", values=column).loc[list(buildings)].to_numpy()
