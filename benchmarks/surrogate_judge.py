"""Each house of a district, its surrogate trained like the build and judged on a fresh EnergyPlus run.

    .venv/bin/python benchmarks/surrogate_judge.py [raw/district.toml] [--bldg-ids 8 61] [--recipe build|default]
        [--set hidden_size=16 pretrain_steps=2000 ...] [--data /tmp/districtgen_judge]

Per house: the training ILV table (the build's ``[simulation]`` settings and months,
:func:`pipeline.builder.surrogates.ilv_config`) and the judge's table (:func:`surrogates.judge.judge_ilv_config`:
20 timesteps/h, another seed, the same months) are simulated once and kept under ``--data`` (keyed by house,
settings and the generator's sources); then the recipe trains (float32 or what ``precision`` resolves to, one
thread; ``build``: the config's own training settings, on the period's season) and the model is scored by
:func:`surrogates.judge.score_judge_table` over the simulated months (a June config: June; a full-year one,
or a season across the new year: the whole year).
One JSON line per house: monthly RMSE median and worst month, the median of the period's months,
mean absolute errors (partial loads, ideal loads), CPU seconds of training, best epoch, closed-loop validation
RMSE [degC]; then the CPU model and load average.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import platform
import sys
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import pandas as pd  # noqa: E402

import surrogates  # noqa: E402
from pipeline.builder.cache import files_digest  # noqa: E402
from pipeline.builder.surrogates import JUDGE_SOURCES, ilv_config, train_config  # noqa: E402
from pipeline.config import BuildConfig, read_build_config  # noqa: E402
from pipeline.ingest.stock import read_characteristics_row  # noqa: E402
from surrogates.config import BUILD_RECIPE, TrainConfig, season_months  # noqa: E402
from surrogates.energyplus.ilv_runs import ILVConfig  # noqa: E402
from surrogates.judge import JudgeConfig, judge_ilv_config, score_judge_table  # noqa: E402
from surrogates.sources.energyplus import energyplus_ilv_table  # noqa: E402
from surrogates.train import train_surrogate  # noqa: E402

RECIPES = {"build": BUILD_RECIPE, "default": TrainConfig()}


def cached_table(row: dict, epw: Path, config, folder: Path) -> pd.DataFrame:
    """The ILV table of ``row`` under ``config``, simulated once per (row, EPW, config, generator sources)."""
    package = Path(surrogates.__file__).parent
    key = hashlib.sha256(json.dumps([row, str(epw), asdict(config), files_digest(
        [package / f for f in JUDGE_SOURCES], package)], sort_keys=True, default=str).encode()).hexdigest()[:16]
    path = folder / f"{row['bldg_id']}_{config.timesteps_per_hour}tph_{key}.parquet"
    if not path.exists():
        folder.mkdir(parents=True, exist_ok=True)
        energyplus_ilv_table(row, epw, config=config).table.to_parquet(path, index=False)
    return pd.read_parquet(path)


def parse_settings(pairs: list[str]) -> dict:
    """``key=value`` pairs typed after the :class:`TrainConfig` field's default."""
    out = {}
    for pair in pairs:
        key, value = pair.split("=", 1)
        default = getattr(TrainConfig(), key)
        if isinstance(default, bool):
            out[key] = value.lower() == "true"
        elif isinstance(default, tuple):  # inputs=a,b,c or months=12,1,2
            out[key] = tuple(int(v) if v.isdigit() else v for v in value.split(","))
        else:
            out[key] = type(default)(value)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default="raw/district.toml")
    parser.add_argument("--bldg-ids", type=int, nargs="+", help="default: the district's houses (selection)")
    parser.add_argument("--recipe", choices=sorted(RECIPES), default="build")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="TrainConfig overrides")
    parser.add_argument("--judge-timesteps", type=int, default=JudgeConfig().timesteps_per_hour,
                        help="the judge's zone timesteps per hour (default: the build's); the training data's "
                             "count is the config's [simulation] timesteps_per_hour")
    parser.add_argument("--data", type=Path, default=Path(os.environ.get("TMPDIR", "/tmp")) / "districtgen_judge")
    args = parser.parse_args()
    config = read_build_config(args.config)
    if args.bldg_ids is None:
        from pipeline.builder.steps import resolve_selection

        config, _ = resolve_selection(config)
    ids = args.bldg_ids or list(config.inputs.buildings)
    # "build": the build's own TrainConfig (its [surrogate] settings, trained on the period's season)
    base = train_config(config) if args.recipe == "build" else RECIPES[args.recipe]
    recipe = replace(base, progress=False, threads=1, **parse_settings(args.set))
    served = period_months(config)
    training_ilv = ilv_config(config)
    judge_ilv = judge_ilv_config(training_ilv, JudgeConfig(timesteps_per_hour=args.judge_timesteps))
    for number, bldg_id in enumerate(ids, 1):
        row = read_characteristics_row(config.inputs.characteristics, bldg_id)
        result = judge_house(row, config.inputs.weather, training_ilv, judge_ilv, recipe, args.data, served)
        print(json.dumps({"house": bldg_id, "building": f"Building_{number}" if args.bldg_ids is None else None,
                          "recipe": args.recipe, "set": args.set, **result}), flush=True)
    print(json.dumps({"cpu": cpu_model(), "load_average": os.getloadavg()}))


def judge_house(row: dict, epw: Path, training_ilv: ILVConfig, judge_ilv: ILVConfig, recipe: TrainConfig,
                data: Path, served: set[int], prepare: Callable[[pd.DataFrame], pd.DataFrame] | None = None) -> dict:
    """One house: its training and judge tables (simulated once, :func:`cached_table`), the recipe trained on the
    first and scored closed loop on the second (:func:`surrogates.judge.score_judge_table`). Returns the monthly
    closed-loop RMSE median and worst month, the mean absolute errors of the partial-load runs and of the ideal
    replay, the calendar-month medians and the median over the ``served`` months [degC]; the training's CPU
    seconds (its thread's own), the precision it ran in, its best epoch and that epoch's closed-loop validation
    RMSE [degC]. ``prepare``: a trial's change to both tables after they are read (e.g. a column added)."""
    table = cached_table(row, epw, training_ilv, data)
    fresh = cached_table(row, epw, judge_ilv, data)
    if prepare is not None:
        table, fresh = prepare(table), prepare(fresh)
    trained = train_surrogate(table, recipe)
    s = score_judge_table(trained.model, trained.normalization, trained.inputs, trained.config.lookback, fresh)
    return {"median_c": s["median_c"], "worst_c": s["worst_c"], "mean_abs_c": s["mean_abs_c"],
            "ideal_mean_abs_c": s["ideal_mean_abs_c"], "by_month_c": by_month(s["monthly"]),
            "period_median_c": period_median(s["monthly"], served), "months": list(recipe.months),
            "train_cpu_s": round(trained.cpu_seconds, 1), "precision": trained.config.precision,
            "best_epoch": trained.best_epoch,
            "val_closed_loop_rmse_c": trained.history[trained.best_epoch]["val_closed_loop_rmse_c"]}


def full_year(config: BuildConfig) -> BuildConfig:
    """``config`` with its period the whole calendar year of its start (a full-year build)."""
    year = config.period.start.year
    return config.model_copy(update={"period": config.period.model_copy(
        update={"start": datetime.date(year, 1, 1), "end": datetime.date(year, 12, 31)})})


def period_months(config) -> set[int]:
    """The calendar months of the config's period (what a build's judge scores): its season without margin."""
    return set(season_months(config.period.start, config.period.end, margin=0)) or set(range(1, 13))


def period_median(monthly: list[dict], months: set[int]) -> float:
    """Median of the monthly closed-loop RMSE rows of ``months`` [degC] (the build judges only those)."""
    frame = pd.DataFrame(monthly)
    return round(float(frame.loc[frame["month"].isin(months), "rmse_c"].median()), 4)


def by_month(monthly: list[dict]) -> dict[int, float]:
    """Median over the judge's partial-load runs of each calendar month's closed-loop RMSE [degC]."""
    frame = pd.DataFrame(monthly)
    return {int(m): round(float(v), 3) for m, v in frame.groupby("month")["rmse_c"].median().items()}


def cpu_model() -> str:
    """The CPU's model name (``lscpu``'s "Model name", from /proc/cpuinfo), else the machine type."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.machine()
    return next((line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")), platform.machine())


if __name__ == "__main__":
    main()
