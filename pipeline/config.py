"""The district build configuration: one TOML file, validated once into frozen pydantic models.

Relative paths resolve against the configuration file's folder. Errors name the file, the key path and the
expected form (:class:`pipeline.errors.InputError`).
"""

from __future__ import annotations

import re
import tomllib
import zoneinfo
from datetime import date
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

import surrogates.config as trainer  # torch-free: the build's recipe and the trainer's names
from citylearn_env.sizing import BATTERIES, SizingRules
from pipeline.errors import InputError
from surrogates.precision import PRECISIONS

#: a district name: it becomes the folder ``<output root>/<name>``, so no separators, no hidden or dot names
NAME_PATTERN = r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}"
#: seeds are below 2**32: numpy's legacy RandomState and CityLearn's random_seed take 32 bits
SEED_LIMIT = 2**32


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)  # inf/nan: never a value


class Inputs(_Frozen):
    eulp: str | None = Field(None, description="EULP release folder (OEDI layout) or http(s) base URL: the "
                                               "building loads come from its timeseries")
    characteristics: Path | None = Field(
        None, description="stock metadata file (EULP or buildstockbatch layout): the houses are simulated with "
                          "the project's EnergyPlus house model on the district's weather")
    buildings: list[int] | None = Field(None, min_length=1, description="bldg_id values, in district order "
                                                                         "(or chosen by [selection])")
    upgrade: int = 0
    state: str | None = None
    weather: Path
    tariff: Path
    fuel_mix: Path
    ilv: Path | None = Field(None, description="folder of precomputed ILV tables <bldg_id>.parquet/.csv")
    holidays: list[date] = []


class Selection(_Frozen):
    """Stock selection (pipeline.select): filters, then ``houses`` buildings: one per k-means cluster up to the
    filtered rows, beyond them every row and seeded repeats (each with its own occupant schedules)."""

    metadata: Path | None = Field(None, description="stock metadata file (default: inputs.characteristics)")
    filters: dict[str, str | list[str]] = Field(default_factory=dict,
                                                description="characteristic (no prefix) -> allowed value(s)")
    houses: int | Literal["auto"] = Field("auto", description="number of houses, or auto (k by the cluster-"
                                                              "validity indices); more than the filtered rows: "
                                                              "every row and seeded repeats")
    clusters: int | Literal["auto"] = Field("auto", description="the former name of houses (same meaning)")
    max_clusters: int | None = Field(None, ge=2)
    method: Literal["medoid", "draw"] = "medoid"
    seed: int = Field(0, ge=0, lt=SEED_LIMIT)

    @model_validator(mode="before")
    @classmethod
    def _one_count(cls, data):
        """``houses`` and ``clusters`` are one setting: either fills the other; both must agree."""
        if not isinstance(data, dict):
            return data
        given = {k: data[k] for k in ("houses", "clusters") if k in data}
        if len(given) == 2 and given["houses"] != given["clusters"]:
            raise ValueError(f"houses = {given['houses']!r} and clusters = {given['clusters']!r}: clusters is "
                             "the former name of houses, give one")
        if given:
            value = next(iter(given.values()))
            data = {**data, "houses": value, "clusters": value}
        return data

    @field_validator("houses", "clusters", mode="before")
    @classmethod
    def _whole_positive(cls, value):
        if value == "auto":
            return value
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError("houses must be a whole number >= 1 or 'auto'")
        return value


class Simulation(_Frozen):
    """EnergyPlus houses (inputs.characteristics): the one pass (the months the district needs) that gives loads
    and ILV data."""

    partial_runs: int = Field(4, ge=0, description="partial-load ILV runs besides the ideal replay (at least; "
                                                  "see month_runs)")
    month_runs: int = Field(12, ge=0, description="more partial-load runs where the simulated months are few: "
                                                 "at least this many (run, month) pairs, so a June house runs "
                                                 "12 (a surrogate trained on one month learns from 10 runs of "
                                                 "it), a year partial_runs")
    free_float: bool = Field(False, description="also simulate the free-float run (reference 1, no HVAC) into the "
                                                "ILV table, for retraining with use_free_float; the build's "
                                                "recipe does not train on it (one more EnergyPlus run per house)")
    seed: int = Field(2018, ge=0, lt=SEED_LIMIT,
                      description="seed of the partial-load multipliers (combined with the bldg_id)")
    schedule_seed: int = Field(0, ge=0, lt=SEED_LIMIT,
                               description="seed of the occupant schedules (combined with the bldg_id); the "
                                           "r-th repeat of a stock row in the district draws with this + r")
    timesteps_per_hour: int = Field(6, ge=1, le=60, description="EnergyPlus zone timesteps per hour (tables "
                                    "stay hourly); 6: at 1 the hourly zone solution is 0.3-0.5 degC off the "
                                    "physics, at 4 still 0.1-0.14 degC (RMSE against 20)")
    fuel_heating: Literal["heat_pump", "electric_heater"] = Field(
        "heat_pump", description="device for houses heated with a fuel (gas, oil, propane): electrified as")


class Period(_Frozen):
    start: date
    end: date

    @model_validator(mode="after")
    def _ordered(self):
        if self.end < self.start:
            raise ValueError("end must not be before start")
        return self


class PV(_Frozen):
    tilt: float | None = Field(None, ge=0, le=90, description="degrees; default: the site latitude")
    azimuth: float = Field(180.0, ge=0, lt=360)


#: the sizing defaults: :class:`citylearn_env.sizing.SizingRules`' (the paper's), the one place they are set
_RULES = SizingRules()


class Sizing(_Frozen):
    """The ``[sizing]`` keys: the :class:`SizingRules` a district may change, defaulting to its values."""

    heat_pump_efficiency: float = Field(_RULES.heat_pump_efficiency, gt=0, le=1)
    target_cooling_temperature: float = _RULES.target_cooling_temperature
    target_heating_temperature: float = _RULES.target_heating_temperature
    electric_heater_efficiency: float = Field(_RULES.electric_heater_efficiency, gt=0, le=1)
    dhw_heater_efficiency: float = Field(_RULES.dhw_heater_efficiency, gt=0, le=1)
    dhw_tank_fraction: float = Field(_RULES.dhw_tank_fraction, ge=0)
    battery: str = _RULES.battery
    pv_zne_fraction: float = Field(_RULES.pv_zne_fraction, ge=0, le=10,
                                   description="PV yield / consumption over the period")

    @field_validator("battery")
    @classmethod
    def _known_battery(cls, value: str) -> str:
        if value not in BATTERIES:
            raise ValueError(f"unknown battery {value!r}; known: {', '.join(BATTERIES)}")
        return value

    def rules(self) -> SizingRules:
        return SizingRules(**self.model_dump())


def _recipe(key: str):
    """A default factory: ``key`` of :data:`surrogates.config.BUILD_RECIPE` when a configuration is read."""
    return lambda: getattr(trainer.BUILD_RECIPE, key)


#: the ``[surrogate]`` keys that are training settings (:class:`surrogates.config.TrainConfig` fields of the
#: same names): each defaults to the build's recipe, and :func:`pipeline.builder.surrogates.train_config`
#: puts them over it
RECIPE_KEYS = ("hidden_size", "num_layers", "epochs", "pretrain_steps", "long_chunk_epochs", "max_seconds", "seed",
               "precision", "start")


class Surrogate(_Frozen):
    """The ``[surrogate]`` section: where the ILV data comes from, and the training settings of
    :data:`RECIPE_KEYS`, whose defaults are :data:`surrogates.config.BUILD_RECIPE`'s."""

    source: Literal["csv", "energyplus", "fmu", "none"] = Field(
        "csv", description="ILV data: precomputed tables, EnergyPlus runs, an FMU, or none (no LSTM)")
    fmu: Path | None = Field(None, description="FMI 2.0 co-simulation FMU of a building (source fmu)")
    fmu_variables: dict[str, str] = Field(default_factory=dict, description="our name -> FMU variable name")
    fmu_start_values: dict[str, float] = Field(default_factory=dict)
    hidden_size: int = Field(default_factory=_recipe("hidden_size"), ge=1, le=1024)
    num_layers: int = Field(default_factory=_recipe("num_layers"), ge=1, le=8)
    epochs: int = Field(default_factory=_recipe("epochs"), ge=1, le=10_000,
                        description="closed-loop epochs; the last long_chunk_epochs on 168-h chunks")
    pretrain_steps: int = Field(default_factory=_recipe("pretrain_steps"), ge=0, le=1_000_000,
                                description="teacher-forced warm-start updates")
    long_chunk_epochs: int = Field(default_factory=_recipe("long_chunk_epochs"), ge=0, le=10_000,
                                   description="last closed-loop epochs on 168-h chunks")
    season_margin: int = Field(0, ge=0, le=6, description="train on the period's calendar months and this many "
                                                          "months either side (6: every month)")
    max_seconds: float | None = Field(default_factory=_recipe("max_seconds"), gt=0,
                                      description="optional wall-clock cap (makes training machine-dependent)")
    seed: int = Field(default_factory=_recipe("seed"), ge=0, lt=SEED_LIMIT)
    precision: Literal[PRECISIONS] = Field(
        default_factory=_recipe("precision"),
        description="numeric mode of the updates: auto = bfloat16 only where the CPU multiplies it natively and it "
                    "measures faster (the mode that ran is in timings.json)")
    start: Literal[trainer.STARTS] = Field(
        default_factory=_recipe("start"),
        description="the weights each house's training begins from: generic = the model trained once on many "
                    "houses (surrogates/generic.py), random = seeded random weights")
    strict: bool = Field(False, description="refuse the build when a house's surrogate misses the bound against "
                                            "the judge (monthly RMSE median 0.25 / worst month 0.5 degC); else warn")


class BuildConfig(_Frozen):
    name: str = Field(description="the district's folder name: a safe slug, see NAME_PATTERN")
    period: Period
    inputs: Inputs
    pv: PV = PV()
    sizing: Sizing = Sizing()
    surrogate: Surrogate = Field(default_factory=Surrogate)  # made when read: its defaults are the recipe's
    selection: Selection | None = None
    simulation: Simulation = Simulation()
    layout: Literal["v2.1", "v2.2"] = "v2.2"
    forecast: Literal["perfect", "noisy"] = "perfect"
    seed: int = Field(0, ge=0, lt=SEED_LIMIT)
    timezone: str = Field("America/Chicago", description="IANA zone of the district: the tables' "
                          "daylight_savings_status and the households' clock (their schedules and thermostat "
                          "offsets come an hour earlier in standard time while it shows daylight time)")
    cache_dir: Path | None = Field(None, description="surrogate cache root (default: $DISTRICTGEN_CACHE_DIR, "
                                                     "else ~/.cache/districtgen); relative to the file")
    source: Path = Path("<dict>")

    @field_validator("name")
    @classmethod
    def _safe_slug(cls, value: str) -> str:
        if not re.fullmatch(NAME_PATTERN, value):
            raise ValueError("name must be 1-64 letters, digits, '_', '-' or '.', starting with a letter or digit "
                             "(it becomes a folder name: no '.', '..', '/' or hidden names)")
        return value

    @field_validator("timezone")
    @classmethod
    def _known_timezone(cls, value: str) -> str:
        try:
            zoneinfo.ZoneInfo(value)
        except (zoneinfo.ZoneInfoNotFoundError, ValueError, OSError):
            raise ValueError(f"unknown time zone {value!r} (an IANA name such as 'America/Chicago')") from None
        return value

    @model_validator(mode="after")
    def _one_building_source(self):
        i = self.inputs
        if (i.eulp is None) == (i.characteristics is None):
            raise ValueError("give exactly one of inputs.eulp (EULP timeseries) and inputs.characteristics "
                             "(houses simulated in EnergyPlus)")
        if i.buildings is None and self.selection is None:
            raise ValueError("give inputs.buildings or a [selection] section")
        if self.selection is not None and self.selection.metadata is None and i.characteristics is None:
            raise ValueError("selection.metadata is needed when inputs.characteristics is not given")
        if self.surrogate.source == "fmu" and (self.surrogate.fmu is None or not self.surrogate.fmu_variables):
            raise ValueError("surrogate.source = 'fmu' needs surrogate.fmu and surrogate.fmu_variables")
        return self


def parse_build_config(data: dict, *, file: object = "<config>", base: Path | None = None) -> BuildConfig:
    """Validate a configuration mapping; relative input paths resolve against ``base``."""
    try:
        config = BuildConfig(**data, source=Path(str(file)))
    except ValidationError as error:
        first = error.errors()[0]
        key = ".".join(str(p) for p in first["loc"])
        got = repr(first.get("input"))
        got = got if len(got) <= 80 else got[:77] + "..."
        raise InputError(f"{first['msg']} (got {got})", file=file, column=key) from None
    except TypeError as error:
        raise InputError(f"invalid configuration: {error}", file=file) from None
    if base is None:
        return config
    inputs = config.inputs
    resolved: dict[str, object] = {k: (base / getattr(inputs, k)) for k in ("weather", "tariff", "fuel_mix")}
    for key in ("ilv", "characteristics"):
        if getattr(inputs, key) is not None:
            resolved[key] = base / getattr(inputs, key)
    if inputs.eulp is not None and not inputs.eulp.startswith(("http://", "https://")):
        resolved["eulp"] = str(base / inputs.eulp)
    update: dict[str, object] = {"inputs": inputs.model_copy(update=resolved)}
    if config.cache_dir is not None:
        update["cache_dir"] = base / config.cache_dir.expanduser()
    if config.selection is not None and config.selection.metadata is not None:
        update["selection"] = config.selection.model_copy(update={"metadata": base / config.selection.metadata})
    if config.surrogate.fmu is not None:
        update["surrogate"] = config.surrogate.model_copy(update={"fmu": base / config.surrogate.fmu})
    return config.model_copy(update=update)


def read_build_config(path: str | Path) -> BuildConfig:
    """Read and validate a district TOML file."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError("configuration file not found", file=path) from None
    except (OSError, UnicodeDecodeError) as error:  # a folder, unreadable, not text
        raise InputError(f"cannot read the configuration: {getattr(error, 'strerror', None) or error}",
                         file=path) from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"not valid TOML: {error}", file=path) from None
    return parse_build_config(data, file=path, base=path.resolve().parent)
