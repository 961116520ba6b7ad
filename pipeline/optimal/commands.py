"""``districtgen optimal SCHEMA``: the best perfect-foresight plan of a district's storage and a certified lower
bound, printed, and the plan's schedule
written as CSV (:func:`pipeline.optimal.optimum.optimal`); with ``--mpc``, receding-horizon MPC beside it (its
actions written instead). The parser loads nothing heavy (HiGHS loads when
the command runs)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: objectives a user names on the command line (weights: ``--objective cost=1 emissions=0.5``)
OBJECTIVE_NAMES = ("cost", "emissions", "consumption", "average_daily_peak")
#: MPC's forecasts (pipeline.optimal.forecasts.FORECASTS; repeated so the parser imports nothing heavy)
FORECASTS = ("perfect", "persistence", "day_ahead", "predicted")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``optimal`` to the ``districtgen`` sub-commands."""
    parser = subparsers.add_parser(
        "optimal", help="the perfect-foresight optimum of a district's storage (a linear program, HiGHS)")
    parser.add_argument("schema", type=Path, help="a CityLearn schema.json (a built district's or upstream's)")
    parser.add_argument("--objective", nargs="+", default=["cost"], metavar="NAME[=WEIGHT]",
                        help=f"one of {', '.join(OBJECTIVE_NAMES)}, or weighted terms (cost=1 emissions=0.5)")
    parser.add_argument("--normalise", action="store_true",
                        help="divide each weight by the objective's no-control value (unit-free weights)")
    parser.add_argument("--start", type=int, help="first data row of the period (default: the schema's)")
    parser.add_argument("--end", type=int, help="last data row of the period, inclusive (default: the schema's)")
    parser.add_argument("-o", "--output", type=Path, help="write the schedule (actions and SOC per step) here")
    parser.add_argument("--compat", action="store_true", help="plan and replay in the CityLearn 2.1 preset")
    parser.add_argument("--no-check", action="store_true", help="skip the replay of the schedule in the env")
    parser.add_argument("--workers", type=int, default=1, help="processes solving buildings in parallel")
    parser.add_argument("--certify", type=float, metavar="SECONDS",
                        help="seconds per building for tightening the certified lower bound with each step's "
                             "battery power range as a choice (default CERTIFY_SECONDS, 60; 0: the linear relaxation's bound)")
    parser.add_argument("--mpc", action="store_true",
                        help="also run receding-horizon MPC and print it beside the oracle; -o writes its actions")
    parser.add_argument("--horizon", type=int, default=24, help="with --mpc: steps planned ahead (default 24)")
    parser.add_argument("--forecast", default="perfect", choices=FORECASTS,
                        help="with --mpc: what the controller knows ahead (default perfect)")
    parser.add_argument("--train", type=int, nargs=2, metavar=("START", "END"),
                        help="with --mpc: data rows (inclusive) the day-ahead profiles learn from (default: every "
                             "row before the period)")
    parser.set_defaults(func=optimal_command)


def parse_objective(terms: list[str]) -> str | dict[str, float]:
    """``["cost"]`` -> ``"cost"``; ``["cost=1", "emissions=0.5"]`` -> ``{"cost": 1.0, "emissions": 0.5}``;
    an unknown name or a weight that is not a finite number is one :class:`InputError` naming the option."""
    from pipeline.errors import InputError

    weights: dict[str, float] = {}
    for term in terms:
        name, _, weight = term.partition("=")
        if name not in OBJECTIVE_NAMES:
            raise InputError(f"unknown objective {name!r}; known: {', '.join(OBJECTIVE_NAMES)}",
                             column="--objective")
        try:
            value = float(weight) if weight else 1.0
        except ValueError:
            value = float("nan")
        if not value == value or value in (float("inf"), float("-inf")) or value < 0:
            raise InputError(f"the weight of {name} must be a finite number >= 0, got {weight!r}",
                             column="--objective")
        weights[name] = value
    if len(weights) == 1 and len(terms) == 1 and "=" not in terms[0]:
        return terms[0]
    return weights


#: the forecasts that learn from past data rows (the others ignore --train)
TRAINED_FORECASTS = ("day_ahead", "predicted")


def check_mpc_options(args: argparse.Namespace) -> None:
    """Refuse (one line) ``--horizon`` below 1 and ``--train`` with a forecast that does not learn from it."""
    from pipeline.errors import InputError

    if args.horizon < 1:
        raise InputError(f"--horizon N needs N >= 1 steps, got {args.horizon}", column="--horizon")
    if args.train is not None and args.forecast not in TRAINED_FORECASTS:
        raise InputError(f"--train applies to the forecasts that learn from past rows ({', '.join(TRAINED_FORECASTS)}"
                         f"); --forecast {args.forecast} ignores it", column="--train")


def optimal_command(args: argparse.Namespace) -> int:
    from pipeline.errors import InputError
    from pipeline.optimal.optimum import CERTIFY_SECONDS, optimal

    if args.workers < 1:
        raise InputError("--workers N needs N >= 1", column="--workers")
    if args.certify is not None and not 0 <= args.certify < float("inf"):
        raise InputError(f"--certify SECONDS needs a finite number >= 0, got {args.certify}", column="--certify")
    if not args.mpc and (args.horizon != 24 or args.forecast != "perfect" or args.train is not None):
        raise InputError("--horizon, --forecast and --train apply to --mpc only", column="--mpc")
    check_mpc_options(args)
    control = {"horizon": args.horizon, "forecast": args.forecast,
               "train": None if args.train is None else tuple(args.train)} if args.mpc else None
    from pipeline.optimal.solver import SolveError

    try:
        optimal(args.schema, parse_objective(args.objective), start=args.start, end=args.end, out=args.output,
                settings="citylearn-2.1" if args.compat else None, normalise=args.normalise,
                check=not args.no_check, workers=args.workers, control=control,
                certify=CERTIFY_SECONDS if args.certify is None else args.certify)
    except SolveError as error:  # a status HiGHS reports: one line, exit 1 (the input passed every check)
        print(f"districtgen: error: {args.schema}: the oracle's linear program was not solved: {error}",
              file=sys.stderr)
        return 1
    return 0
