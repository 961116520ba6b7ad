"""The paper's command: ``districtgen paper SCHEMA -o OUT`` runs the SimBuild 2024 paper's 17 benchmarks on a
district (:func:`pipeline.paper.tasks.run_paper`) and prints its tables. The parser loads only what its choices
need (the SAC back ends' names, the precision modes); the benchmarks load when the command runs.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from citylearn_env.outputs import output_file
from pipeline.errors import InputError
from pipeline.paper.sac.train import BACKENDS
from pipeline.runners import DaskRunner
from surrogates.precision import PRECISIONS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``paper`` to the ``districtgen`` sub-commands."""
    paper = subparsers.add_parser("paper", help="run the SimBuild 2024 paper's 17 benchmarks on a district")
    paper.add_argument("schema", type=Path, help="a district schema.json (e.g. artifacts/default/schema.json)")
    paper.add_argument("-o", "--output", type=Path, required=True,
                       help="folder for results, figures and tasks/ (finished tasks there are reused)")
    paper.add_argument("--only", nargs="*", help="benchmark ids to run (default: all 17)")
    paper.add_argument("--buildings", nargs="+", metavar="NAME",
                       help="schema buildings playing B1 [B2] (default: the first two)")
    paper.add_argument("--rules", choices=("described", "published"), default="described",
                       help="the RBCs as the paper describes them, or as its published code has them")
    paper.add_argument("--compat", action="store_true", help="the CityLearn 2.1 preset (bugs included)")
    paper.add_argument("--sac", choices=BACKENDS, default="fast",
                       help="SAC back end, all with SB3's defaults (see docs/paper.md)")
    paper.add_argument("--precision", choices=PRECISIONS, default="auto",
                       help="numeric mode of the fast/torch SAC updates: auto = bfloat16 only where this CPU "
                            "multiplies it natively and it measures faster, else float32")
    paper.add_argument("--sac-episodes", type=int, default=150, help="SAC training episodes (paper: 150)")
    paper.add_argument("--dask", nargs="?", const="local", metavar="ADDRESS",
                       help="run the tasks on Dask: a local cluster of --workers processes, or a scheduler ADDRESS")
    paper.add_argument("--sac-threads", type=int, metavar="N",
                       help="torch threads per SAC training (default: the cores each running task may use, "
                            "if more than one thread measures faster here; else 1)")
    paper.add_argument("--multiplier", type=float, default=3.0, help="over-cooling multiplier m of d_o")
    paper.add_argument("--seed", type=int, default=0, help="first seed")
    paper.add_argument("--seeds", type=int, default=1, help="run the learning rows with N seeds (mean ± std)")
    paper.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="parallel processes")
    paper.add_argument("--sweep", type=float, nargs="*", metavar="M",
                       help="the m-sweep of rlc-b1-d_o-hp for these multipliers (paper: 1 3 6 12); with --only "
                            "or alone, default: none; --full runs all 17 and the sweep 1 3 6 12")
    paper.add_argument("--full", action="store_true", help="the whole paper: all 17 and the m-sweep 1 3 6 12")
    paper.add_argument("--controllers", nargs="+", choices=("rbc", "sac", "oracle", "mpc"),
                       default=["rbc", "sac", "oracle", "mpc"],
                       help="controllers to run (default all): the RBC and SAC rows, and the perfect-foresight oracle "
                            "and 24-h MPC on each storage configuration (regret.md; docs/paper.md)")
    paper.add_argument("--docs", type=Path, metavar="PAGE",
                       help="also write the tables, with the command, date and CPU, to this markdown page "
                            "(e.g. docs/paper_results.md); rerun on a finished folder to regenerate it")
    paper.set_defaults(func=paper_command)


def paper_command(args: argparse.Namespace) -> int:
    from pipeline.paper.benchmarks import RunOptions
    from pipeline.paper.tasks import run_paper

    check_numbers(args)
    if args.docs:
        output_file(args.docs, column="--docs")  # before the run: not through a link, not into a built district
    options = RunOptions(sac_episodes=args.sac_episodes, roles=tuple(args.buildings) if args.buildings else None,
                         rules=args.rules, compat=args.compat, sac=args.sac,
                         sac_threads=args.sac_threads, precision=args.precision)
    sweep = (1.0, 3.0, 6.0, 12.0) if args.full and not args.sweep else tuple(args.sweep or ())
    only = args.only if args.only or args.full or not args.sweep else []
    runner = None
    if args.dask:
        runner = DaskRunner(None if args.dask == "local" else args.dask, args.workers)
    run_paper(args.schema, args.output, only=only, sweep=sweep, seed=args.seed, seeds=args.seeds,
              multiplier=args.multiplier, options=options, workers=args.workers, runner=runner,
              controllers=tuple(args.controllers))
    for name in ("results.md", "regret.md", "multiplier_sweep.md"):
        if (args.output / name).is_file():
            print((args.output / name).read_text())
    if args.docs:
        from pipeline.paper.results import write_docs_page

        print(f"wrote {write_docs_page(args.output, args.docs, command=paper_command_line(args))}")
    return 0


#: the numeric options and the least value each admits (the multipliers: finite as well)
LEAST = {"sac_episodes": 1, "seeds": 1, "workers": 1, "seed": 0, "sac_threads": 1, "multiplier": 0.0}


def check_numbers(args: argparse.Namespace) -> None:
    """Refuse (one line naming the option) a numeric option out of its range (:data:`LEAST`; the m-sweep's
    multipliers as ``--multiplier``): nothing runs and nothing is written."""
    values = [(f"--{name.replace('_', '-')}", name, getattr(args, name)) for name in LEAST]
    values += [("--sweep", "multiplier", m) for m in args.sweep or ()]
    for option, name, value in values:
        if value is None:  # --sac-threads left out: chosen per task
            continue
        if not value >= LEAST[name] or value in (float("inf"), float("-inf")):
            raise InputError(f"{option} must be a number >= {LEAST[name]:g}, got {value:g}", column=option)


def paper_command_line(args: argparse.Namespace) -> str:
    """The ``districtgen paper`` command line that reproduces ``args`` (the options that change results)."""
    parts = ["districtgen paper", str(args.schema), "-o", str(args.output)]
    if args.only:
        parts += ["--only", *args.only]
    if args.buildings:
        parts += ["--buildings", *args.buildings]
    parts += [f"--{name.replace('_', '-')} {value}" for name, value, default in (
        ("rules", args.rules, "described"), ("sac", args.sac, "fast"), ("precision", args.precision, "auto"),
        ("sac_episodes", args.sac_episodes, 150), ("multiplier", args.multiplier, 3.0), ("seed", args.seed, 0),
        ("seeds", args.seeds, 1)) if value != default]
    parts += ["--compat"] * args.compat + ["--full"] * args.full
    if args.sweep:
        parts += ["--sweep", *map(str, args.sweep)]
    if args.controllers != ["rbc", "sac", "oracle", "mpc"]:
        parts += ["--controllers", *args.controllers]
    return " ".join([*parts, "--docs", str(args.docs)])
