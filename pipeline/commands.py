"""Environment and build commands: ``districtgen run``, ``build`` and ``verify``.

``build`` runs the district build flow on a TOML configuration (default ``raw/district.toml``, the embedded
inputs); ``verify`` re-checks a build; ``run`` runs any schema (default: the synthetic example district the
package writes itself) through the environment and prints its KPI table.

Each command imports the build, the paper or the configuration (Prefect, pydantic, torch: the ``pipeline``
extra) inside itself, so ``districtgen --help`` and ``run`` on a plain install load none of them.
"""

from __future__ import annotations

import argparse
import os
import re
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.errors import SchemaError
from citylearn_env.example import write_example_district
from citylearn_env.footprint import memory_refusal
from pipeline import progress
from pipeline.controllers import run_policy
from pipeline.errors import InputError
from pipeline.paper.sac.train import BACKENDS
from pipeline.runners import DaskRunner
from surrogates.precision import PRECISIONS

ARTIFACTS = Path("artifacts")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("run", help="run a district (default: the example) and print its KPIs")
    parser.add_argument("--schema", type=Path, help="a CityLearn schema.json (default: the example district)")
    parser.add_argument("--policy", choices=("zero", "random"), default="random",
                        help="zero = no storage use (baseline); random = uniform random actions")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compat", action="store_true", help="reproduce CityLearn 2.1 exactly (bugs included)")
    parser.set_defaults(func=run_command)

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
    paper.set_defaults(func=paper_command)

    verify = subparsers.add_parser("verify", help="re-check a built district's manifest hashes and validate it")
    verify.add_argument("folder", type=Path)
    verify.add_argument("--expect", metavar="DIGEST",
                        help="the manifest digest the district must have (printed by build and verify; or a "
                             "file holding it, e.g. a copy of manifest.sha256): pins the whole build for CI")
    verify.set_defaults(func=verify_command)


def run_command(args: argparse.Namespace) -> int:


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
    with tempfile.TemporaryDirectory() as scratch:
        validate_district(args.folder / "schema.json", Path(scratch))
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


def paper_command(args: argparse.Namespace) -> int:
    from pipeline.paper.benchmarks import RunOptions
    from pipeline.paper.tasks import run_paper

    if args.sac_threads is not None and args.sac_threads < 1:
        raise InputError("--sac-threads N needs N >= 1 (leave it out to choose per task)", column="--sac-threads")
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
    return 0


def register_surrogate_install(surrogate_commands: argparse._SubParsersAction) -> None:
    """Add ``install`` to the ``districtgen surrogate`` sub-commands."""
    install_parser = surrogate_commands.add_parser(
        "install", help="put a retrained model into a built district (checked, validated, manifest rewritten)")
    install_parser.add_argument("district", type=Path, help="a built district folder (with manifest.json)")
    install_parser.add_argument("building", help="the schema building to replace the model of, e.g. Building_1")
    install_parser.add_argument("model", type=Path, help="<name>.pth written by 'surrogate train' (dynamics JSON "
                                                         "beside it), or its folder")
    install_parser.add_argument("--force", action="store_true",
                                help="install even when the district no longer matches its manifest")
    install_parser.set_defaults(func=_install_command)


def _install_command(args: argparse.Namespace) -> int:
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
