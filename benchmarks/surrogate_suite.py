"""Independent surrogate validation suite: EnergyPlus reference models shipped with pyenergyplus-lbnl (not our
parametric house), 3 climates, 2 partial-load schemes; train on references 0-5, score the unseen 6-7
closed-loop, month by month, in the environment's and CityLearn 2.1's rollout semantics.

    .venv/bin/python benchmarks/surrogate_suite.py generate            # EnergyPlus ILV tables (cached)
    .venv/bin/python benchmarks/surrogate_suite.py run [--recipe default] [--houses ...] [--climates ...]
    .venv/bin/python benchmarks/surrogate_suite.py table [--recipe default]   # markdown table of the results

``--loads`` (``net`` or ``gross``: how the zones' loads are aggregated in the ILV tables) and
``--timesteps-per-hour`` (EnergyPlus zone timesteps) choose the data
(:class:`reference_houses.SuiteSettings`, whose defaults are the suite's); results and
models are kept apart per data variant (:func:`data_label`). Cache (ILV tables, exported models, results):
``$DISTRICTGEN_SUITE_CACHE`` or /tmp/districtgen_surrogate_suite (``results/<label>/<recipe>.jsonl``,
``models/<label>/<recipe>/``); every step skips what is already there, so an interrupted run resumes. ``run``
trains in this one process (one torch thread) and records wall seconds and the 1-minute load average at the
end of each training. Recipes (``--recipe``) are :func:`recipes`: the trainer's default; the ablations of
docs/surrogates.md ran at the commits it names (check one out and ``run --recipe <name>`` there).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import reference_houses as rh  # noqa: E402
from citylearn_env.settings import CITYLEARN_2_1, CORRECTED  # noqa: E402
from surrogates.config import BUILD_RECIPE, TrainConfig  # noqa: E402
from surrogates.evaluate import bank_rollout, monthly_rmse  # noqa: E402
from surrogates.export import dynamics_block, save_checkpoint  # noqa: E402
from surrogates.ilv import read_ilv  # noqa: E402
from surrogates.train import run_segments, train_surrogate  # noqa: E402

CACHE = Path(os.environ.get("DISTRICTGEN_SUITE_CACHE", "/tmp/districtgen_surrogate_suite"))
#: climate -> EPW shipped in pyenergyplus/data/weather (TMY3)
CLIMATES = {
    "hot_humid_tampa": "USA_FL_Tampa.Intl.AP.722110_TMY3.epw",
    "mixed_sterling": "USA_VA_Sterling-Washington.Dulles.Intl.AP.724030_TMY3.epw",
    "cold_chicago": "USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw",
}
TRAIN_REFERENCES = (0, 1, 2, 3, 4, 5)
TEST_REFERENCES = (6, 7)


def recipes() -> dict[str, TrainConfig]:
    """Named training configurations, all with the suite's splits (``test_runs=0``: references 6-7 are scored
    apart): ``build`` is the build's and ``districtgen surrogate train``'s :data:`surrogates.config.BUILD_RECIPE`
    (hidden 16, 5000 warm-start updates of batch 16, 16 closed-loop epochs, from the generic model: an input of
    the table it lacks starts with zero weights); ``build_random`` the same from seeded random weights;
    ``default`` is ``TrainConfig()`` (hidden 32, lookback 1, updates in the precision the CPU runs fastest, no
    day-type inputs, 6000 teacher-forced updates on 48-h sequences with a temperature history perturbed after
    its first 6 hours, every pass holding the first sequence of each training run, 32 closed-loop epochs at 5e-4
    all run, 48-h chunks then the last 10 on 168-h chunks at a low rate)."""
    build = replace(BUILD_RECIPE, progress=False, test_runs=0)
    return {"build": build, "build_random": replace(build, start="random"),
            "default": TrainConfig(progress=False, test_runs=0)}


def suite_settings(args: argparse.Namespace) -> rh.SuiteSettings:
    """The generation settings the command line chose."""
    return rh.SuiteSettings(loads=args.loads, timesteps_per_hour=args.timesteps_per_hour)


def data_label(settings: rh.SuiteSettings) -> str:
    """Folder name of one data variant's results and models, e.g. ``net_tph4``."""
    return f"{settings.loads}_tph{settings.timesteps_per_hour}"


def epw(climate: str) -> Path:
    return rh.package_data_dir("weather") / CLIMATES[climate]


def houses(names: list[str] | None) -> list[rh.ReferenceHouse]:
    chosen = [h for h in rh.SUITE_HOUSES if not names or h.name in names]
    if not chosen:
        raise SystemExit(f"no such house; choose from {[h.name for h in rh.SUITE_HOUSES]}")
    return chosen


def generate(args: argparse.Namespace) -> None:
    for house in houses(args.houses):
        for climate in args.climates:
            started = time.perf_counter()
            paths = rh.generate_reference_ilv(house, climate, epw(climate), CACHE, schemes=args.schemes,
                                              settings=suite_settings(args))
            print(f"{house.name} {climate}: {time.perf_counter() - started:.1f} s "
                  f"{[p.name for p in paths.values()]}", flush=True)


def evaluate_one(table, pth: Path, block: dict) -> dict:
    """Monthly closed-loop RMSE on the test references in both rollout semantics."""
    runs = run_segments(table)
    out = {}
    for label, settings in (("env", CORRECTED), ("cl21", CITYLEARN_2_1)):
        hours = bank_rollout(pth, block, table, [runs[r] for r in TEST_REFERENCES], settings)
        monthly = monthly_rmse(hours)
        out[label] = {"median": float(np.median(monthly["rmse_c"])), "max": float(np.max(monthly["rmse_c"])),
                      "monthly": monthly["rmse_c"].round(4).tolist()}
    return out


def run(args: argparse.Namespace) -> None:
    config = recipes()[args.recipe]
    if args.seed is not None:
        config = replace(config, seed=args.seed)
    label = data_label(suite_settings(args))
    run_name = f"{args.recipe}{'' if args.seed is None else f'_seed{args.seed}'}"
    results = CACHE / "results" / label / f"{run_name}.jsonl"
    results.parent.mkdir(parents=True, exist_ok=True)

    def done() -> set[str]:  # re-read before every building: several workers may share the results file
        return {json.loads(line)["key"] for line in results.read_text().splitlines()} if results.is_file() else set()

    for house in houses(args.houses):
        for climate in args.climates:
            paths = rh.generate_reference_ilv(house, climate, epw(climate), CACHE, schemes=args.schemes,
                                              settings=suite_settings(args))
            for scheme, path in paths.items():
                key = f"{house.name}/{climate}/{scheme}"
                if key in done():
                    continue
                table = read_ilv(path)
                train = table[table["reference"].isin(TRAIN_REFERENCES)].reset_index(drop=True)
                trained = train_surrogate(train, config, source=path)
                load = os.getloadavg()[0]
                folder = CACHE / "models" / label / run_name  # per recipe and seed: seeds may run in parallel
                folder.mkdir(parents=True, exist_ok=True)
                name = key.replace("/", "__")
                pth = save_checkpoint(trained, folder / f"{name}.pth")
                block = dynamics_block(trained, str(pth)).to_schema()
                scores = evaluate_one(table, pth, block)
                row = {"key": key, "house": house.name, "climate": climate, "scheme": scheme, "data": label,
                       "seconds": round(trained.seconds, 2), "cpu_seconds": round(trained.cpu_seconds, 2),
                       "load_average": round(load, 2),
                       "epochs": len(trained.history), "best_epoch": trained.best_epoch,
                       "val_rmse_c": [h["val_closed_loop_rmse_c"] for h in trained.history], **scores}
                with results.open("a") as handle:
                    handle.write(json.dumps(row) + "\n")
                print(f"{key}: {trained.seconds:.1f} s, cpu {trained.cpu_seconds:.1f} s (load {load:.1f}) env {scores['env']['median']:.3f}/"
                      f"{scores['env']['max']:.3f} cl21 {scores['cl21']['median']:.3f}/{scores['cl21']['max']:.3f}",
                      flush=True)


def read_results(recipe: str, label: str) -> dict[str, dict]:
    """key -> result row of one recipe on one data variant (:func:`data_label`; the last row of a key wins)."""
    path = CACHE / "results" / label / f"{recipe}.jsonl"
    rows = [json.loads(line) for line in path.read_text().splitlines()] if path.is_file() else []
    return {r["key"]: {**r, "recipe": recipe} for r in rows}


def table(args: argparse.Namespace) -> None:
    label = data_label(suite_settings(args))
    chosen = read_results(args.recipe, label)
    if args.fallback:  # rows the recipe has not run yet, from another recipe (marked in the last column)
        chosen = {**read_results(args.fallback, label), **chosen}
    rows = list(chosen.values())
    print("| house | climate | scheme | env median / max, degC | CityLearn 2.1 median / max, degC | train wall s | "
          "train CPU s | load avg | goal | recipe |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["house"], r["climate"], r["scheme"])):
        within = all(r[k]["median"] <= 0.3 and r[k]["max"] <= 0.6 for k in ("env", "cl21"))
        print(f"| {r['house']} | {r['climate']} | {r['scheme']} | {r['env']['median']:.3f} / {r['env']['max']:.3f}"
              f" | {r['cl21']['median']:.3f} / {r['cl21']['max']:.3f} | {r['seconds']:.1f} | {r['cpu_seconds']:.1f}"
              f" | {r['load_average']:.1f} | {'yes' if within and r['cpu_seconds'] <= 30 else '**no**'}"
              f" | {r['recipe']} |")
    print(f"\n{len(rows)} buildings; rows within the accuracy goal (both semantics): "
          f"{sum(all(r[k]['median'] <= 0.3 and r[k]['max'] <= 0.6 for k in ('env', 'cl21')) for r in rows)}; "
          f"worst median {max(r['env']['median'] for r in rows):.3f}, worst month "
          f"{max(r['env']['max'] for r in rows):.3f} degC; CPU s {min(r['cpu_seconds'] for r in rows):.1f}-"
          f"{max(r['cpu_seconds'] for r in rows):.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["generate", "run", "table"])
    parser.add_argument("--houses", nargs="*")
    parser.add_argument("--climates", nargs="*", default=list(CLIMATES))
    parser.add_argument("--schemes", nargs="*", default=list(rh.SCHEMES))
    parser.add_argument("--recipe", choices=list(recipes()), default="default")
    parser.add_argument("--loads", choices=list(rh.LOAD_AGGREGATIONS), default=rh.SuiteSettings().loads,
                        help="zone-load aggregation of the ILV tables (gross: per-direction sums; net: netted)")
    parser.add_argument("--timesteps-per-hour", type=int, default=rh.SuiteSettings().timesteps_per_hour,
                        help="EnergyPlus zone timesteps per hour of the generated tables")
    parser.add_argument("--seed", type=int)
    parser.add_argument("--fallback", help="table: recipe whose rows fill the keys --recipe has not run")
    args = parser.parse_args()
    {"generate": generate, "run": run, "table": table}[args.command](args)


if __name__ == "__main__":
    main()
