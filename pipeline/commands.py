"""The environment's command: ``districtgen run`` runs any schema (default: the synthetic example district the
package writes itself) through the environment and prints its KPI table. It loads the environment alone (no
Prefect, pydantic, torch or matplotlib), so it runs on a plain install.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.example import write_example_district
from citylearn_env.footprint import memory_refusal
from pipeline.controllers import run_policy
from pipeline.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``run`` to the ``districtgen`` sub-commands."""
    parser = subparsers.add_parser("run", help="run a district (default: the example) and print its KPIs")
    parser.add_argument("--schema", type=Path, help="a CityLearn schema.json (default: the example district)")
    parser.add_argument("--policy", choices=("zero", "random"), default="random",
                        help="zero = no storage use (baseline); random = uniform random actions")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compat", action="store_true", help="reproduce CityLearn 2.1 exactly (bugs included)")
    parser.set_defaults(func=run_command)


def run_command(args: argparse.Namespace) -> int:
    """``run [--schema S] [--policy zero|random] [--seed N] [--compat]``: one episode, its KPI table and
    objectives printed."""
    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}", column="--seed")
    policy = "no_control" if args.policy == "zero" else "random"
    if args.schema is not None:
        check_memory(args.schema)
    with tempfile.TemporaryDirectory(prefix="districtgen_example_") as scratch:  # never ./artifacts in the cwd
        schema = args.schema or write_example_district(Path(scratch) / "example")
        env = run_policy(schema, policy, seed=args.seed, ideal_cooling=False,
                         settings="citylearn-2.1" if args.compat else None)
    schema = args.schema or "the example district (synthetic)"
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


def check_memory(schema: Path, available: int | None = None) -> None:
    """Refuse, in one line naming the estimate, the memory available [bytes; default: what the OS can give] and
    what to do, a schema whose whole-episode run would not fit, before anything is loaded
    (:func:`citylearn_env.footprint.memory_refusal`; a schema that cannot be sized is left to the loader)."""
    refusal = memory_refusal(schema, available)
    if refusal is not None:
        raise InputError(refusal, file=schema, column="buildings")
