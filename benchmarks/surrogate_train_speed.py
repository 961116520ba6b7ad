"""Surrogate trainer speed: the previous trainer (a git revision) against the working tree, side by side in
one process, one torch thread, on one cached suite building (office2004, Sterling, upstream's hourly
multipliers; train references 0-5 as in benchmarks/surrogate_suite.py).

    .venv/bin/python benchmarks/surrogate_train_speed.py [--old 428fd94] [--repeats 3] [--hidden 16 32]
                                                         [--variants old new new_bf16]
                                                         [--recipe default|build] [--table ILV.parquet]

Per (hidden size, variant) it reports the median process CPU seconds of ``repeats`` trainings (each the
whole ``train_surrogate`` call: setup, warm start, closed-loop epochs, validation), the wall seconds, the
epochs run, the best epoch and its validation RMSE, and whether the weights equal the old trainer's bit for
bit. Every variant trains its own ``TrainConfig()`` (``--recipe build``: ``BUILD_RECIPE``, hidden 16 unless
``--hidden`` says otherwise) at the hidden size asked for, with the suite's splits (``--table``: any ILV
table instead, e.g. a district's ``surrogates/Building_6.ilv.parquet``),
in float32 (``new_bf16``: ``precision="auto"``, bfloat16 where the CPU runs it natively and faster), so with
a revision whose default recipe is the working tree's (the eighth pass's, ``c69e254`` and later; the
``precision`` field needs ``3063899`` or later) only the implementation differs. Rounds interleave the
variants (old, new, ... then again) so load changes hit all alike; the 1-, 5- and 15-minute load averages
are printed before and after. The old trainer's ``surrogates/model.py`` and ``surrogates/train.py`` are read
with ``git show`` and imported under other module names; nothing in the working tree or the git state
changes. The accuracy of the recipe on the suite's buildings is ``benchmarks/surrogate_suite.py run``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from revisions import import_source, source_at  # noqa: E402

from surrogates import train as new_train  # noqa: E402
from surrogates.config import BUILD_RECIPE  # noqa: E402
from surrogates.ilv import read_ilv  # noqa: E402

CACHE = Path(os.environ.get("DISTRICTGEN_SUITE_CACHE", "/tmp/districtgen_surrogate_suite"))
TABLE = CACHE / "ilv" / "office2004__mixed_sterling__upstream__1f94dbc3c278.parquet"


def load_revision(revision: str, folder: Path):
    """The trainer module of ``revision`` (its model module imported as ``old_surrogates_model``)."""
    import_source("old_surrogates_model", source_at(revision, "surrogates/model.py"), folder)
    return import_source("old_surrogates_train", source_at(revision, "surrogates/train.py").replace(
        "from surrogates.model import", "from old_surrogates_model import"), folder)


def run_once(trainer, table, hidden: int, bf16: bool, recipe: str = "default") -> dict:
    """One training of ``trainer``'s default recipe with no test run (``build``: ``BUILD_RECIPE`` as the build
    trains it) at ``hidden`` (float32, or ``auto`` with ``bf16``); CPU and wall seconds of the whole call."""
    # the suite trains on references 0-5 with no test run; the build's recipe keeps its own held-out run
    base = BUILD_RECIPE if recipe == "build" else trainer.TrainConfig(test_runs=0)
    config = replace(base, progress=False, hidden_size=hidden, precision="auto" if bf16 else "float32")
    cpu, wall = time.process_time(), time.perf_counter()
    trained = trainer.train_surrogate(table, config)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    best = trained.history[trained.best_epoch]["val_closed_loop_rmse_c"]
    return {"cpu": cpu, "wall": wall, "epochs": len(trained.history), "best_epoch": trained.best_epoch,
            "val_rmse_c": best, "state": {k: v.clone() for k, v in trained.model.state_dict().items()}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", default="428fd94", help="git revision of the previous trainer (3063899 or "
                                                          "later: it has TrainConfig.precision)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--hidden", type=int, nargs="*", default=None, help="default: 16 32 (build: 16)")
    parser.add_argument("--variants", nargs="*", default=["old", "new", "new_bf16"])
    parser.add_argument("--recipe", choices=["default", "build"], default="default")
    parser.add_argument("--table", type=Path, default=TABLE, help="ILV table (default: the suite's office)")
    args = parser.parse_args()
    if args.hidden is None:
        args.hidden = [BUILD_RECIPE.hidden_size] if args.recipe == "build" else [16, 32]
    if not args.table.is_file():
        raise SystemExit(f"{args.table} missing: run benchmarks/surrogate_suite.py generate first")
    table = read_ilv(args.table)
    table = table[table["reference"].isin(range(6))].reset_index(drop=True)
    torch.optim.Adam([torch.zeros(1, requires_grad=True)])  # torch.optim's one-time import, outside the timings
    print(f"load average before: {os.getloadavg()}; torch {torch.__version__}; old = {args.old}; recipe "
          f"{args.recipe}; table {args.table}", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        trainers = {"old": load_revision(args.old, Path(folder)), "new": new_train, "new_bf16": new_train}
        runs: dict[tuple[int, str], list[dict]] = {}
        for hidden in args.hidden:
            for repeat in range(args.repeats):
                for variant in args.variants:
                    result = run_once(trainers[variant], table, hidden, variant.endswith("bf16"), args.recipe)
                    runs.setdefault((hidden, variant), []).append(result)
                    print(f"hidden {hidden} {variant} #{repeat}: {result['cpu']:.2f} s CPU, {result['wall']:.2f} s "
                          f"wall, load {os.getloadavg()[0]:.2f}", flush=True)
    print(f"load average after: {os.getloadavg()}\n")
    print(f"| hidden | trainer | CPU s (median of {args.repeats}) | CPU s runs | wall s (median) | epochs (best) | "
          "best val RMSE, degC | weights = old |")
    print("|---|---|---|---|---|---|---|---|")
    for (hidden, variant), results in runs.items():
        first, cpus = results[0], ", ".join(f"{r['cpu']:.1f}" for r in results)
        old = runs.get((hidden, "old"), [None])[0]
        same = "-" if old is None or variant == "old" else \
            ("yes" if all(torch.equal(v, old["state"][k]) for k, v in first["state"].items()) else "no")
        print(f"| {hidden} | {variant} | {statistics.median(r['cpu'] for r in results):.2f} | "
              f"{cpus} | {statistics.median(r['wall'] for r in results):.2f}"
              f" | {first['epochs']} ({first['best_epoch']}) | {first['val_rmse_c']:.4f} | {same} |")


if __name__ == "__main__":
    main()
