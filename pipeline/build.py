"""The district build steps as plain functions: ingest -> sizing -> surrogates -> emit -> validate.

:mod:`pipeline.flows` runs these as a Prefect flow (one task per building for the per-building work);
:func:`build_district_local` runs them in-process without Prefect (tests, quick runs). A build is written
into a temporary sibling folder and renamed into place only when complete and validated.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shutil
import time
from importlib import metadata as importlib_metadata
from pathlib import Path

import numpy as np

from pipeline.config import BuildConfig
from pipeline.errors import InputError

OBSERVATIONS_SHARED = ("month", "day_type", "hour", "outdoor_dry_bulb_temperature",
                       "outdoor_dry_bulb_temperature_predicted_6h", "diffuse_solar_irradiance",
                       "direct_solar_irradiance", "carbon_intensity", "electricity_pricing",
                       "electricity_pricing_predicted_6h")
OBSERVATIONS_BUILDING = ("indoor_dry_bulb_temperature", "non_shiftable_load", "solar_generation",
                         "dhw_storage_soc", "electrical_storage_soc", "net_electricity_consumption",
                         "cooling_demand", "dhw_demand", "occupant_count", "indoor_dry_bulb_temperature_set_point",
                         "indoor_dry_bulb_temperature_delta", "power_outage")


def building_names(config: BuildConfig) -> list[str]:
    return [f"Building_{i}" for i in range(1, len(config.inputs.buildings) + 1)]


# ---------------------------------------------------------------------------------------------- ingest
def ingest_signals(config: BuildConfig, out: Path) -> None:
    """weather.csv, pricing.csv and carbon_intensity.csv for the period."""
    from pipeline.ingest.commands import write_carbon, write_pricing, write_weather

    p, i = config.period, config.inputs
    write_weather(i.weather, p.start, p.end, out / "weather.csv", layout=config.layout, forecast=config.forecast,
                  seed=config.seed)
    write_pricing(i.tariff, p.start, p.end, out / "pricing.csv", layout=config.layout)
    write_carbon(i.fuel_mix, p.start, p.end, out / "carbon_intensity.csv", layout=config.layout,
                 timezone=config.timezone)


def ingest_building(config: BuildConfig, bldg_id: int, name: str, out: Path) -> Path:
    """One building CSV from the EULP source (with the PV yield of the weather file)."""
    from pipeline.ingest.commands import write_building

    p, i = config.period, config.inputs
    return write_building(i.eulp, bldg_id, p.start, p.end, out / f"{name}.csv", layout=config.layout,
                          upgrade=i.upgrade, state=i.state, weather=i.weather, tilt=config.pv.tilt,
                          azimuth=config.pv.azimuth, holidays=[d.isoformat() for d in i.holidays])


def read_building(path: Path, hours: int):
    """The written building CSV back as a DataFrame of internal column names (validated like the env does)."""
    import pandas as pd

    from citylearn_env.schema import _read_csv, parse_data_frame

    return pd.DataFrame(parse_data_frame(_read_csv(path), "building", path, hours))


# ---------------------------------------------------------------------------------------------- sizing
def size_buildings(config: BuildConfig, out: Path, names: list[str]) -> dict[str, dict]:
    from citylearn_env.schema import _read_csv, parse_data_frame
    from pipeline.sizing import size_building

    hours = _hours(config)
    weather = parse_data_frame(_read_csv(out / "weather.csv"), "weather", out / "weather.csv", hours)
    rules = config.sizing.rules()
    return {n: size_building(read_building(out / f"{n}.csv", hours), weather["outdoor_dry_bulb_temperature"],
                             rules) for n in names}


# ---------------------------------------------------------------------------------------------- surrogates
def ilv_table(config: BuildConfig, bldg_id: int, out: Path):
    """The building's ideal-load-variation table: precomputed (csv/parquet) or simulated with EnergyPlus."""
    from surrogates.ilv import read_ilv

    if config.surrogate.source == "energyplus":
        from pipeline.ingest.eulp import locate_building, read_eulp_metadata
        from surrogates.sources.energyplus import build_ilv_table

        metadata_path, _ = locate_building(config.inputs.eulp, bldg_id, upgrade=config.inputs.upgrade,
                                           state=config.inputs.state)
        row = read_eulp_metadata(metadata_path).loc[bldg_id].to_dict()
        path = build_ilv_table(row, config.inputs.weather, out / "surrogates" / f"{bldg_id}_ilv.parquet")
        return read_ilv(path)
    if config.inputs.ilv is None:
        raise InputError("surrogate.source = 'csv' needs inputs.ilv (a folder of <bldg_id>.parquet/.csv)",
                         file=config.source, column="inputs.ilv")
    for suffix in (".parquet", ".csv"):
        path = config.inputs.ilv / f"{bldg_id}{suffix}"
        if path.exists():
            return read_ilv(path)
    raise InputError(f"no ILV table for building {bldg_id}", file=config.inputs.ilv, column="inputs.ilv")


def train_building(config: BuildConfig, bldg_id: int, name: str, out: Path) -> dict:
    """Train, evaluate and export one building's LSTM into ``out``; return the schema ``dynamics`` block."""
    return write_surrogate_files(out, train_building_files(config, bldg_id, name, surrogate_input_digest(config,
                                                                                                      bldg_id)))


def surrogate_input_digest(config: BuildConfig, bldg_id: int) -> str:
    """sha256 of what a building's surrogate is trained from (its ILV table, or the EPW for EnergyPlus):
    part of the training task's cache key, so a changed input file retrains."""
    if config.surrogate.source == "energyplus" or config.inputs.ilv is None:
        return _sha256(Path(config.inputs.weather))
    for suffix in (".parquet", ".csv"):
        path = config.inputs.ilv / f"{bldg_id}{suffix}"
        if path.exists():
            return _sha256(path)
    return "missing"


def train_building_files(config: BuildConfig, bldg_id: int, name: str, input_digest: str) -> dict[str, bytes]:
    """Train, evaluate and export in a scratch folder; return the files (relative path -> bytes).

    ``<name>.pth`` goes next to the schema, ``surrogates/<name>.{dynamics,metrics}.json`` and ``.png`` into
    ``surrogates/``. A pure function of its arguments (``input_digest`` keys the Prefect cache).
    """
    import tempfile

    from surrogates.export import train_and_export
    from surrogates.train import TrainConfig

    s = config.surrogate
    train_config = TrainConfig(hidden_size=s.hidden_size, num_layers=s.num_layers, lookback=s.lookback,
                               epochs=s.epochs, seed=s.seed, max_seconds=s.max_seconds, progress=False, threads=1)
    with tempfile.TemporaryDirectory(prefix="districtgen_surrogate_") as scratch:
        scratch = Path(scratch)
        table = ilv_table(config, bldg_id, scratch)
        train_and_export(table, scratch / "surrogates", name, train_config,
                         source=f"ILV table of building {bldg_id}")
        files = {str(p.relative_to(scratch)): p.read_bytes()
                 for p in sorted((scratch / "surrogates").glob(f"{name}.*"))}
    files[f"{name}.pth"] = files.pop(f"surrogates/{name}.pth")
    return files


def write_surrogate_files(out: Path, files: dict[str, bytes]) -> dict:
    """Write a building's surrogate files into the district folder; return its ``dynamics`` block."""
    block = None
    for relative, data in files.items():
        path = out / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        if relative.endswith(".dynamics.json"):
            block = json.loads(data)
    pth = next(r for r in files if r.endswith(".pth"))
    block["attributes"]["filename"] = pth
    (out / next(r for r in files if r.endswith(".dynamics.json"))).write_text(json.dumps(block, indent=2))
    return block


# ---------------------------------------------------------------------------------------------- emit
def schema_dict(config: BuildConfig, names: list[str], sizes: dict[str, dict],
                dynamics: dict[str, dict] | None) -> dict:
    """The CityLearn schema of the district (file names relative to the schema's folder)."""
    observations = {n: {"active": True, "shared_in_central_agent": n in OBSERVATIONS_SHARED}
                    for n in (*OBSERVATIONS_SHARED[:3], *OBSERVATIONS_SHARED[3:], *OBSERVATIONS_BUILDING)}
    buildings = {}
    for name in names:
        devices = sizes[name]
        spec = {
            "type": "citylearn.building.LSTMDynamicsBuilding" if dynamics else "citylearn.building.Building",
            "include": True, "energy_simulation": f"{name}.csv", "weather": "weather.csv",
            "pricing": "pricing.csv", "carbon_intensity": "carbon_intensity.csv",
            "inactive_observations": [], "inactive_actions": [],
            "cooling_device": {"type": "citylearn.energy_model.HeatPump", "autosize": False,
                               "attributes": devices["cooling_device"]},
            "dhw_device": {"type": "citylearn.energy_model.ElectricHeater", "autosize": False,
                           "attributes": devices["dhw_device"]},
            "dhw_storage": {"type": "citylearn.energy_model.StorageTank", "autosize": False,
                            "attributes": devices["dhw_storage"]},
            "electrical_storage": {"type": "citylearn.energy_model.Battery", "autosize": False,
                                   "attributes": devices["electrical_storage"]},
            "pv": {"type": "citylearn.energy_model.PV", "autosize": False, "attributes": devices["pv"]},
            "power_outage": {"simulate_power_outage": False, "stochastic_power_outage": False},
        }
        if dynamics:  # v2.1 wants a {cooling, heating} pair; one model serves both modes here
            block = dynamics[name]
            spec["dynamics"] = {"cooling": block, "heating": block} if config.layout == "v2.1" else block
        buildings[name] = spec
    return {
        "root_directory": None, "central_agent": True,
        "simulation_start_time_step": 0, "simulation_end_time_step": _hours(config) - 1,
        "episode_time_steps": None, "rolling_episode_split": False, "random_episode_split": False,
        "seconds_per_time_step": 3600.0, "random_seed": config.seed,
        "observations": observations,
        "actions": {"cooling_storage": {"active": False}, "heating_storage": {"active": False},
                    "dhw_storage": {"active": True}, "electrical_storage": {"active": True},
                    "cooling_device": {"active": bool(dynamics)}, "heating_device": {"active": False}},
        "reward_function": {"type": "citylearn.reward_function.RewardFunction", "attributes": {}},
        "buildings": buildings,
    }


def write_manifest(out: Path, config: BuildConfig, timings: dict[str, float]) -> Path:
    files = {}
    for path in sorted(p for p in out.rglob("*") if p.is_file() and p.name != "manifest.json"):
        files[str(path.relative_to(out))] = {"sha256": _sha256(path), "bytes": path.stat().st_size}
    inputs = {}
    for key in ("weather", "tariff", "fuel_mix"):
        path = Path(getattr(config.inputs, key))
        inputs[key] = {"path": str(path), "sha256": _sha256(path)}
    versions = {}
    for dist in ("districtgen", "numpy", "pandas", "torch", "gymnasium", "prefect", "pvlib"):
        try:
            versions[dist] = importlib_metadata.version(dist)
        except importlib_metadata.PackageNotFoundError:
            versions[dist] = None
    manifest = {"district": config.name, "config": json.loads(config.model_dump_json()), "inputs": inputs,
                "outputs": files, "versions": versions, "python": platform.python_version(),
                "seeds": {"build": config.seed, "surrogate": config.surrogate.seed}, "timings_s": timings}
    path = out / "manifest.json"
    path.write_text(json.dumps(manifest, indent=2, default=str))
    return path


def verify_district(folder: str | Path) -> list[str]:
    """Re-check every output hash of ``manifest.json``; return the problems (empty = intact)."""
    folder = Path(folder)
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except FileNotFoundError:
        raise InputError("no manifest.json: not a districtgen build", file=folder) from None
    problems = []
    for name, entry in manifest["outputs"].items():
        path = folder / name
        if not path.exists():
            problems.append(f"{name}: missing")
        elif _sha256(path) != entry["sha256"]:
            problems.append(f"{name}: sha256 differs from the manifest")
    return problems


# ---------------------------------------------------------------------------------------------- validate
def validate_district(schema_path: Path, report_dir: Path, name: str | None = None) -> dict:
    """Load the schema in the environment, run no control and the cost RBC; write KPI tables and the report."""
    from pipeline.controllers import run_policy
    from pipeline.report import write_report

    report_dir.mkdir(parents=True, exist_ok=True)
    results = {}
    for policy in ("no_control", "cost_rbc"):
        env = run_policy(schema_path, policy)
        kpis = env.evaluate()
        kpis.to_csv(report_dir / f"kpis_{policy}.csv", index=False)
        results[policy] = {"objectives": {k: v for k, v in env.objectives().items() if np.isscalar(v)},
                           "kpis": kpis, "net": env.series()["net_electricity_consumption"].sum(axis=0)}
    schema = json.loads(schema_path.read_text())
    write_report(report_dir, name or schema_path.parent.name, schema, results, schema_path.parent / "surrogates")
    return results


# ---------------------------------------------------------------------------------------------- driver
def build_district_local(config: BuildConfig, output_root: str | Path = "artifacts") -> Path:
    """Run the whole build in-process (no Prefect) and move the result into ``output_root/<name>``."""
    names = building_names(config)
    with staging(config, output_root) as out:
        timings = {}
        started = time.perf_counter()
        ingest_signals(config, out)
        for bldg_id, name in zip(config.inputs.buildings, names, strict=True):
            ingest_building(config, bldg_id, name, out)
        timings["ingest"] = time.perf_counter() - started
        sizes = size_buildings(config, out, names)
        started = time.perf_counter()
        dynamics = None
        if config.surrogate.source != "none":
            dynamics = {name: train_building(config, bldg_id, name, out)
                        for bldg_id, name in zip(config.inputs.buildings, names, strict=True)}
        timings["surrogates"] = time.perf_counter() - started
        finish(config, out, names, sizes, dynamics, timings)
    return Path(output_root) / config.name


def finish(config: BuildConfig, out: Path, names, sizes, dynamics, timings: dict) -> None:
    """Write the schema, validate it in the environment, write the manifest."""
    schema_path = out / "schema.json"
    schema_path.write_text(json.dumps(schema_dict(config, names, sizes, dynamics), indent=2))
    started = time.perf_counter()
    validate_district(schema_path, out / "report", config.name)
    timings["validate"] = time.perf_counter() - started
    write_manifest(out, config, timings)


class staging:
    """Context manager: a temporary sibling folder that replaces ``root/name`` only on success."""

    def __init__(self, config: BuildConfig, root: str | Path):
        self.final = Path(root) / config.name
        self.tmp = Path(root) / f".{config.name}.building-{os.getpid()}"

    def __enter__(self) -> Path:
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.tmp.mkdir(parents=True)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return
        old = self.final.with_name(f".{self.final.name}.old-{os.getpid()}")
        if self.final.exists():
            self.final.rename(old)
        self.tmp.rename(self.final)
        shutil.rmtree(old, ignore_errors=True)


def _hours(config: BuildConfig) -> int:
    return ((config.period.end - config.period.start).days + 1) * 24


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()
