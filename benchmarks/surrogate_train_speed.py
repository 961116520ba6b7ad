"""Surrogate trainer speed: the previous trainer (a git revision) against the working tree, side by side in
one process, one torch thread, on one cached suite building (office2004, Sterling, upstream's hourly
multipliers; train references 0-5 as in benchmarks/surrogate_suite.py).

    .venv/bin/python benchmarks/surrogate_train_speed.py speed [--old 266628d] [--repeats 3] [--hidden 16 32]
                                                               [--variants old new new_bf16]
    .venv/bin/python benchmarks/surrogate_train_speed.py accuracy [--houses ...] [--climates ...] [--schemes ...]
                                                                  [--variants new new_bf16]

Per (hidden size, variant) it reports the median process CPU seconds of ``repeats`` trainings (each the
whole ``train_surrogate`` call: setup, one-step pretraining, closed-loop epochs, validation), the wall
seconds, the epochs run, the best epoch and its validation RMSE, and whether the weights equal the old
trainer's bit for bit. Rounds interleave the variants (old, new, ... then again) so load changes hit all
alike; the 1-, 5- and 15-minute load averages are printed before and after. The old trainer's
``surrogates/model.py`` and ``surrogates/train.py`` are read with ``git show`` and imported under other
module names; nothing in the working tree or the git state changes.

``accuracy`` trains the suite's ``hidden32`` recipe (float32 updates, and bfloat16 updates for ``new_bf16``) on
suite buildings and scores them like ``benchmarks/surrogate_suite.py run`` (closed-loop monthly RMSE of the
test references, both rollout semantics); rows go to ``$CACHE/results/train_speed_<variant>.jsonl`` (the
suite's own result files are not touched) and a table of both variants is printed.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
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
from surrogates.ilv import read_ilv  # noqa: E402

CACHE = Path(os.environ.get("DISTRICTGEN_SUITE_CACHE", "/tmp/districtgen_surrogate_suite"))
TABLE = CACHE / "ilv" / "office2004__mixed_sterling__upstream__1f94dbc3c278.parquet"


def load_revision(revision: str, folder: Path):
    """The trainer module of ``revision`` (its model module imported as ``old_surrogates_model``)."""
    import_source("old_surrogates_model", source_at(revision, "surrogates/model.py"), folder)
    return import_source("old_surrogates_train", source_at(revision, "surrogates/train.py").replace(
        "from surrogates.model import", "from old_surrogates_model import"), folder)


def run_once(trainer, table, hidden: int, bf16: bool) -> dict:
    """One training; CPU and wall seconds of the whole call."""
    config = trainer.TrainConfig(progress=False, test_runs=0, hidden_size=hidden)
    if bf16:
        config = replace(config, bf16_updates=True)
    cpu, wall = time.process_time(), time.perf_counter()
    trained = trainer.train_surrogate(table, config)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    best = trained.history[trained.best_epoch]["val_closed_loop_rmse_c"]
    return {"cpu": cpu, "wall": wall, "epochs": len(trained.history), "best_epoch": trained.best_epoch,
            "val_rmse_c": best, "state": {k: v.clone() for k, v in trained.model.state_dict().items()}}


def suite_module():
    """benchmarks/surrogate_suite.py as a module (its recipes, houses and scoring)."""
    spec = importlib.util.spec_from_file_location("surrogate_suite", ROOT / "benchmarks" / "surrogate_suite.py")
    suite = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(suite)
    return suite


def accuracy(args: argparse.Namespace) -> None:
    """Suite rows of the ``hidden32`` recipe with float32 and with bfloat16 updates."""
    from surrogates.energyplus import reference_houses as rh
    from surrogates.export import dynamics_block, save_checkpoint

    suite = suite_module()

    base = suite.recipes()["hidden32"]
    rows: dict[str, dict[str, dict]] = {}
    with tempfile.TemporaryDirectory() as folder:
        for house in suite.houses(args.houses):
            for climate in args.climates:
                paths = rh.generate_reference_ilv(house, climate, suite.epw(climate), CACHE, schemes=args.schemes)
                for scheme, path in paths.items():
                    key = f"{house.name}/{climate}/{scheme}"
                    table = read_ilv(path)
                    train = table[table["reference"].isin(suite.TRAIN_REFERENCES)].reset_index(drop=True)
                    for variant in args.variants:
                        results = CACHE / "results" / f"train_speed_{variant}.jsonl"
                        done = {json.loads(line)["key"]: json.loads(line) for line in
                                results.read_text().splitlines()} if results.is_file() else {}
                        if key not in done:
                            config = replace(base, bf16_updates=variant.endswith("bf16"))
                            trained = new_train.train_surrogate(train, config, source=path)
                            pth = save_checkpoint(trained, Path(folder) / f"{variant}.pth")
                            scores = suite.evaluate_one(table, pth, dynamics_block(trained, str(pth)).to_schema())
                            done[key] = {"key": key, "cpu_seconds": round(trained.cpu_seconds, 2),
                                         "load_average": round(os.getloadavg()[0], 2),
                                         "epochs": len(trained.history), "best_epoch": trained.best_epoch, **scores}
                            results.parent.mkdir(parents=True, exist_ok=True)
                            with results.open("a") as handle:
                                handle.write(json.dumps(done[key]) + "\n")
                        rows.setdefault(key, {})[variant] = done[key]
                        print(f"{key} {variant}: env {done[key]['env']['median']:.3f} / {done[key]['env']['max']:.3f}"
                              f", {done[key]['cpu_seconds']:.1f} s CPU", flush=True)
    print("\n| building | " + " | ".join(f"{v}: env median / max, CL 2.1 median / max, CPU s (epochs)"
                                          for v in args.variants) + " |")
    print("|---|" + "---|" * len(args.variants))
    for key, by_variant in rows.items():
        cells = [f"{r['env']['median']:.3f} / {r['env']['max']:.3f}, {r['cl21']['median']:.3f} / "
                 f"{r['cl21']['max']:.3f}, {r['cpu_seconds']:.1f} ({r['epochs']})" for r in by_variant.values()]
        print(f"| {key} | " + " | ".join(cells) + " |")
    for variant in args.variants:
        medians = [rows[k][variant]["env"]["median"] for k in rows]
        maxima = [rows[k][variant]["env"]["max"] for k in rows]
        print(f"{variant}: mean of the env medians {statistics.mean(medians):.3f}, of the maxima "
              f"{statistics.mean(maxima):.3f} degC over {len(rows)} buildings")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["speed", "accuracy"])
    parser.add_argument("--old", default="266628d", help="speed: git revision of the previous trainer")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--hidden", type=int, nargs="*", default=[16, 32])
    parser.add_argument("--variants", nargs="*")
    parser.add_argument("--houses", nargs="*")
    parser.add_argument("--climates", nargs="*", default=["hot_humid_tampa", "mixed_sterling", "cold_chicago"])
    parser.add_argument("--schemes", nargs="*", default=["upstream", "held"])
    args = parser.parse_args()
    if args.command == "accuracy":
        args.variants = args.variants or ["new", "new_bf16"]
        accuracy(args)
        return
    args.variants = args.variants or ["old", "new", "new_bf16"]
    if not TABLE.is_file():
        raise SystemExit(f"{TABLE} missing: run benchmarks/surrogate_suite.py generate first")
    table = read_ilv(TABLE)
    table = table[table["reference"].isin(range(6))].reset_index(drop=True)
    torch.optim.Adam([torch.zeros(1, requires_grad=True)])  # torch.optim's one-time import, outside the timings
    print(f"load average before: {os.getloadavg()}; torch {torch.__version__}; old = {args.old}", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        trainers = {"old": load_revision(args.old, Path(folder)), "new": new_train, "new_bf16": new_train}
        runs: dict[tuple[int, str], list[dict]] = {}
        for hidden in args.hidden:
            for repeat in range(args.repeats):
                for variant in args.variants:
                    result = run_once(trainers[variant], table, hidden, variant.endswith("bf16"))
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
