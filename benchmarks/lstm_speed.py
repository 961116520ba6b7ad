"""LSTM inference cost per environment step: numpy vs numba backends of citylearn_env.dynamics.LSTMBank.

Run single-threaded:  NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 \
    .venv/bin/python benchmarks/lstm_speed.py
Uses the 2023 challenge Building_*.pth weights from ../shared (13 inputs, 2 layers, 16 units, lookback 12);
B buildings cycle through the six files. Reports the median over repeats of the mean us per bank.step call
(warm buffers, i.e. every call runs the full window for every building), wall and CPU (process) time, the
numpy/numba ratio of the CPU medians, the CPU model and the load average (the numpy path is the plain install's:
no numba; it batches every building of a group into one matmul per layer wavefront, see
citylearn_env/lstm_kernels.py). The repeats of the two backends alternate.

``--hidden H [H ...] [--lookback L ...]``: instead, random weights of the shape our trainer exports (the 12
default inputs, 2 layers; numba only), e.g. ``--hidden 32 64 --lookback 1 6 -- 1 6``.
"""

from __future__ import annotations

import argparse
import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from neighbourhood_speed import cpu_model  # noqa: E402

from citylearn_env.dataset import DynamicsBlock  # noqa: E402
from citylearn_env.dynamics import LSTMBank, LSTMSpec, read_pth_state_dict  # noqa: E402
from citylearn_env.settings import CITYLEARN_2_1  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "citylearn" / \
    "citylearn_challenge_2023_phase_3_1-v2.1"
NAMES = ("direct_solar_irradiance", "diffuse_solar_irradiance", "outdoor_dry_bulb_temperature",
         "indoor_dry_bulb_temperature_set_point", "occupant_count", "cooling_demand", "month_sin", "month_cos",
         "hour_sin", "hour_cos", "day_type_sin", "day_type_cos", "indoor_dry_bulb_temperature")
LOW = (0.0, 0.0, 21.7, 18.9, 0.0, 0.0, -0.87, -1.0, -1.0, -1.0, -0.97, -0.9, 12.8)
HIGH = (931.0, 486.5, 42.8, 24.4, 3.0, 12.7, 0.0, -0.5, 1.0, 1.0, 0.97, 1.0, 43.5)


def make_bank(n: int, backend: str) -> LSTMBank:
    states = [read_pth_state_dict(DATA / f"Building_{i}.pth") for i in range(1, 7)]
    block = DynamicsBlock("model.pth", NAMES, LOW, HIGH, hidden_size=16, num_layers=2, lookback=12)
    specs = [LSTMSpec(states[b % 6], block) for b in range(n)]
    return LSTMBank(specs, settings=CITYLEARN_2_1, backend=backend)


def make_surrogate_bank(n: int, hidden: int, lookback: int = 6) -> LSTMBank:
    """``n`` buildings with freshly initialised weights of the shape our trainer exports
    (``surrogates.model.LSTMModel`` on ``DEFAULT_INPUTS``, 2 layers; torch is imported only here)."""
    import torch

    from surrogates.config import DEFAULT_INPUTS
    from surrogates.model import LSTMModel

    names = DEFAULT_INPUTS
    block = DynamicsBlock("model.pth", names, (0.0,) * len(names), (1.0,) * len(names), hidden_size=hidden,
                          num_layers=2, lookback=lookback)
    specs = []
    for seed in range(n):
        torch.manual_seed(seed)
        state = {k: v.double().numpy() for k, v in LSTMModel(len(names), hidden, 2).state_dict().items()}
        specs.append(LSTMSpec(state, block))
    return LSTMBank(specs, settings=CITYLEARN_2_1, backend="numba")


def inputs(n: int, steps: int, seed: int = 0) -> list[dict[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    rows = []
    for t in range(steps):
        rows.append({"direct_solar_irradiance": rng.uniform(0, 900, n), "diffuse_solar_irradiance": rng.uniform(0, 400, n),
                     "outdoor_dry_bulb_temperature": rng.uniform(22, 40, n),
                     "indoor_dry_bulb_temperature_set_point": np.full(n, 23.0), "occupant_count": np.ones(n),
                     "cooling_demand": rng.uniform(0, 5, n), "heating_demand": np.zeros(n), "month": np.full(n, 6.0),
                     "hour": np.full(n, float(t % 24 + 1)), "day_type": np.full(n, float(t // 24 % 7 + 1)),
                     "indoor_dry_bulb_temperature": rng.uniform(22, 27, n)})
    return rows


def warm_bank(n: int, backend: str, steps: int, surrogate: tuple[int, int] | None = None):
    """(bank, input rows, hvac modes) with full buffers (and numba compiled). ``surrogate``: (hidden, lookback)
    of random weights of our exported shape instead of the 2023 files."""
    bank = make_bank(n, backend) if surrogate is None else make_surrogate_bank(n, *surrogate)
    rows = inputs(n, steps)
    hvac = np.ones(n)
    for row in rows[:20]:
        bank.step(row, hvac)
    return bank, rows, hvac


def timed_pass(bank: LSTMBank, rows: list[dict], hvac: np.ndarray) -> tuple[float, float]:
    """(wall, CPU) us per bank.step call over ``rows``."""
    start, cpu = time.perf_counter(), time.process_time()
    for row in rows:
        bank.step(row, hvac)
    return (time.perf_counter() - start) / len(rows) * 1e6, (time.process_time() - cpu) / len(rows) * 1e6


def us_per_step(n: int, backend: str, steps: int, repeats: int,
                surrogate: tuple[int, int] | None = None) -> tuple[float, float]:
    """(median, min) wall us per bank.step call."""
    bank, rows, hvac = warm_bank(n, backend, steps, surrogate)
    times = [timed_pass(bank, rows, hvac)[0] for _ in range(repeats)]
    return statistics.median(times), min(times)


def compare_backends(n: int, steps: int, repeats: int) -> dict[str, tuple[float, float, float]]:
    """backend -> (median wall, min wall, median CPU) us per bank.step call, the backends alternating."""
    banks = {backend: warm_bank(n, backend, steps) for backend in ("numpy", "numba")}
    runs: dict[str, list[tuple[float, float]]] = {backend: [] for backend in banks}
    for _ in range(repeats):
        for backend, (bank, rows, hvac) in banks.items():
            runs[backend].append(timed_pass(bank, rows, hvac))
    return {b: (statistics.median(w for w, _ in r), min(w for w, _ in r), statistics.median(c for _, c in r))
            for b, r in runs.items()}


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, help="numbers of buildings B (default 1 3 6 17; 1 6 with "
                        "--hidden)")
    parser.add_argument("--hidden", nargs="+", type=int, help="random weights of our exported shape instead")
    parser.add_argument("--lookback", nargs="+", type=int, default=[6], help="with --hidden: lookbacks")
    args = parser.parse_args(argv)
    if args.hidden:
        print("us per bank.step call (numba), random weights of our exported shape: median (min)")
        for lookback in args.lookback:
            for hidden in args.hidden:
                for n in args.sizes or [1, 6]:
                    med, low = us_per_step(n, "numba", 1000, 11, (hidden, lookback))
                    print(f"lookback {lookback:>2} hidden {hidden:>3} B {n:>3}: {med:>8.1f} ({low:>6.1f}) us, "
                          f"{med / n:.1f} per building")
        return
    print(f"CPU: {cpu_model()}; load average {os.getloadavg()}")
    print("us per bank.step call: wall median (min) over 9 repeats of 200 calls; CPU median; numpy/numba CPU")
    print(f"{'B':>3} {'numpy wall':>17} {'CPU':>7} {'numba wall':>17} {'CPU':>7} {'ratio':>6}")
    for n in args.sizes or [1, 3, 6, 17, 100]:
        res = compare_backends(n, 200, 9)
        (np_med, np_min, np_cpu), (nb_med, nb_min, nb_cpu) = res["numpy"], res["numba"]
        print(f"{n:>3} {np_med:>8.1f} ({np_min:>6.1f}) {np_cpu:>7.1f} {nb_med:>8.1f} ({nb_min:>6.1f}) {nb_cpu:>7.1f} "
              f"{np_cpu / nb_cpu:>6.2f}")
    print(f"load average after {os.getloadavg()}")


if __name__ == "__main__":
    main(sys.argv[1:])
