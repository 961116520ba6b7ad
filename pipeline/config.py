"""The district build configuration: one TOML file, validated once into frozen pydantic models.

Relative paths resolve against the configuration file's folder. Errors name the file, the key path and the
expected form (:class:`pipeline.errors.InputError`).
"""

from __future__ import annotations

import tomllib
from datetime import date
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from pipeline.errors import InputError
from pipeline.sizing import BATTERIES, SizingRules


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Inputs(_Frozen):
    eulp: str = Field(description="EULP release folder (OEDI layout) or http(s) base URL")
    buildings: list[int] = Field(min_length=1, description="bldg_id values, in district order")
    upgrade: int = 0
    state: str | None = None
    weather: Path
    tariff: Path
    fuel_mix: Path
    ilv: Path | None = Field(None, description="folder of precomputed ILV tables <bldg_id>.parquet/.csv")
    holidays: list[date] = []


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


class Sizing(_Frozen):
    heat_pump_efficiency: float = Field(0.25, gt=0, le=1)
    target_cooling_temperature: float = 8.0
    dhw_heater_efficiency: float = Field(0.9, gt=0, le=1)
    dhw_tank_fraction: float = Field(0.5, ge=0)
    battery: str = "BYD LVS"
    pv_zne_fraction: float = Field(0.215, ge=0)

    @field_validator("battery")
    @classmethod
    def _known_battery(cls, value: str) -> str:
        if value not in BATTERIES:
            raise ValueError(f"unknown battery {value!r}; known: {', '.join(BATTERIES)}")
        return value

    def rules(self) -> SizingRules:
        return SizingRules(**self.model_dump())


class Surrogate(_Frozen):
    source: Literal["csv", "energyplus", "none"] = Field(
        "csv", description="ILV data: precomputed tables, EnergyPlus runs, or none (no LSTM: plain buildings)")
    hidden_size: int = Field(16, ge=1)
    num_layers: int = Field(2, ge=1)
    lookback: int = Field(12, ge=1)
    epochs: int = Field(40, ge=1)
    max_seconds: float | None = Field(None, gt=0, description="optional wall-clock cap (makes training machine-dependent)")
    seed: int = 0


class BuildConfig(_Frozen):
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    period: Period
    inputs: Inputs
    pv: PV = PV()
    sizing: Sizing = Sizing()
    surrogate: Surrogate = Surrogate()
    layout: Literal["v2.1", "v2.2"] = "v2.2"
    forecast: Literal["perfect", "noisy"] = "perfect"
    seed: int = 0
    timezone: str = "America/Chicago"
    cache_dir: Path | None = Field(None, description="surrogate cache root (default: $DISTRICTGEN_CACHE_DIR, "
                                                     "else ~/.cache/districtgen); relative to the file")
    source: Path = Path("<dict>")


def parse_build_config(data: dict, *, file: object = "<config>", base: Path | None = None) -> BuildConfig:
    """Validate a configuration mapping; relative input paths resolve against ``base``."""
    try:
        config = BuildConfig(**data, source=Path(str(file)))
    except ValidationError as error:
        first = error.errors()[0]
        key = ".".join(str(p) for p in first["loc"])
        raise InputError(f"{first['msg']} (got {first.get('input')!r})", file=file, column=key) from None
    except TypeError as error:
        raise InputError(f"invalid configuration: {error}", file=file) from None
    if base is None:
        return config
    inputs = config.inputs
    resolved = {k: (base / getattr(inputs, k)) for k in ("weather", "tariff", "fuel_mix")}
    if inputs.ilv is not None:
        resolved["ilv"] = base / inputs.ilv
    eulp = inputs.eulp if inputs.eulp.startswith(("http://", "https://")) else str(base / inputs.eulp)
    update: dict[str, object] = {"inputs": inputs.model_copy(update={**resolved, "eulp": eulp})}
    if config.cache_dir is not None:
        update["cache_dir"] = base / config.cache_dir.expanduser()
    return config.model_copy(update=update)


def read_build_config(path: str | Path) -> BuildConfig:
    """Read and validate a district TOML file."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError("configuration file not found", file=path) from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"not valid TOML: {error}", file=path) from None
    return parse_build_config(data, file=path, base=path.resolve().parent)
