"""The ``districtgen`` command.

Each feature area registers its own sub-commands through a ``register(subparsers)`` function, so this file
stays a thin dispatcher: ingest commands live in :mod:`pipeline.ingest.commands`, surrogate commands in
:mod:`surrogates.cli`, environment commands in :mod:`pipeline.run`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from citylearn_env.errors import SchemaError
from pipeline.errors import InputError


def build_parser() -> argparse.ArgumentParser:
    from pipeline import run
    from pipeline.ingest import commands as ingest_commands
    from surrogates import cli as surrogate_commands

    parser = argparse.ArgumentParser(prog="districtgen", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run.register(sub)
    ingest_commands.register(sub)
    surrogate_commands.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit status (2 for bad input, with a one-line message)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (InputError, SchemaError) as error:
        print(f"districtgen: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
