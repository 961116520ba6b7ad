"""Do two finished paper runs' SAC rows differ beyond their seeds? (e.g. bfloat16 against float32 updates)

    .venv/bin/python benchmarks/paper_precision.py RUN_A RUN_B [--multiplier 3]

RUN_A and RUN_B are ``districtgen paper`` output folders (their ``results.csv``: per row the mean over seeds,
the sample standard deviation ``<name>_sd`` and ``seeds``, as :func:`pipeline.paper.results.summarise` wrote
them). For every SAC configuration both hold at ``--multiplier``: the configuration's own objective (``c`` cost
$, ``e`` emissions kg, ``p`` the district's average daily peak kW, ``d_o`` discomfort C h and consumption kWh),
mean +- std over each run's seeds, the precision each side ran, the difference A - B (also in % of B) and
Welch's t = difference / sqrt(s_A^2 / n_A + s_B^2 / n_B). SAC amplifies float32 rounding, so the seeds'
spread is the scale a difference must clear. Prints markdown rows.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd

#: the results.csv columns that measure each objective of pipeline.paper.benchmarks.Benchmark
OBJECTIVE_COLUMNS = {"cost": ("cost",), "emissions": ("emissions",), "peak": ("average_daily_peak",),
                     "discomfort_consumption": ("discomfort", "consumption")}


def read_sac_rows(folder: Path, multiplier: float) -> pd.DataFrame:
    """The SAC rows of ``folder/results.csv`` at ``multiplier``, indexed by benchmark id."""
    rows = pd.read_csv(folder / "results.csv")
    return rows[(rows["controller"] == "sac") & (rows["multiplier"] == multiplier)].set_index("id")


def compare(a: pd.DataFrame, b: pd.DataFrame) -> list[str]:
    """One markdown row per configuration and objective column held by both ``a`` and ``b``."""
    from pipeline.paper.benchmarks import BENCHMARKS

    lines = []
    for bench in (x for x in BENCHMARKS if x.id in a.index and x.id in b.index):
        side_a, side_b = a.loc[bench.id], b.loc[bench.id]
        for column in OBJECTIVE_COLUMNS[bench.objective]:
            cells = [f"{side['precision']} | {side['seeds']} | {side[column]:.3f} ± {side[column + '_sd']:.3f}"
                     for side in (side_a, side_b)]
            diff = side_a[column] - side_b[column]
            se = math.sqrt(sum(side[column + "_sd"] ** 2 / side["seeds"] for side in (side_a, side_b)))
            t = f"{diff / se:+.2f}" if se > 0 else "-"
            share = f" ({100 * diff / side_b[column]:+.2f} %)" if side_b[column] else ""
            lines.append(f"| {bench.id} | {column} | {cells[0]} | {cells[1]} | {diff:+.3f}{share} | {t} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_a", type=Path)
    parser.add_argument("run_b", type=Path)
    parser.add_argument("--multiplier", type=float, default=3.0, help="the over-cooling multiplier m compared")
    args = parser.parse_args()
    rows = compare(read_sac_rows(args.run_a, args.multiplier), read_sac_rows(args.run_b, args.multiplier))
    print("| configuration | objective | A precision | A seeds | A mean ± std | B precision | B seeds | B mean ± std | "
          "A - B | Welch t |\n|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
