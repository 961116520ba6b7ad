"""CLI sub-commands ``districtgen surrogate train|evaluate|install`` (train and evaluate also plain Python
functions). ``install`` and ``evaluate --judge`` work on a built district, which is pipeline work this package
may not import: :func:`register` takes their handlers from the caller (``districtgen``: pipeline.builder.commands)."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Callable
from pathlib import Path

from citylearn_env.errors import InputError
from citylearn_env.outputs import check_output_name, check_slug, output_file, output_folder
from surrogates.config import BUILD_RECIPE, STARTS, TrainConfig, recipe
from surrogates.precision import PRECISIONS
from surrogates.sources.csv import read_ilv_table


def train(table_path: str | os.PathLike, out_dir: str | os.PathLike, name: str | None = None,
          config: TrainConfig | None = None) -> dict:
    """Read an ILV table (CSV/parquet), train ``config`` (default: the build's recipe,
    :func:`surrogates.config.recipe`), evaluate and export; returns the metrics report. ``name`` defaults to the
    table's file stem without ``.ilv`` (a district's ``surrogates/Building_1.ilv.parquet`` -> ``Building_1``)."""
    from surrogates.export import train_and_export  # torch: the CLI builds its parser without it

    name = check_slug(name or Path(table_path).stem.removesuffix(".ilv"), column="--name", file=table_path)
    folder = output_folder(out_dir, column="--out-dir", create=False)  # never a link, never in a built district
    for suffix in TRAIN_OUTPUTS:
        check_output_name(folder, f"{name}{suffix}", column="--out-dir")
    table = read_ilv_table(table_path)  # a bad table fails before the folder is made
    return train_and_export(table, output_folder(folder, column="--out-dir"), name,
                            config if config is not None else recipe(), source=table_path)


#: what ``surrogate train`` writes into its folder, after the building's name
TRAIN_OUTPUTS = (".pth", ".dynamics.json", ".metrics.json", ".png")


def evaluate(pth: str | os.PathLike, table_path: str | os.PathLike, all_runs: bool = False,
             plot: str | os.PathLike | None = None, months: tuple[int, ...] | None = None) -> dict:
    """Metrics of an exported model on an ILV table: its held-out test segments (or every run) in ``months``
    (None: the months the model was trained on, from its record, else every month; ``()``: every month); with
    ``plot`` also the PNG of simulated vs predicted temperature."""
    from surrogates.evaluate import evaluate_segments, plot_predictions  # torch: not at parser build
    from surrogates.export import load_surrogate  # torch: not at parser build
    from surrogates.train import run_segments, split_segments, within_months  # torch: not at parser build

    if plot:
        output_file(plot, column="--plot")  # before the work: not through a link, not into a built district
    model, norm, names, lookback = load_surrogate(pth)
    table = read_ilv_table(table_path)
    segments = list(run_segments(table).values()) if all_runs else split_segments(table)["test"]
    months = trained_months(pth) if months is None else months
    if months:
        segments = within_months(table, {"scored": segments}, months)["scored"]
        if not segments:
            raise InputError(f"no rows to score in the months {','.join(map(str, months))} the model serves "
                             "(--months all scores every month)", file=table_path, column="months")
    metrics, hours = evaluate_segments(model, norm, names, lookback, table, segments)
    metrics["months"] = list(months)
    if plot:
        plot_predictions(hours, plot, title=f"{Path(pth).stem} on {Path(table_path).name}")
    return metrics


def trained_months(pth: str | os.PathLike) -> tuple[int, ...]:
    """The calendar months a model was trained on, from its record (``<stem>.metrics.json`` next to the .pth,
    or under ``surrogates/`` beside it in a built district); ``()`` (every month) without one."""
    from surrogates.export import record_path  # torch: not at parser build

    record = record_path(pth, "metrics.json")
    if not record.is_file():
        return ()
    try:
        months = json.loads(record.read_text()).get("training", {}).get("config", {}).get("months")
    except (ValueError, AttributeError):
        return ()
    return tuple(int(m) for m in months or ())


def _months(text: str) -> tuple[int, ...]:
    """``--months 12,1,2`` -> (12, 1, 2), ``all`` -> () (:attr:`TrainConfig.months` checks the range)."""
    if text == "all":
        return ()
    try:
        return tuple(int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"comma-separated calendar months 1-12, got {text!r}") from None


def train_settings(args: argparse.Namespace) -> TrainConfig:
    """The training settings of ``districtgen surrogate train``: the build's recipe
    (:data:`surrogates.config.BUILD_RECIPE`, read when called) with the options given over it."""
    return recipe(hidden_size=args.hidden, num_layers=args.layers, epochs=args.epochs,
                  pretrain_steps=args.pretrain_steps, seed=args.seed, precision=args.precision, start=args.start,
                  progress=not args.quiet, months=args.months)


def _train_command(args: argparse.Namespace) -> int:
    report = train(args.table, args.out_dir, args.name, train_settings(args))
    print(json.dumps({"building": report["building"], "files": report["files"],
                      "train_seconds": report["training"]["train_seconds"],
                      "precision": report["training"].get("precision"),
                      "one_step_rmse_c": report["test"]["one_step_rmse_c"],
                      "closed_loop_rmse_c": report["test"]["closed_loop_rmse_c"],
                      "monthly_rmse_c": report["test"]["monthly_rmse_c"]}, indent=2))
    return 0


def _evaluate_command(args: argparse.Namespace) -> int:
    from surrogates.evaluate import month_table  # torch: the CLI builds its parser without it

    if args.judge:
        if args.judge_handler is None:
            raise InputError("--judge needs the district pipeline: install districtgen[pipeline,energyplus]",
                             column="--judge")
        return args.judge_handler(args)
    if args.table is None:
        raise InputError("give an ILV table, or --judge CONFIG to score against a fresh EnergyPlus run",
                         column="table")
    plot = args.plot or Path(args.model).with_suffix(".evaluate.png")
    metrics = evaluate(args.model, args.table, all_runs=args.all, plot=plot, months=args.months)
    if args.json:
        print(json.dumps(metrics, indent=2))
        return 0
    print(month_table(metrics["monthly"]))
    print(f"closed-loop monthly RMSE median {metrics['monthly_rmse_c']['median']:.3f} C, max "
          f"{metrics['monthly_rmse_c']['max']:.3f} C; closed-loop RMSE {metrics['closed_loop_rmse_c']:.3f} C, "
          f"one-step {metrics['one_step_rmse_c']:.3f} C over {metrics['hours']} h"
          f"{' of the months ' + ','.join(map(str, metrics['months'])) if metrics['months'] else ''}; plot {plot}")
    return 0


#: a sub-command's handler: parsed arguments -> exit status
Handler = Callable[[argparse.Namespace], int]


def _needs_the_pipeline(args: argparse.Namespace) -> int:
    raise InputError("surrogate install needs the district pipeline: install districtgen[pipeline]",
                     column="install")


def register(subparsers: argparse._SubParsersAction, *, install: Handler | None = None,
             judge: Handler | None = None) -> None:
    """Add ``surrogate train|evaluate|install`` to ``districtgen``. ``install`` runs ``surrogate install`` and
    ``judge`` runs ``surrogate evaluate --judge`` (both on a built district: pipeline work, given by the caller;
    None: the command says it needs the pipeline)."""
    parser = subparsers.add_parser("surrogate", help="train or evaluate an LSTM indoor-temperature surrogate")
    sub = parser.add_subparsers(dest="surrogate_command", required=True)
    shown = BUILD_RECIPE  # the defaults the help shows; the command reads the recipe when it runs
    train_parser = sub.add_parser("train", help="train one building's LSTM on an ILV table and export it; the "
                                                "options default to the build's recipe (BUILD_RECIPE)")
    train_parser.add_argument("table", help="ILV table (.csv or .parquet), see docs/surrogates.md")
    train_parser.add_argument("-o", "--out-dir", required=True, help="folder for <name>.pth, .dynamics.json, "
                              ".metrics.json, .png")
    train_parser.add_argument("--name", help="building name (default: the table's file stem without .ilv)")
    train_parser.add_argument("--hidden", type=int, help=f"LSTM hidden size (default {shown.hidden_size})")
    train_parser.add_argument("--layers", type=int, help=f"stacked LSTM layers (default {shown.num_layers})")
    train_parser.add_argument("--epochs", type=int,
                              help=f"closed-loop epochs (max; default {shown.epochs}, the last "
                                   f"{shown.long_chunk_epochs} on {shown.long_chunk_hours}-h chunks)")
    train_parser.add_argument("--pretrain-steps", type=int,
                              help="one-step warm-start updates before the closed-loop epochs (default "
                                   f"{shown.pretrain_steps})")
    train_parser.add_argument("--seed", type=int, help=f"default {shown.seed}")
    train_parser.add_argument("--months", type=_months, default=(), metavar="M,M,...",
                              help="train and validate on these calendar months only, e.g. 12,1,2 (a build "
                                   "trains on its period's months and one either side; default: every month)")
    train_parser.add_argument("--start", choices=STARTS,
                              help="initial weights: random (seeded) or generic (the model trained once on many "
                                   "houses, surrogates/generic.py, where its size matches: hidden 16, 2 layers; "
                                   f"default {shown.start})")
    train_parser.add_argument("--precision", choices=PRECISIONS,
                              help="numeric mode of the updates: auto = bfloat16 only where this CPU multiplies "
                                   f"it natively and it measures faster, else float32 (default {shown.precision})")
    train_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    train_parser.set_defaults(func=_train_command)
    eval_parser = sub.add_parser("evaluate", help="print the per-month closed-loop table and write the plot, or "
                                                  "judge against a fresh EnergyPlus run of the house (--judge)")
    eval_parser.add_argument("model", help="<name>.pth written by 'surrogate train' (dynamics JSON beside it)")
    eval_parser.add_argument("table", nargs="?", help="ILV table (.csv or .parquet); not with --judge")
    eval_parser.add_argument("--judge", metavar="CONFIG",
                             help="district TOML: score against a fresh EnergyPlus run of the model's house (another "
                                  "zone timestep count and seed than the training data; docs/surrogates.md)")
    eval_parser.add_argument("--bldg-id", type=int, help="--judge: the house (default: buildings.json beside the "
                                                         "model)")
    eval_parser.add_argument("--all", action="store_true", help="evaluate every run, not only the test split")
    eval_parser.add_argument("--months", type=_months, default=None, metavar="M,M,...|all",
                             help="score these calendar months (default: the months the model was trained on, "
                                  "from its metrics record; all: every month)")
    eval_parser.add_argument("--plot", help="PNG of prediction vs simulation (default: <model>.evaluate.png)")
    eval_parser.add_argument("--json", action="store_true", help="print the metrics as JSON instead")
    eval_parser.set_defaults(func=_evaluate_command, judge_handler=judge)
    install_parser = sub.add_parser(
        "install", help="put a retrained model into a built district (checked, validated, manifest rewritten)")
    install_parser.add_argument("district", type=Path, help="a built district folder (with manifest.json)")
    install_parser.add_argument("building", help="the schema building to replace the model of, e.g. Building_1")
    install_parser.add_argument("model", type=Path, help="<name>.pth written by 'surrogate train' (dynamics JSON "
                                                         "beside it), or its folder")
    install_parser.add_argument("--force", action="store_true",
                                help="install even when the district no longer matches its manifest")
    install_parser.set_defaults(func=install or _needs_the_pipeline)
