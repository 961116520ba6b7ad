"""Regenerate the generic starting model (surrogates/data/generic_lstm.json, :mod:`surrogates.generic`).

    .venv/bin/python benchmarks/generic_start.py [raw/district.toml] [--rows 1 3 4 ...] [--steps 20000]
        [--data /tmp/districtgen_judge] [-o surrogates/data/generic_lstm.json]

Each stock row is simulated like a full-year build of the configuration (its weather, the calendar year of its
period, its ``[simulation]`` settings; tables kept under ``--data``, as ``benchmarks/surrogate_judge.py`` keeps
them), the tables are pooled, each scaled to its own [0, 1] (:func:`surrogates.generic.pool_tables`), and one
LSTM of the build's size is trained on them in float32 on one thread. About 36 s of EnergyPlus per row and a
minute of training on a 2-core Intel Xeon (family 6 model 207). The default rows: sixteen occupied
single-family rows of raw/'s stock of four climate zones, none of the default district's houses.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from surrogate_judge import cached_table, full_year  # noqa: E402

from pipeline.builder.surrogates import ilv_config  # noqa: E402
from pipeline.config import read_build_config  # noqa: E402
from pipeline.ingest.stock import read_characteristics_row  # noqa: E402
from surrogates.config import BUILD_RECIPE  # noqa: E402
from surrogates.generic import GENERIC_FILE, pool_tables, write_generic  # noqa: E402
from surrogates.train import train_surrogate  # noqa: E402

ROWS = (1, 3, 4, 5, 6, 9, 10, 12, 15, 16, 18, 19, 20, 22, 23, 24)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=str(ROOT / "raw" / "district.toml"))
    parser.add_argument("--rows", type=int, nargs="+", default=list(ROWS))
    parser.add_argument("--steps", type=int, default=20000, help="warm-start updates on the pooled tables")
    parser.add_argument("--data", type=Path, default=Path("/tmp/districtgen_judge"))
    parser.add_argument("-o", "--out", type=Path, default=GENERIC_FILE)
    args = parser.parse_args()
    config = full_year(read_build_config(args.config))
    year = config.period.start.year
    simulation = ilv_config(config)
    tables = []
    for bldg_id in args.rows:
        row = read_characteristics_row(config.inputs.characteristics, bldg_id)
        tables.append(cached_table(row, config.inputs.weather, simulation, args.data))
        print(f"row {bldg_id}: {len(tables[-1])} rows", flush=True)
    recipe = replace(BUILD_RECIPE, start="random", pretrain_steps=args.steps, epochs=4, long_chunk_epochs=1,
                     precision="float32", progress=False, threads=1)
    trained = train_surrogate(pool_tables(tables, recipe.inputs), recipe)
    best = trained.history[trained.best_epoch]
    about = {"rows": list(args.rows), "weather": Path(config.inputs.weather).name, "year": year,
             "timesteps_per_hour": simulation.timesteps_per_hour, "partial_runs": simulation.partial_runs,
             "steps": args.steps, "epochs": recipe.epochs, "seed": recipe.seed,
             "val_closed_loop_rmse_unit": best["val_closed_loop_rmse_c"]}
    write_generic(args.out, trained.model, trained.inputs, about)
    print(f"wrote {args.out}: inputs {trained.inputs}, validation {best['val_closed_loop_rmse_c']} of each "
          f"house's range, {trained.cpu_seconds:.1f} CPU s")


if __name__ == "__main__":
    main()
