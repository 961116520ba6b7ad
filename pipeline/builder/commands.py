"""The builder's commands: ``districtgen build`` and ``verify``, and the district work behind two ``surrogate``
sub-commands (``install``, ``evaluate --judge``: their parsers are the surrogates' own, :mod:`surrogates.cli`,
which hands them to :func:`install_command` and :func:`judge_command`).

``build`` runs the district build flow on a TOML configuration (default ``raw/district.toml``, the embedded
inputs); ``verify`` re-checks a build. Each command imports the build or the configuration (Prefect, pydantic,
torch: the ``pipeline`` extra) inside itself, so ``districtgen --help`` and ``run`` load none of them.
"""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

from citylearn_env.errors import SchemaError
from pipeline import progress
from pipeline.errors import InputError

ARTIFACTS = Path("artifacts")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``build`` and ``verify`` to the ``districtgen`` sub-commands."""
    build = subparsers.add_parser("build", help="build a district from a TOML configuration (Prefect flow)")
    build.add_argument("config", type=Path, nargs="?", default=Path("raw/district.toml"))
    build.add_argument("-o", "--output-root", type=Path, default=ARTIFACTS)
    build.add_argument("--no-prefect", action="store_true", help="run the steps in-process, without Prefect")
    build.add_argument("--dask", nargs="?", const="local", metavar="ADDRESS",
                       help="run the flow's tasks on Dask: a local cluster, or the scheduler at ADDRESS")
    build.add_argument("--workers", type=int, metavar="N",
                       help="worker processes of the local Dask cluster (default: the CPU count)")
    build.add_argument("--quiet", action="store_true", help="print nothing but errors (no progress, no summary)")
    build.add_argument("--cache-dir", type=Path, metavar="DIR",
                       help="surrogate cache root (default: the configuration's cache_dir, else "
                            "$DISTRICTGEN_CACHE_DIR, else ~/.cache/districtgen)")
    build.add_argument("--surrogate-source", choices=("csv", "energyplus", "fmu", "none"),
                       help="override [surrogate] source: precomputed ILV tables, EnergyPlus, the configured FMU, "
                            "or no surrogates")
    build.add_argument("--strict", action="store_true",
                       help="refuse the build when a house's surrogate misses the bound against a fresh EnergyPlus "
                            "run (monthly RMSE median 0.25 / worst month 0.5 degC); default: one warning per house")
    build.set_defaults(func=build_command)


    verify = subparsers.add_parser("verify", help="re-check a built district's manifest hashes and validate it")
    verify.add_argument("folder", type=Path)
    verify.add_argument("--expect", metavar="DIGEST",
                        help="the manifest digest the district must have (printed by build and verify; or a "
                             "file holding it, e.g. a copy of manifest.sha256): pins the whole build for CI")
    verify.set_defaults(func=verify_command)


def build_command(args: argparse.Namespace) -> int:
    from pipeline.builder.staging import staging
    from pipeline.config import read_build_config

    config = read_build_config(args.config)
    if args.cache_dir is not None:
        config = config.model_copy(update={"cache_dir": args.cache_dir.resolve()})
    if args.surrogate_source is not None:
        from pipeline.config import parse_build_config

        data = config.model_dump(exclude={"source"})
        data["surrogate"]["source"] = args.surrogate_source
        config = parse_build_config(data, file=f"{args.config} (--surrogate-source)")
    if args.strict:
        config = config.model_copy(update={"surrogate": config.surrogate.model_copy(update={"strict": True})})
    staging(config, args.output_root).check()  # a bad output folder: one line before any work
    if args.workers is not None and (args.workers < 1 or not args.dask or args.dask != "local"):
        raise InputError("--workers N (N >= 1) sizes the local Dask cluster: use it with --dask and no ADDRESS",
                         column="--workers")

    with progress.active(progress.make_reporter("quiet" if args.quiet else "auto")):
        folder = _build(config, args)
    if not args.quiet:
        from pipeline.builder.manifest import manifest_digest

        print(f"built {folder} (manifest digest {manifest_digest(folder)})")
        print((folder / "report" / "summary.md").read_text())
    return 0


def _build(config, args: argparse.Namespace) -> Path:
    """Run the build the way ``args`` asks; any failure that is not already one located error becomes one
    line (:class:`InputError` naming the configuration), never a traceback."""

    _quiet_orchestration()
    try:
        if args.no_prefect:
            from pipeline.builder.driver import build_district_local

            return build_district_local(config, args.output_root)
        if args.dask:
            from pipeline.flows import build_district_on_dask

            address = None if args.dask == "local" else args.dask
            return build_district_on_dask(config, str(args.output_root), address=address, workers=args.workers)
        from pipeline.flows import build_district, prefect_api

        with prefect_api():  # no Prefect server outlives the build
            return build_district(config, str(args.output_root))
    except (InputError, SchemaError, OSError, ModuleNotFoundError):
        raise
    except Exception as error:  # noqa: BLE001 - Prefect, Dask or a bug: one line, exit 2
        text = " ".join(str(error).split()) or "(no message)"
        raise InputError(f"build failed: {type(error).__name__}: {text[:400]}", file=args.config) from None


def _quiet_orchestration() -> None:
    """Prefect and Dask log failures with tracebacks on stderr; the CLI reports them itself in one line, so
    Prefect's console handlers show only critical messages (run logs go to a configured API only) and Dask's
    console logs likewise, unless the user set these variables. Must run before Prefect is imported."""
    for name in ("PREFECT_LOGGING_HANDLERS_CONSOLE_LEVEL", "PREFECT_LOGGING_HANDLERS_DEBUG_LEVEL"):
        os.environ.setdefault(name, "CRITICAL")
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "critical")


def verify_command(args: argparse.Namespace) -> int:
    """Re-hash every artifact and input of a district against its manifest (pipeline.builder.manifest.check_district):
    one line per problem or warning, naming the file; exit 2 when anything differs, else a validation run."""
    from pipeline.builder.manifest import check_district, manifest_digest
    from pipeline.builder.validate import validate_district

    if not args.folder.is_dir():
        raise InputError("not a folder (verify takes a built district's folder)", file=args.folder, column="folder")
    expect = parse_expected_digest(args.expect)
    try:
        result = check_district(args.folder, expect=expect)
    except (KeyError, TypeError, AttributeError, ValueError) as error:
        if isinstance(error, InputError):
            raise
        raise InputError(f"manifest.json is not a districtgen manifest ({type(error).__name__}: {error})",
                         file=args.folder / "manifest.json") from None
    for warning in result.warnings:
        print(f"districtgen: warning: {args.folder}: {warning}")
    for problem in result.problems:
        print(f"districtgen: {args.folder}: {problem}")
    if result.problems:
        print(f"districtgen: {args.folder}: {len(result.problems)} problem(s): the district differs from its "
              "manifest")
        return 2
    validate_district(args.folder / "schema.json")
    print(f"{args.folder}: every artifact and input matches the manifest ({len(result.warnings)} warning(s)); "
          "the environment runs it")
    print(f"manifest digest {manifest_digest(args.folder)}" + (" (as expected)" if expect else ""))
    return 0


def parse_expected_digest(value: str | None) -> str | None:
    """``verify --expect``: a 64-hex manifest digest, or a file whose ``manifest.json`` line (sha256sum format)
    or only word is one; anything else is one :class:`InputError` naming the option."""
    if value is None:
        return None
    text = value
    if not re.fullmatch(r"[0-9a-fA-F]{64}", value) and Path(value).is_file():
        lines = Path(value).read_text(errors="replace").split("\n")
        named = [line.split()[0] for line in lines if line.split()[1:] in (["manifest.json"], ["*manifest.json"])]
        words = [line.strip() for line in lines if line.strip()]
        text = (named or words or [""])[0]
    if not re.fullmatch(r"[0-9a-fA-F]{64}", text):
        raise InputError(f"expected a manifest digest (64 hex digits) or a file holding one, got {value[:80]!r}",
                         column="--expect")
    return text.lower()


def install_command(args: argparse.Namespace) -> int:
    """``surrogate install DISTRICT BUILDING MODEL``: a retrained model into a built district, re-verified
    (the work is :func:`pipeline.builder.install.install_surrogate`)."""
    from pipeline.builder.install import install_surrogate
    from pipeline.builder.manifest import verify_district

    folder = install_surrogate(args.district, args.building, args.model, force=args.force)
    problems = verify_district(folder)
    for problem in problems:
        print(f"districtgen: {folder}: {problem}")
    if problems:
        return 2
    print(f"installed {Path(args.model).name} as {args.building} in {folder}: validated, manifest rewritten, "
          "verify passes")
    return 0


def judge_command(args: argparse.Namespace) -> int:
    """``surrogate evaluate MODEL --judge CONFIG``: :func:`pipeline.builder.judge_district.judge_command`."""
    from pipeline.builder.judge_district import (
        judge_command as judge,  # the build (pydantic, torch, EnergyPlus)
    )

    return judge(args)
