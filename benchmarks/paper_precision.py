"""Do two finished paper runs' SAC rows differ beyond their seeds? (e.g. bfloat16 against float32 updates)

    .venv/bin/python benchmarks/paper_precision.py RUN_A RUN_B [--multiplier 3]

RUN_A and RUN_B are ``districtgen paper`` output folders (their ``runs.csv``). For every SAC configuration
both hold at ``--multiplier``: the configuration's own objective (``c`` cost $, ``e`` emissions kg, ``p`` the
district's average daily peak kW, ``d_o`` discomfort C h and consumption kWh), mean +- sample standard
deviation over each run's seeds, the precision each side ran, the difference A - B (also in % of B) and
Welch's t = difference / sqrt(s_A^2 / n_A + s_B^2 / n_B). SAC amplifies float32 rounding, so the seeds'
spread is the scale a difference must clear. Prints markdown rows.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd

#: the runs.csv columns that measure each objective of pipeline.paper.benchmarks.Benchmark
OBJECTIVE_COLUMNS = {"cost": ("cost",), "emissions": ("emissions",), "peak": ("average_daily_peak",),
                     "discomfort_consumption": ("discomfort", "consumption")}


def read_sac_runs(folder: Path, multiplier: float) -> pd.DataFrame:
    """The SAC rows of ``folder/runs.csv`` at ``multiplier``."""
    runs = pd.read_csv(folder / "runs.csv")
    return runs[(runs["controller"] == "sac") & (runs["multiplier"] == multiplier)]


def spread(values: pd.Series) -> tuple[float, float]:
    """Mean and sample standard deviation (0 for one value)."""
    return float(values.mean()), float(values.std(ddof=1)) if len(values) > 1 else 0.0


def compare(a: pd.DataFrame, b: pd.DataFrame) -> list[str]:
    """One markdown row per configuration and objective column held by both ``a`` and ``b``."""
    from pipeline.paper.benchmarks import BENCHMARKS

    rows = []
    for bench in (x for x in BENCHMARKS if x.id in set(a["id"]) & set(b["id"])):
        side_a, side_b = a[a["id"] == bench.id], b[b["id"] == bench.id]
        for column in OBJECTIVE_COLUMNS[bench.objective]:
            (mean_a, sd_a), (mean_b, sd_b) = spread(side_a[column]), spread(side_b[column])
            diff = mean_a - mean_b
            se = math.sqrt(sd_a ** 2 / len(side_a) + sd_b ** 2 / len(side_b))
            t = f"{diff / se:+.2f}" if se > 0 else "-"
            share = f" ({100 * diff / mean_b:+.2f} %)" if mean_b else ""
            rows.append(f"| {bench.id} | {column} | {'/'.join(sorted(set(side_a['precision'])))} | {len(side_a)} | "
                        f"{mean_a:.3f} ± {sd_a:.3f} | {'/'.join(sorted(set(side_b['precision'])))} | {len(side_b)} | "
                        f"{mean_b:.3f} ± {sd_b:.3f} | {diff:+.3f}{share} | {t} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_a", type=Path)
    parser.add_argument("run_b", type=Path)
    parser.add_argument("--multiplier", type=float, default=3.0, help="the over-cooling multiplier m compared")
    args = parser.parse_args()
    rows = compare(read_sac_runs(args.run_a, args.multiplier), read_sac_runs(args.run_b, args.multiplier))
    print("| configuration | objective | A precision | A seeds | A mean ± std | B precision | B seeds | B mean ± std | "
          "A - B | Welch t |\n|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
