"""``districtgen run``: the main job. Runs a district through the environment and prints its KPI table.

Until the district build flow exists, the default district is the synthetic example the project writes
itself (``citylearn_env.example``) into ``artifacts/example/``. ``--schema`` runs any CityLearn schema.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ARTIFACTS = Path("artifacts")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("run", help="run a district (default: the example) and print its KPIs")
    parser.add_argument("--schema", type=Path, help="a CityLearn schema.json (default: the example district)")
    parser.add_argument("--policy", choices=("zero", "random"), default="random",
                        help="zero = no storage use (baseline); random = uniform random actions")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compat", action="store_true", help="reproduce CityLearn 2.1 exactly (bugs included)")
    parser.set_defaults(func=run_command)


def run_episode(schema: Path, *, policy: str = "random", seed: int = 0, compat: bool = False):
    """Run one episode; return the environment at its end."""
    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(schema, compat=compat)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    terminated = False
    while not terminated:
        action = env.action_space.sample() if policy == "random" else np.zeros(env.action_space.shape)
        _, _, terminated, _, _ = env.step(action)
    return env


def run_command(args: argparse.Namespace) -> int:
    import pandas as pd

    from citylearn_env.example import write_example_district

    schema = args.schema or write_example_district(ARTIFACTS / "example")
    env = run_episode(schema, policy=args.policy, seed=args.seed, compat=args.compat)
    kpis = env.evaluate()
    table = kpis.pivot_table(index="cost_function", columns="name", values="value", dropna=False)
    with pd.option_context("display.width", 160, "display.max_columns", 20, "display.precision", 4):
        print(f"district: {schema}  ({len(env.building_names)} buildings, {env.t + 1} time steps, "
              f"policy {args.policy})")
        print(table)
        print("\nobjectives (absolute units):")
        for name, value in env.objectives().items():
            if np.isscalar(value):
                print(f"  {name:24s} {value:12.4f}")
    return 0
