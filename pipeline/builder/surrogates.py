"""A building's LSTM surrogate in the build: its ILV table (csv, FMU or EnergyPlus), the cache key, training
through :mod:`surrogates`, the judge (cached on its own) and the files written into the district.
"""

from __future__ import annotations

import calendar
import io
import json
import re
import sys
import tempfile
import warnings
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import pandas as pd

import surrogates
from pipeline.builder.cache import FileCache, cache_key, cache_root, files_digest, sha256_bytes
from pipeline.builder.manifest import (
    package_version,
    sha256_file,
)
from pipeline.builder.staging import write_same_file
from pipeline.builder.steps import eulp_metadata_row
from pipeline.config import RECIPE_KEYS, BuildConfig
from pipeline.errors import InputError
from pipeline.ingest.stock import read_characteristics_row
from pipeline.ingest.weather import check_weather
from pipeline.progress import epochs, report
from surrogates.config import TrainConfig, recipe, season_months
from surrogates.energyplus.ilv_runs import ILVConfig, partial_runs_for
from surrogates.evaluate import replay_test_rmse
from surrogates.export import train_and_export
from surrogates.ilv import read_ilv, table_digest, validate_ilv
from surrogates.judge import JudgeConfig, judge_surrogate, verdict
from surrogates.plausibility import replay_far_off
from surrogates.precision import Choice
from surrogates.sources.energyplus import energyplus_ilv_table
from surrogates.sources.fmu import simulate_ilv_fmu
from surrogates.train import progress_units, update_precision

#: the trainer's source files (relative to the ``surrogates`` package), the generic starting model among them:
#: part of every surrogate cache key
TRAINER_SOURCES = ("config.py", "train.py", "model.py", "export.py", "evaluate.py", "ilv.py", "generic.py",
                   "data/generic_lstm.json")


#: what turns EULP metadata + EPW into an ILV table (every module of the house model): part of the key for
#: ``surrogate.source = "energyplus"``
ENERGYPLUS_SOURCES = ("sources/energyplus.py", *sorted(
    p.relative_to(Path(surrogates.__file__).parent).as_posix()
    for p in (Path(surrogates.__file__).parent / "energyplus").glob("*.py")))


#: the judge's sources (relative to ``surrogates``): part of the key of every judgement
JUDGE_SOURCES = ("judge.py", *ENERGYPLUS_SOURCES)

#: the file of a judgement cache entry (``<cache root>/judgements/<key>/``): the judge's record as JSON
JUDGE_RECORD = "judge.json"


@dataclass(frozen=True)
class SurrogateFiles:
    """A building's surrogate files (relative path -> bytes), the training cache key and whether the cache had
    the trained model; for a judged house also the judgement's cache key and whether that cache had it."""

    files: dict[str, bytes]
    key: str
    hit: bool
    judge_key: str | None = None
    judge_hit: bool | None = None


@dataclass(frozen=True)
class Judgement:
    """The judge's record of a trained surrogate (:func:`surrogates.judge.judge_record`, plain JSON), its cache
    key and whether the judgement cache had it."""

    record: dict
    key: str
    hit: bool


def train_config(config: BuildConfig) -> TrainConfig:
    """The :class:`surrogates.config.TrainConfig` of the build (single-threaded, no progress bar): the
    ``[surrogate]`` training settings (:data:`pipeline.config.RECIPE_KEYS`, each defaulting to the recipe's)
    over :data:`surrogates.config.BUILD_RECIPE` (about 30 s of CPU per building-year in float32 on an
    AVX2-only CPU), trained on the months the district serves its surrogates in: the period's and
    ``season_margin`` either side (:func:`surrogates.config.season_months`)."""

    s = config.surrogate
    months = season_months(config.period.start, config.period.end, s.season_margin)
    return replace(recipe(), **{key: getattr(s, key) for key in RECIPE_KEYS}, months=months, progress=False,
                   threads=1)


def resolve_precision(config: BuildConfig) -> tuple[BuildConfig, Choice | None]:
    """``config`` with ``[surrogate] precision`` resolved on this CPU (``auto`` -> ``float32`` or ``bfloat16``,
    :func:`surrogates.train.update_precision`) and the choice with its reason; ``(config, None)`` without
    surrogates. The build resolves once, in its own process, before any training: ``auto`` measures bfloat16
    against float32 where the CPU multiplies it natively, and a measurement repeated in each Dask worker, under
    the load of the other workers, could choose differently per house and per run, and the weights with it."""
    if config.surrogate.source == "none":
        return config, None
    choice = update_precision(train_config(config))
    surrogate = config.surrogate.model_copy(update={"precision": choice.precision})
    return config.model_copy(update={"surrogate": surrogate}), choice


def simulated_months(config: BuildConfig) -> tuple[tuple[int, int], tuple[int, int]]:
    """The run period ((month, day), (month, day)) of the houses' EnergyPlus pass: the whole months the district
    needs inside the period's year, its period's and its surrogates' training season (``season_margin``), in
    one span; the whole year when the season wraps around a new year, covers every month, or the period
    crosses a year. A June district simulates June (about a twelfth of a year's EnergyPlus time), a full-year
    district the year."""
    start, end = config.period.start, config.period.end
    months = season_months(start, end, config.surrogate.season_margin)
    if start.year != end.year or not months or list(months) != list(range(months[0], months[-1] + 1)):
        return (1, 1), (12, 31)
    return (months[0], 1), (months[-1], calendar.monthrange(start.year, months[-1])[1])


def ilv_config(config: BuildConfig) -> ILVConfig:
    """The ILV configuration of the build's EnergyPlus houses (``[simulation]``, the period's year, the months
    of :func:`simulated_months`): what their building tables come from and their surrogates train on.
    Partial-load runs: ``partial_runs``, or as many as give ``month_runs`` (run, month) pairs over the
    simulated months (a June house: 12 runs of June, 10 of them training data; docs/surrogates.md, section
    11)."""
    sim = config.simulation
    period = simulated_months(config)
    return ILVConfig(partial_runs=partial_runs_for(period, sim.partial_runs, sim.month_runs), seed=sim.seed,
                     timesteps_per_hour=sim.timesteps_per_hour, year=config.period.start.year,
                     free_float=sim.free_float, timezone=config.timezone, run_period=period,
                     schedule_seed=sim.schedule_seed)


def judge_config(config: BuildConfig) -> JudgeConfig:
    """The build's judge: the whole months of the district's period (the months its surrogates serve in), or
    the training data's year when the period crosses a new year."""
    start, end = config.period.start, config.period.end
    if start.year != end.year:
        return JudgeConfig()
    last = calendar.monthrange(end.year, end.month)[1]
    return JudgeConfig(run_period=((start.month, 1), (end.month, last)))


def judge_row(config: BuildConfig, bldg_id: int) -> dict[str, object] | None:
    """The stock row the judge simulates (EnergyPlus houses and EULP buildings with ``energyplus`` surrogates);
    None where there is no house to judge against (precomputed tables, FMUs, no surrogate)."""
    if config.surrogate.source == "none":
        return None
    if config.inputs.characteristics is not None:

        return read_characteristics_row(config.inputs.characteristics, bldg_id)
    if config.surrogate.source == "energyplus":
        return eulp_metadata_row(config, bldg_id)
    return None


def judge_training_config(config: BuildConfig) -> ILVConfig:
    """The ILV configuration the judged model was trained on: the houses' (:func:`ilv_config`), or the
    default of ``energyplus`` tables of EULP buildings (:func:`energyplus_ilv`)."""
    return ilv_config(config) if config.inputs.characteristics is not None else ILVConfig()


def judge_cache_part(config: BuildConfig, row: Mapping[str, object]) -> dict:
    """What a judgement is a function of (besides the model): the row, the weather file, both ILV configs
    (the judge's months come from the district's period) and the judge's and generator's sources."""
    package = Path(surrogates.__file__).parent
    return {"row": dict(row), "epw_sha256": sha256_file(Path(config.inputs.weather)),
            "judge": asdict(judge_config(config)), "training_ilv": judge_training_config(config).record(),
            "judge_sha256": files_digest([package / f for f in JUDGE_SOURCES], package)}


def judge_cache_parts(config: BuildConfig, row: Mapping[str, object], files: Mapping[str, bytes],
                      name: str) -> dict:
    """The key parts of a judgement (its own cache, not the training's): the trained model (sha256 of
    ``<name>.pth`` and of the dynamics block it loads with), :func:`judge_cache_part` and what scores the
    closed-loop rollout (the trainer's sources, :data:`TRAINER_SOURCES`, and the torch version)."""
    package = Path(surrogates.__file__).parent
    return {"model_sha256": sha256_bytes(files[f"{name}.pth"]),
            "dynamics_sha256": sha256_bytes(files[f"surrogates/{name}.dynamics.json"]),
            **judge_cache_part(config, row),
            "scorer_sha256": files_digest([package / f for f in TRAINER_SOURCES], package),
            "torch": package_version("torch")}


def check_cache_root(config: BuildConfig) -> None:
    """Refuse (one line naming the folder and key ``cache_dir``) a surrogate cache that cannot be written, before
    any work: creates ``<root>/surrogates`` and a scratch file in it. Nothing to check without surrogates."""
    if config.surrogate.source == "none":
        return
    folder = cache_root(config.cache_dir) / "surrogates"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".probe-"):
            pass
    except OSError as error:
        raise InputError(f"the surrogate cache cannot be written ({error.strerror or error}): set cache_dir, "
                         "--cache-dir or DISTRICTGEN_CACHE_DIR to a writable folder", file=folder,
                         column="cache_dir") from None


def csv_ilv_path(config: BuildConfig, bldg_id: int) -> Path:
    """``inputs.ilv/<bldg_id>.parquet`` (or ``.csv``) of a building (surrogate source ``csv``)."""
    if config.inputs.ilv is None:
        raise InputError("surrogate.source = 'csv' needs inputs.ilv (a folder of <bldg_id>.parquet/.csv)",
                         file=config.source, column="inputs.ilv")
    for suffix in (".parquet", ".csv"):
        path = config.inputs.ilv / f"{bldg_id}{suffix}"
        if path.exists():
            return path
    raise InputError(f"no ILV table for building {bldg_id}", file=config.inputs.ilv, column="inputs.ilv")


def surrogate_cache_parts(config: BuildConfig, bldg_id: int, name: str, table: pd.DataFrame | None = None,
                          weather: pd.Series | None = None) -> tuple[dict, pd.DataFrame | None]:
    """What a building's surrogate is a function of (the cache key parts), and its ILV table when at hand.

    Parts: the ILV table's content sha256 (a ``table`` given by the caller: a simulated house or an FMU run;
    else source ``csv``) or, for ``energyplus`` on EULP inputs, the EPW's sha256, the metadata row and the
    generator's sources; the full training configuration and the precision it resolves to on this CPU
    (:func:`surrogates.train.update_precision`); the trainer's sources (:data:`TRAINER_SOURCES`) and
    the torch version; the building's name and id (they are written into the files). Nothing else of the build
    configuration (battery, PV, period, ...) enters; nor does the judge (its months follow the period): it has
    its own key (:func:`judge_cache_parts`). With ``weather`` (the district's outdoor temperature [degC]) a csv
    table simulated on other weather is refused (:func:`check_weather`).
    """

    package = Path(surrogates.__file__).parent

    train = train_config(config)
    # the mode asked for is not a part: the mode that runs is (auto and its outcome asked for give one key)
    settings = {k: v for k, v in train.record().items() if k not in ("progress", "precision")}
    parts: dict[str, object] = {
        "building": name, "bldg_id": int(bldg_id), "train": settings,
        "precision": update_precision(train).precision,  # what runs here: auto resolves per CPU
        "trainer_sha256": files_digest([package / f for f in TRAINER_SOURCES], package),
        "torch": package_version("torch"),
    }
    if table is not None:
        parts["ilv"] = {"source": config.surrogate.source, "table_sha256": table_digest(table)}
        return parts, table
    if config.surrogate.source == "energyplus":
        parts["ilv"] = {"source": "energyplus", "epw_sha256": sha256_file(Path(config.inputs.weather)),
                        "metadata_row": eulp_metadata_row(config, bldg_id),
                        "generator_sha256": files_digest([package / f for f in ENERGYPLUS_SOURCES], package)}
        return parts, None

    path = csv_ilv_path(config, bldg_id)
    table = read_ilv(path)
    if weather is not None:
        ideal = table[table["reference"] == table["reference"].min()]
        check_weather(pd.Series(ideal["outdoor_dry_bulb_temperature"].to_numpy(dtype=float),
                                index=pd.DatetimeIndex(ideal["timestamp"])), weather,
                      what=f"ILV table of building {bldg_id}", file=path)
    parts["ilv"] = {"source": "csv", "table_sha256": table_digest(table)}
    return parts, table


def fmu_ilv(config: BuildConfig, frame: pd.DataFrame, weather: pd.DataFrame) -> pd.DataFrame:
    """The ILV table of a building from the configured FMU, driven by the building's ideal loads and the
    district's weather over the period (:func:`surrogates.sources.fmu.simulate_ilv_fmu`)."""

    s = config.surrogate
    loads = pd.DataFrame({
        "direct_solar_irradiance": weather["direct_solar_irradiance"].to_numpy(dtype=float),
        "diffuse_solar_irradiance": weather["diffuse_solar_irradiance"].to_numpy(dtype=float),
        "outdoor_dry_bulb_temperature": weather["outdoor_dry_bulb_temperature"].to_numpy(dtype=float),
        "occupant_count": frame["occupant_count"].to_numpy(dtype=float),
        "cooling_demand": frame["cooling_demand"].to_numpy(dtype=float),
        "heating_demand": frame["heating_demand"].to_numpy(dtype=float),
        "indoor_dry_bulb_temperature_set_point": frame["indoor_dry_bulb_temperature_set_point"].to_numpy(float),
    }, index=frame.index)
    return simulate_ilv_fmu(s.fmu, loads, s.fmu_variables, start_values=s.fmu_start_values, seed=s.seed,
                            holidays={d for d in config.inputs.holidays} or None)


def energyplus_ilv(config: BuildConfig, bldg_id: int) -> pd.DataFrame:
    """The building's ILV table simulated with the project's EnergyPlus house model (validated)."""

    result = energyplus_ilv_table(eulp_metadata_row(config, bldg_id), Path(config.inputs.weather),
                                  config=judge_training_config(config))
    return validate_ilv(result.table, source=f"EnergyPlus ILV of building {bldg_id}")


def ilv_file(name: str) -> str:
    """Where a building's training table goes in the district and in its cache entry:
    ``surrogates/<name>.ilv.parquet``."""
    return f"surrogates/{name}.ilv.parquet"


def ilv_parquet(table: pd.DataFrame, source: object = "<ILV table>") -> bytes:
    """The bytes of ``surrogates/<name>.ilv.parquet``: the table as training sees it
    (:func:`surrogates.ilv.validate_ilv`), ``to_parquet(index=False)`` with zstd compression; its content
    digest (:func:`surrogates.ilv.table_digest` of :func:`surrogates.ilv.read_ilv`) is the ``table_sha256`` of
    the model's metrics."""
    clean = validate_ilv(table, source=source)
    return clean.to_parquet(index=False, compression="zstd", compression_level=9)


def train_files(table: pd.DataFrame, bldg_id: int, name: str, settings) -> dict[str, bytes]:
    """Train, evaluate and export in a scratch folder; return the files (relative path -> bytes).

    ``<name>.pth`` goes next to the schema, ``surrogates/<name>.{dynamics,metrics}.json``, ``.png`` and the
    training table ``.ilv.parquet`` (:func:`ilv_parquet`) into ``surrogates/``.
    """
    source = f"ILV table of building {bldg_id}"
    with tempfile.TemporaryDirectory(prefix="districtgen_surrogate_") as scratch:
        folder = Path(scratch) / "surrogates"
        train_and_export(table, folder, name, settings, source=source, progress=epochs(name))
        files = {f"surrogates/{p.name}": p.read_bytes() for p in sorted(folder.glob(f"{name}.*"))}
    files[f"{name}.pth"] = files.pop(f"surrogates/{name}.pth")
    files[ilv_file(name)] = ilv_parquet(table, source)
    return files


def complete_entry(files: Mapping[str, bytes] | None, name: str) -> bool:
    """Whether a surrogate cache entry holds what a district needs: the weights, the dynamics block, the
    metrics and the training table (an entry from before the table was kept is rebuilt)."""
    needed = (f"{name}.pth", f"surrogates/{name}.dynamics.json", f"surrogates/{name}.metrics.json",
              ilv_file(name))
    return files is not None and all(n in files for n in needed) and parses(files, needed[1:3])


def parses(files: Mapping[str, bytes], names: tuple[str, ...]) -> bool:
    """Whether each of ``names`` in ``files`` is a JSON object (an entry whose checksums match a damaged file
    is a miss, rebuilt, never a failure of every later build)."""
    try:
        return all(isinstance(json.loads(files[n]), dict) for n in names)
    except (KeyError, ValueError):
        return False


def replay_off_record(files: Mapping[str, bytes], name: str) -> str | None:
    """Replay a cached model closed loop on the held-out test runs its metrics record, on the entry's own
    training table (:func:`surrogates.evaluate.replay_test_rmse`): None when it behaves as recorded, else why
    not (far above its recorded RMSE, :func:`surrogates.plausibility.replay_far_off`; or not replayable). The
    checksums of an entry say it was not damaged, the replay that its model is the one its metrics describe."""
    try:
        metrics = json.loads(files[f"surrogates/{name}.metrics.json"])
        claimed = float(metrics["test"]["closed_loop_rmse_c"])
        test = metrics["training"]["splits"]["test"]
        block = json.loads(files[f"surrogates/{name}.dynamics.json"])
        table = pd.read_parquet(io.BytesIO(files[ilv_file(name)]))
        with tempfile.TemporaryDirectory(prefix="districtgen_replay_") as folder:
            pth = Path(folder) / f"{name}.pth"
            pth.write_bytes(files[f"{name}.pth"])
            rmse, hours = replay_test_rmse(pth, block, table, test)
    except (KeyError, TypeError, ValueError, OSError, InputError) as error:
        return f"its model cannot be replayed on its held-out runs ({str(error).splitlines()[0][:200]})"
    if replay_far_off(rmse, claimed):
        return (f"its model replays at {rmse:.3g} degC closed-loop RMSE on its held-out runs ({hours} h), its "
                f"metrics claim {claimed:.3g} degC")
    return None


def surrogate_files(config: BuildConfig, bldg_id: int, name: str, table: pd.DataFrame | None = None,
                    weather: pd.Series | None = None) -> SurrogateFiles:
    """A building's surrogate files: the trained model from the surrogate cache (:mod:`pipeline.builder.cache`)
    when an intact entry of the same key exists, else trained (and stored); for a house with a stock row its
    judge's record under ``"judge"`` in the metrics, from the judgement cache or judged afresh
    (:func:`judgement`). The cache root: ``config.cache_dir``, else ``$DISTRICTGEN_CACHE_DIR``, else
    ``~/.cache/districtgen``; entries under ``surrogates/<key>/`` and ``judgements/<key>/``.
    ``table``: the ILV table when the caller has it (a simulated house, an FMU run)."""

    parts, table = surrogate_cache_parts(config, bldg_id, name, table, weather)
    key = cache_key(parts)
    cache = FileCache(cache_root(config.cache_dir) / "surrogates")
    files = cache.get(key, owns=surrogate_owns(name))
    hit = complete_entry(files, name)
    off = replay_off_record(files, name) if hit else None
    if off is not None:
        warnings.warn(f"surrogate cache entry {cache.folder / key} of {name}: {off}: retrained", RuntimeWarning,
                      stacklevel=2)
        hit = False
    if hit:
        report(name, "surrogate from the cache")
    else:
        if files is not None and off is None:
            warnings.warn(f"surrogate cache entry {cache.folder / key} of {name} does not parse: rebuilt",
                          RuntimeWarning, stacklevel=2)
        if table is None:
            report(name, "simulate ILV runs (EnergyPlus)")
            table = energyplus_ilv(config, bldg_id)
        settings = train_config(config)
        report(name, "train", 0, progress_units(settings))
        files = train_files(table, bldg_id, name, settings)
        cache.put(key, files, inputs=parts)
    row = judge_row(config, bldg_id)
    if row is None:
        return SurrogateFiles(files, key, hit)
    judged = judgement(config, name, files, row)
    return SurrogateFiles(with_judge(files, name, judged.record), key, hit, judged.key, judged.hit)


def cache_hits(surrogate: SurrogateFiles) -> dict[str, bool]:
    """What ``timings.json`` records of a surrogate's caches: ``hit`` (the trained model) and, for a judged
    house, ``judge_hit`` (the judge's record)."""
    hits = {"hit": surrogate.hit}
    if surrogate.judge_hit is not None:
        hits["judge_hit"] = surrogate.judge_hit
    return hits


def judgement(config: BuildConfig, name: str, files: Mapping[str, bytes], row: Mapping[str, object],
              ) -> Judgement:
    """The judge's record of a trained surrogate (``files``): from the judgement cache
    (``<cache root>/judgements/<key>/judge.json``, key :func:`judge_cache_parts`) when an intact entry exists,
    else judged (:func:`judge_model`) and stored. So a period that only changes the judged months reuses the
    trained model and runs only the judge."""
    parts = judge_cache_parts(config, row, files, name)
    key = cache_key(parts)
    cache = FileCache(cache_root(config.cache_dir) / "judgements")
    record = cached_record(cache.get(key, owns=lambda relative: relative == JUDGE_RECORD))
    if record is not None:
        report(name, "judge from the cache")
        return Judgement(record, key, True)
    report(name, "judge (fresh EnergyPlus run)")
    data = (json.dumps(judge_model(config, name, files, row), indent=2) + "\n").encode()
    cache.put(key, {JUDGE_RECORD: data}, inputs=parts)
    return Judgement(json.loads(data), key, False)  # read back: the same record as from the cache


def cached_record(files: Mapping[str, bytes] | None) -> dict | None:
    """The judge's record of a judgement cache entry, or None (no entry, or not a JSON object)."""
    try:
        record = json.loads(files[JUDGE_RECORD]) if files is not None else None
    except (KeyError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def judge_model(config: BuildConfig, name: str, files: Mapping[str, bytes], row: Mapping[str, object],
                ) -> dict:
    """The judge's record (:func:`surrogates.judge.judge_surrogate`: a fresh EnergyPlus run of the house,
    other seed and timestep count than the training data, over the period's months) of a trained surrogate's
    ``<name>.pth`` with its dynamics block."""
    with tempfile.TemporaryDirectory(prefix="districtgen_judge_") as scratch:
        pth = Path(scratch) / f"{name}.pth"
        pth.write_bytes(files[f"{name}.pth"])
        block = json.loads(files[f"surrogates/{name}.dynamics.json"])
        return judge_surrogate(pth, row, Path(config.inputs.weather), judge_training_config(config),
                               judge_config(config), dynamics=block, source=f"building {name}")


def with_judge(files: Mapping[str, bytes], name: str, record: Mapping[str, object]) -> dict[str, bytes]:
    """``files`` with the judge's ``record`` under ``"judge"`` in ``surrogates/<name>.metrics.json``."""
    metrics_name = f"surrogates/{name}.metrics.json"
    metrics = json.loads(files[metrics_name])
    metrics["judge"] = dict(record)
    return {**files, metrics_name: (json.dumps(metrics, indent=2) + "\n").encode()}


def surrogate_errors(files: Mapping[str, Mapping[str, bytes]]) -> dict[str, dict]:
    """Building name -> the judge's record in its metrics (buildings without a judge left out)."""
    out = {}
    for name, entry in files.items():
        metrics = json.loads(entry.get(f"surrogates/{name}.metrics.json", b"{}"))
        if "judge" in metrics:
            out[name] = metrics["judge"]
    return out


def check_surrogate_errors(judged: Mapping[str, Mapping], strict: bool = False, stream=None) -> None:
    """One warning line per house whose surrogate misses the bound (monthly RMSE median 0.25 / worst month
    0.5 degC against the judge); with ``strict`` the first such house is one :class:`InputError` instead."""
    for name, record in judged.items():
        miss = verdict(record, record.get("median_bound_c", 0.25), record.get("worst_bound_c", 0.5))
        if miss is None:
            continue
        ilv = record.get("judge_ilv", {})
        line = (f"{name}: surrogate misses the bound against a fresh EnergyPlus run "
                f"({ilv.get('timesteps_per_hour')} timesteps/h, seed {ilv.get('seed')}): {miss}")
        if strict:
            raise InputError(f"{line} (--strict)", column="surrogate")
        out = stream or sys.stderr
        # written, not print()ed: inside the build flow (log_prints) a print would become an INFO record of
        # the run logger, which `make run` (PREFECT_LOGGING_LEVEL=WARNING) drops
        out.write(f"districtgen: warning: {line}\n")
        out.flush()


def surrogate_error_summary(record: Mapping) -> dict:
    """The schema's short form of a judge record [degC]: monthly RMSE median and worst month, mean absolute
    errors, the bounds, whether it passes and the judge's timestep count and seed."""
    ilv = record.get("judge_ilv", {})
    return {"judge": "fresh EnergyPlus run of the house (surrogates.judge)",
            "monthly_rmse_median_c": record["median_c"], "monthly_rmse_worst_c": record["worst_c"],
            "mean_abs_error_c": record.get("mean_abs_c"), "ideal_loads_mean_abs_error_c": record.get("ideal_mean_abs_c"),
            "median_bound_c": record.get("median_bound_c"), "worst_bound_c": record.get("worst_bound_c"),
            "passes": record.get("passes"), "timesteps_per_hour": ilv.get("timesteps_per_hour"),
            "seed": ilv.get("seed")}


def annotate_schema(schema: dict, judged: Mapping[str, Mapping]) -> dict:
    """Put each judged building's :func:`surrogate_error_summary` into its schema ``dynamics`` entry, key
    ``surrogate_error`` beside ``type``/``attributes`` (both v2.1 blocks): loaders read only those two."""
    for name, record in judged.items():
        entry = schema["buildings"][name].get("dynamics")
        if not entry:
            continue
        for block in ([entry] if "type" in entry or "attributes" in entry else list(entry.values())):
            block["surrogate_error"] = surrogate_error_summary(record)
    return schema


def write_surrogate_files(out: Path, files: Mapping[str, bytes]) -> dict:
    """Write a building's surrogate files into the district folder; return its ``dynamics`` block."""
    dynamics_name = next(r for r in files if r.endswith(".dynamics.json"))
    pth = next(r for r in files if r.endswith(".pth"))
    block = json.loads(files[dynamics_name])
    block["attributes"]["filename"] = pth
    for relative, data in files.items():
        path = out / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        write_same_file(path, json.dumps(block, indent=2) if relative == dynamics_name else data)
    return block


def surrogate_owns(name: str) -> Callable[[str], bool]:
    """Which files a surrogate cache entry of building ``name`` may hold: ``<name>.pth`` and
    ``surrogates/<name>.<kind>.json`` / ``.png`` / ``.ilv.parquet``, never a district data file."""
    pattern = re.compile(rf"{re.escape(name)}\.pth|"
                         rf"surrogates/{re.escape(name)}(\.[a-z_]+\.json|\.png|\.ilv\.parquet)")
    return lambda relative: pattern.fullmatch(relative) is not None
