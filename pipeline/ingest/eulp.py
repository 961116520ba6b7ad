"""NREL End-Use Load Profiles (ResStock/ComStock) -> hourly building loads -> CityLearn building columns.

Source layout (a local folder or a base URL, both laid out as the OEDI data lake release folder)::

    <root>/metadata/metadata.parquet                      (or metadata.csv; index or column bldg_id)
    <root>/timeseries_individual_buildings/by_state/upgrade=<u>/state=<ST>/<bldg_id>-<u>.parquet  (or .csv)

Timeseries: ``timestamp`` marks the END of each 15-min (or hourly) interval, standard time; energy
columns are per interval: ``out.<fuel>.<end_use>.energy_consumption`` [kWh] (an optional ``.kwh``
suffix is accepted), ``out.load.{cooling,heating,hot_water}.energy_delivered.kbtu`` [kBtu],
``out.zone_mean_air_temp.conditioned_space.c`` [C].

Hourly building frame (:func:`building_loads`), index = interval-beginning local standard time:
``non_shiftable_load_kwh`` = electricity end uses other than space conditioning, water heating, PV and
totals (:data:`NOT_NON_SHIFTABLE`); ``cooling_demand_kwh``, ``heating_demand_kwh``, ``dhw_demand_kwh`` =
delivered loads x 0.29307107 kWh/kBtu (where one hour has both cooling and heating, the smaller is set to
0, as CityLearn requires); ``indoor_dry_bulb_temperature_c`` (hourly mean; the set point when the column is
absent); ``cooling_set_point_c`` / ``heating_set_point_c`` (metadata ``in.cooling_setpoint`` /
``in.heating_setpoint``, degF strings); ``occupant_count`` (metadata ``in.occupants``, constant).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.dataset import BUILDING_COLUMNS, calendar
from pipeline.errors import InputError
from pipeline.ingest import fetch
from pipeline.ingest.calendar import calendar_columns
from pipeline.ingest.messages import one_line
from pipeline.ingest.timeindex import check_regular, select_period
from surrogates.energyplus.metadata import parse_setpoint

KWH_PER_KBTU = 0.29307107017222  # 1 kBtu = 1055.05585262 kJ (International Table Btu) / 3600 kJ/kWh
ELECTRICITY = re.compile(r"^out\.electricity\.([a-z0-9_]+)\.energy_consumption(\.kwh)?$")
ENERGY = re.compile(r"^out\.[a-z0-9_]+\.[a-z0-9_]+\.(energy_consumption(\.kwh)?|energy_delivered\.kbtu)$")
LOADS = {
    "cooling_demand_kwh": "out.load.cooling.energy_delivered.kbtu",
    "heating_demand_kwh": "out.load.heating.energy_delivered.kbtu",
    "dhw_demand_kwh": "out.load.hot_water.energy_delivered.kbtu",
}
INDOOR_TEMPERATURE = "out.zone_mean_air_temp.conditioned_space.c"
#: electricity end uses that are NOT part of non_shiftable_load (2021 and 2022+ release names)
NOT_NON_SHIFTABLE = frozenset({
    "heating", "heating_supplement", "heating_hp_bkup", "heating_hp_bkup_fa", "heating_fans_pumps",
    "cooling", "cooling_fans_pumps", "fans_cooling", "fans_heating", "pumps_cooling", "pumps_heating",
    "water_systems", "hot_water", "pv", "total", "net",
})
#: energy columns allowed to be negative (generation)
MAY_BE_NEGATIVE = re.compile(r"^out\.electricity\.(pv|net)\.")
METADATA_CANDIDATES = ("metadata/metadata.parquet", "metadata/metadata.csv")
TOLERANCE = 1e-6


def timeseries_path(bldg_id: int, upgrade: int, state: str, suffix: str = "parquet") -> str:
    """Relative path of one building's timeseries in the data-lake layout."""
    return (f"timeseries_individual_buildings/by_state/upgrade={upgrade}/state={state}/"
            f"{bldg_id}-{upgrade}.{suffix}")


def read_eulp_metadata(path: str | Path) -> pd.DataFrame:
    """Metadata table (parquet or CSV) indexed by integer ``bldg_id``."""
    path = Path(path)
    frame = _read_table(path)
    if "bldg_id" in frame.columns:
        frame = frame.set_index("bldg_id")
    elif frame.index.name != "bldg_id":
        raise InputError("missing column", file=path, column="bldg_id", row=1)
    frame.index = pd.to_numeric(pd.Index(frame.index), errors="coerce")
    if frame.index.isna().any():
        raise InputError("non-numeric bldg_id", file=path, column="bldg_id",
                         row=int(np.argmax(frame.index.isna())) + 2)
    frame.index = frame.index.astype(np.int64)
    return frame


def read_eulp_timeseries(path: str | Path, timestamp_offset_hours: float = 0.0) -> tuple[pd.DataFrame, dict]:
    """One building's timeseries: the ``out.*`` columns as floats, index = interval-beginning.

    ``timestamp_offset_hours`` is added to the file's timestamps (e.g. -1 turns Eastern standard time
    into Central standard time, if a release is found to use EST). Rows in messages are 1-based data rows
    (CSV: file lines). Returns ``(frame, metadata)`` with the detected ``step``.
    """
    path = Path(path)
    raw = _read_table(path)
    first_row = 2 if path.suffix == ".csv" else 1
    if "timestamp" not in raw.columns:
        raise InputError("missing column", file=path, column="timestamp", row=1)
    for column in LOADS.values():
        if column not in raw.columns:
            raise InputError("missing column", file=path, column=column, row=1)
    stamps = pd.to_datetime(raw["timestamp"], errors="coerce")
    if stamps.isna().any():
        i = int(np.argmax(stamps.isna().to_numpy()))
        raise InputError(f"not a timestamp: {raw['timestamp'].iloc[i]!r}", file=path, column="timestamp",
                         row=first_row + i)
    ends = pd.DatetimeIndex(stamps)
    if ends.tz is not None:
        raise InputError("timestamps carry a time zone; expected naive standard time", file=path,
                         column="timestamp")
    ends = ends + pd.Timedelta(hours=timestamp_offset_hours)
    step = pd.Series(ends[1:] - ends[:-1]).mode().iloc[0] if len(ends) > 1 else pd.Timedelta(hours=1)
    if step not in (pd.Timedelta(minutes=15), pd.Timedelta(hours=1)):
        raise InputError(f"time step {step}; expected 15 min or 1 h", file=path, column="timestamp")
    check_regular(ends, step, file=path, column="timestamp", first_row=first_row)
    columns = [c for c in raw.columns if c.startswith("out.")]
    data = {}
    for column in columns:
        values = pd.to_numeric(raw[column], errors="coerce")
        if values.isna().any():
            i = int(np.argmax(values.isna().to_numpy()))
            raise InputError(f"non-numeric or empty value {raw[column].iloc[i]!r}", file=path, column=column,
                             row=first_row + i)
        values = values.to_numpy(dtype=float)
        if ENERGY.match(column) and not MAY_BE_NEGATIVE.match(column) and (values < -TOLERANCE).any():
            i = int(np.argmax(values < -TOLERANCE))
            raise InputError(f"negative energy {values[i]}", file=path, column=column, row=first_row + i)
        data[column] = values
    frame = pd.DataFrame(data, index=ends - step)
    return frame, {"file": str(path), "step": step, "first_end": ends[0], "last_end": ends[-1]}


def building_loads(timeseries: pd.DataFrame, metadata: pd.Series, *, file: object = None) -> pd.DataFrame:
    """Hourly building frame (module docstring) from a timeseries and the building's metadata row."""
    step = timeseries.index[1] - timeseries.index[0] if len(timeseries) > 1 else pd.Timedelta(hours=1)
    per_hour = int(pd.Timedelta(hours=1) / step)
    hours = timeseries.index.floor("h")
    counts = pd.Series(1, index=timeseries.index).groupby(hours).sum()
    keep = counts.index[counts == per_hour]
    if len(keep) == 0:
        raise InputError("no complete hour in the timeseries", file=file, column="timestamp")
    grouped = timeseries.groupby(hours)
    energy = grouped.sum().loc[keep]
    electric = [c for c in energy.columns if (m := ELECTRICITY.match(c)) and m.group(1) not in NOT_NON_SHIFTABLE]
    if not electric:
        raise InputError("no electricity end-use column for non_shiftable_load", file=file,
                         column="out.electricity.<end_use>.energy_consumption")
    out = pd.DataFrame(index=pd.DatetimeIndex(keep, name=None))
    out["non_shiftable_load_kwh"] = energy[electric].sum(axis=1).clip(lower=0.0).to_numpy()
    for name, column in LOADS.items():
        out[name] = energy[column].clip(lower=0.0).to_numpy() * KWH_PER_KBTU
    both = (out["cooling_demand_kwh"] > 0) & (out["heating_demand_kwh"] > 0)
    smaller_cooling = both & (out["cooling_demand_kwh"] < out["heating_demand_kwh"])
    out.loc[smaller_cooling, "cooling_demand_kwh"] = 0.0
    out.loc[both & ~smaller_cooling, "heating_demand_kwh"] = 0.0
    cooling_sp = metadata_set_point_c(metadata, "in.cooling_setpoint", file)
    heating_sp = metadata_set_point_c(metadata, "in.heating_setpoint", file)
    out["cooling_set_point_c"] = cooling_sp
    out["heating_set_point_c"] = heating_sp
    set_point = np.where(out["heating_demand_kwh"] > out["cooling_demand_kwh"], heating_sp, cooling_sp)
    if INDOOR_TEMPERATURE in timeseries.columns:
        out["indoor_dry_bulb_temperature_c"] = grouped[INDOOR_TEMPERATURE].mean().loc[keep].to_numpy()
    else:
        out["indoor_dry_bulb_temperature_c"] = set_point
    out["set_point_c"] = set_point
    out["occupant_count"] = _metadata_number(metadata, "in.occupants", file)
    out.attrs["hours_with_cooling_and_heating"] = int(both.sum())
    return out


def citylearn_building(loads: pd.DataFrame, index: pd.DatetimeIndex, *, holidays: Iterable = (),
                       timezone: str | None = None, solar_generation: pd.Series | None = None,
                       file: object = None) -> pd.DataFrame:
    """CityLearn building columns (internal names of :data:`BUILDING_COLUMNS`) for the hours of ``index``.

    ``solar_generation`` [W/kW] defaults to 0 (filled later by PV sizing); indoor relative humidity [%] comes
    from the loads' ``indoor_relative_humidity`` column when they have one (simulated houses; EULP timeseries
    do not) and is 0 otherwise; ``hvac_mode`` is 1 (cooling) unless the heating demand of the
    hour exceeds its cooling demand (2); ``power_outage`` 0.
    """
    part = select_period(loads, index, file=file)
    index = pd.DatetimeIndex(index)
    if len(index) and not index.equals(pd.date_range(index[0], periods=len(index), freq="h")):
        raise InputError("the period index must be hourly and contiguous", file=file, column="timestamp")
    start = index[0].to_datetime64() if len(index) else np.datetime64("2000-01-01T00")
    out = pd.DataFrame(calendar(start, len(index), holidays), index=index)
    if timezone is not None:  # daylight_savings_status from the zone's rules; 0 (standard time) otherwise
        out["daylight_savings_status"] = calendar_columns(index, timezone=timezone)["daylight_savings_status"]
    out["indoor_dry_bulb_temperature"] = part["indoor_dry_bulb_temperature_c"].to_numpy()
    out["average_unmet_cooling_setpoint_difference"] = (part["indoor_dry_bulb_temperature_c"]
                                                        - part["set_point_c"]).to_numpy()
    out["indoor_relative_humidity"] = (part["indoor_relative_humidity"].to_numpy()
                                       if "indoor_relative_humidity" in part.columns else 0.0)
    out["non_shiftable_load"] = part["non_shiftable_load_kwh"].to_numpy()
    out["dhw_demand"] = part["dhw_demand_kwh"].to_numpy()
    out["cooling_demand"] = part["cooling_demand_kwh"].to_numpy()
    out["heating_demand"] = part["heating_demand_kwh"].to_numpy()
    if solar_generation is None:
        out["solar_generation"] = 0.0
    else:
        out["solar_generation"] = select_period(solar_generation.to_frame(), index, file=file).iloc[:, 0].to_numpy()
    out["occupant_count"] = part["occupant_count"].to_numpy()
    out["indoor_dry_bulb_temperature_set_point"] = part["set_point_c"].to_numpy()
    out["hvac_mode"] = np.where(part["heating_demand_kwh"] > part["cooling_demand_kwh"], 2, 1)
    out["power_outage"] = 0
    out["indoor_dry_bulb_temperature_cooling_set_point"] = part["cooling_set_point_c"].to_numpy()
    out["indoor_dry_bulb_temperature_heating_set_point"] = part["heating_set_point_c"].to_numpy()
    return out[[c for c in BUILDING_COLUMNS if c in out.columns]]


def solar_noon_lag_hours(generation: pd.Series, longitude: float, utc_offset_hours: float) -> float:
    """How many hours the centroid of a sun-driven daily profile lags local solar noon.

    Parameters
    ----------
    generation
        Hourly PV generation (any positive unit; sign ignored), index = interval-beginning.
    longitude
        Site longitude [deg east].
    utc_offset_hours
        UTC offset of the index's standard time [h] (e.g. -6 for US Central).

    Returns
    -------
    Centroid time of the mean daily profile minus mean solar noon, 12 h + (15 x offset - longitude) / 15
    [h]. The equation of time moves noon by at most +-0.27 h, so a result near +-1 means the timestamps are
    in a neighbouring zone (e.g. Eastern data at a Central site give about -1): pass minus the rounded
    value as ``timestamp_offset_hours``.
    """
    values = generation.abs()
    profile = values.groupby(values.index.hour).mean()
    if profile.sum() <= 0:
        raise InputError("no generation to locate solar noon", column=str(generation.name))
    centroid = float(((profile.index.to_numpy() + 0.5) * profile.to_numpy()).sum() / profile.sum())
    noon = 12.0 + (15.0 * utc_offset_hours - longitude) / 15.0
    return centroid - noon


def locate_building(source: str, bldg_id: int, *, upgrade: int = 0, state: str | None = None,
                    cache_dir: str | Path = ".cache/districtgen") -> tuple[Path, Path]:
    """Paths of the metadata and timeseries files of one building, downloading from a URL ``source``.

    ``source`` is a local release folder or an ``http(s)://`` base URL with the same layout; downloads
    are cached under ``cache_dir`` and checked against ``<source>/SHA256SUMS`` when the server has one.
    """
    remote = source.startswith(("http://", "https://"))
    checksums = fetch.get_checksums(source, cache_dir) if remote else {}

    def find(candidates: list[str], what: str) -> Path:
        for relative in candidates:
            if not remote:
                if (Path(source) / relative).exists():
                    return Path(source) / relative
                continue
            try:
                return fetch.get_file(fetch.join_url(source, relative), cache_dir, sha256=checksums.get(relative))
            except InputError as error:
                if "HTTP 404" not in str(error):
                    raise
        raise InputError(f"no {what} found (looked for {', '.join(candidates)})", file=source)

    metadata_path = find(list(METADATA_CANDIDATES), "metadata")
    if state is None:
        metadata = read_eulp_metadata(metadata_path)
        if bldg_id not in metadata.index or "in.state" not in metadata.columns:
            raise InputError(f"building {bldg_id} or its in.state not in the metadata; give --state",
                             file=metadata_path, column="in.state")
        state = str(metadata.at[bldg_id, "in.state"])
    series = [timeseries_path(bldg_id, upgrade, state, suffix) for suffix in ("parquet", "csv")]
    return metadata_path, find(series, f"timeseries for building {bldg_id}")


@dataclass(frozen=True)
class EulpBuilding:
    """One EULP building read from its release: the hourly loads (:func:`building_loads`), its raw timeseries
    (for checks of its own columns, e.g. its outdoor temperature) and where the timeseries came from."""

    loads: pd.DataFrame
    series: pd.DataFrame
    series_path: Path


def read_eulp_building(source: str, bldg_id: int, *, upgrade: int = 0, state: str | None = None,
                       cache_dir: str | Path = ".cache/districtgen",
                       timestamp_offset_hours: float = 0.0) -> EulpBuilding:
    """Locate (:func:`locate_building`), read and convert one building of an EULP release; a building missing
    from the metadata is one :class:`InputError` naming the metadata file."""
    metadata_path, series_path = locate_building(source, int(bldg_id), upgrade=upgrade, state=state,
                                                 cache_dir=cache_dir)
    metadata = read_eulp_metadata(metadata_path)
    if int(bldg_id) not in metadata.index:
        raise InputError(f"building {bldg_id} not in the metadata", file=metadata_path, column="bldg_id")
    series, _ = read_eulp_timeseries(series_path, timestamp_offset_hours)
    return EulpBuilding(building_loads(series, metadata.loc[int(bldg_id)], file=series_path), series, series_path)


def _read_table(path: Path) -> pd.DataFrame:
    try:
        if path.suffix == ".parquet":
            return pd.read_parquet(path)
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except FileNotFoundError:
        raise InputError("file not found", file=path) from None
    except Exception as error:  # pyarrow/pandas raise many types for a corrupt file
        raise InputError(f"cannot read table ({type(error).__name__}: {one_line(error)})", file=path) from None


def _metadata_number(metadata: pd.Series, column: str, file: object) -> float:
    if column not in metadata.index:
        raise InputError("missing metadata column", file=file, column=column, row=f"bldg_id {metadata.name}")
    try:
        return float(str(metadata[column]).strip())
    except ValueError:
        raise InputError(f"not a number: {metadata[column]!r}", file=file, column=column,
                         row=f"bldg_id {metadata.name}") from None


def metadata_set_point_c(metadata: pd.Series, column: str, file: object) -> float:
    """A ResStock set point cell (``"76F"``, bare numbers are degF) -> degC, via the one shared parser
    :func:`surrogates.energyplus.metadata.parse_setpoint`."""

    if column not in metadata.index:
        raise InputError("missing metadata column", file=file, column=column, row=f"bldg_id {metadata.name}")
    try:
        return parse_setpoint(metadata[column])
    except ValueError as error:
        raise InputError(str(error), file=file, column=column, row=f"bldg_id {metadata.name}") from None
