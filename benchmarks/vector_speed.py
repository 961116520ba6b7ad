"""Batch API throughput: env-steps per second of CityLearnVectorEnv for N = 1, 8, 64 copies.

    .venv/bin/python benchmarks/vector_speed.py [--repeats 3]

District: the shared 2023 phase-3-1 dataset, 3 LSTM buildings, one month, DHW + battery + heat-pump actions
(the same case as env_speed.py's "3 bldg, month, LSTM + heat pump"). One thread; median over repeats of a
whole episode (719 vector steps); throughput = N x steps / s.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ[var] = "1"
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from benchmarks.env_speed import CASES, DATASET, make_schema  # noqa: E402
from citylearn_env.settings import CITYLEARN_2_1  # noqa: E402
from citylearn_env.vector import CityLearnVectorEnv  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sizes", type=int, nargs="*", default=[1, 8, 64])
    args = parser.parse_args()
    if not DATASET.exists():
        sys.exit(f"needs the shared dataset at {DATASET}")
    schema = make_schema(**CASES["3 bldg, month, LSTM + heat pump"])
    print("| N copies | vector steps/s | env-steps/s (N x steps/s) | us per env-step |")
    print("|---|---|---|---|")
    for n in args.sizes:
        vec = CityLearnVectorEnv(schema, n, settings=CITYLEARN_2_1)
        rng = np.random.default_rng(0)
        low, high = vec.single_action_space.low, vec.single_action_space.high
        table = rng.uniform(low, high, size=(719, n, low.size))
        vec.reset(seed=0)
        for actions in table[:50]:  # warm-up (numba kernel load)
            vec.step(actions)
        rates = []
        for _ in range(args.repeats):
            vec.reset(seed=0)
            start = time.perf_counter()
            for actions in table:
                vec.step(actions)
            rates.append(len(table) / (time.perf_counter() - start))
        rate = statistics.median(rates)
        print(f"| {n} | {rate:,.0f} | {n * rate:,.0f} | {1e6 / (n * rate):.1f} |", flush=True)


if __name__ == "__main__":
    main()
