"""ILV tables from an FMU (FMI 2.0 co-simulation) of a building, driven with fmpy.

Given the building's ideal hourly loads and weather, the FMU is stepped hour by hour (inputs held constant
over each hour, zero-order hold) for
  * reference 0: ideal-load replay (multiplier 1),
  * reference 1: free float (multiplier 0 in every hour: a true free float, unlike upstream CityLearn's
    "free_float" run that only zeroes ~60 % of the hours),
  * references 2 .. N+1: partial-load runs, multiplier ~ U(m_min, m_max) with probability p, else 1, drawn
    from ``numpy.random.default_rng([seed, reference])`` per hour or, with ``hold_hours`` > 1, held over
    random blocks of 1..hold_hours hours.
The recorded loads are the multiplied ones (what the FMU received); the indoor temperature is the FMU output
at the end of each hour. FMU variable names come from configuration: a mapping from our names
(:data:`MAPPABLE`) to the FMU's variable names.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.errors import InputError
from surrogates.ilv import calendar_columns, validate_ilv

#: our name -> (expected FMU causality, unit sent to / read from the FMU)
MAPPABLE: dict[str, tuple[str, str]] = {
    "outdoor_dry_bulb_temperature": ("input", "degC"),
    "direct_solar_irradiance": ("input", "W/m2"),
    "diffuse_solar_irradiance": ("input", "W/m2"),
    "occupant_count": ("input", "people"),
    "indoor_dry_bulb_temperature_set_point": ("input", "degC"),
    "heating_power": ("input", "W, heat added, >= 0"),
    "cooling_power": ("input", "W, heat removed, >= 0"),
    "net_heating_power": ("input", "W, heating minus cooling"),
    "indoor_dry_bulb_temperature": ("output", "degC"),
}
LOAD_COLUMNS = ("direct_solar_irradiance", "diffuse_solar_irradiance", "outdoor_dry_bulb_temperature",
                "occupant_count", "cooling_demand", "heating_demand")


def check_variables(fmu_path: str | os.PathLike, variables: Mapping[str, str]):
    """Read the FMU's model description and check the mapping; returns ``(description, {our name: vr})``.

    Raises :class:`InputError` for unknown keys, a missing required mapping, or FMU variables that do not
    exist or have the wrong causality.
    """
    from fmpy import read_model_description  # lazy: fmpy is optional (extra fmu)

    fmu_path = Path(fmu_path)
    if not fmu_path.is_file():
        raise InputError("FMU not found", file=fmu_path)
    unknown = [k for k in variables if k not in MAPPABLE]
    if unknown:
        raise InputError(f"unknown mapping key; known keys are {sorted(MAPPABLE)}", file=fmu_path,
                         column=unknown[0])
    if "indoor_dry_bulb_temperature" not in variables:
        raise InputError("the FMU output for the indoor temperature must be mapped", file=fmu_path,
                         column="indoor_dry_bulb_temperature")
    split = "heating_power" in variables and "cooling_power" in variables
    if not split and "net_heating_power" not in variables:
        raise InputError("map either both 'heating_power' and 'cooling_power' or 'net_heating_power'",
                         file=fmu_path, column="heating_power")
    try:
        description = read_model_description(str(fmu_path))
    except Exception as error:  # fmpy raises several types for a broken archive
        raise InputError(f"not a readable FMU: {error}", file=fmu_path) from None
    if description.coSimulation is None:
        raise InputError("the FMU has no co-simulation interface (FMI 2.0 CS needed)", file=fmu_path)
    by_name = {v.name: v for v in description.modelVariables}
    refs = {}
    for ours, theirs in variables.items():
        causality = MAPPABLE[ours][0]
        variable = by_name.get(theirs)
        if variable is None:
            candidates = sorted(v.name for v in description.modelVariables if v.causality == causality)
            raise InputError(f"the FMU has no variable named {theirs!r}; its {causality}s are {candidates}",
                             file=fmu_path, column=ours)
        if variable.causality != causality:
            raise InputError(f"FMU variable {theirs!r} has causality {variable.causality!r}, expected "
                             f"{causality!r}", file=fmu_path, column=ours)
        refs[ours] = variable.valueReference
    return description, refs


def _check_loads(loads: pd.DataFrame) -> pd.DatetimeIndex:
    source = "<building loads and weather>"
    missing = [c for c in LOAD_COLUMNS if c not in loads.columns]
    if missing:
        raise InputError(f"missing column(s) {missing}", file=source, column=missing[0])
    if not isinstance(loads.index, pd.DatetimeIndex):
        raise InputError("the loads frame needs an hourly DatetimeIndex (interval-beginning, local standard "
                         "time)", file=source, column="index")
    for column in LOAD_COLUMNS:
        values = loads[column].to_numpy(dtype=float)
        if not np.isfinite(values).all():
            raise InputError("missing or non-finite value", file=source, column=column,
                             row=int(np.flatnonzero(~np.isfinite(values))[0]))
    steps = np.diff(loads.index.as_unit("ns").asi8)
    if len(steps) and (steps != 3_600_000_000_000).any():
        raise InputError("index is not consecutive hourly", file=source, column="index",
                         row=int(np.flatnonzero(steps != 3_600_000_000_000)[0]) + 1)
    return loads.index


def load_multipliers(n_hours: int, reference: int, seed: int = 0, multiplier_range: tuple[float, float] = (0.3, 1.7),
                     probability: float = 0.6, hold_hours: int = 6) -> np.ndarray:
    """Per-hour load multipliers of one reference run: 1 (ideal), 0 (free float) or random partial loads.

    With ``hold_hours`` > 1 each draw is held for a block of 1..hold_hours hours (length uniform), so the
    runs also contain sustained over/under-supply that charges or discharges the building mass; with 1 every
    hour is drawn independently (upstream CityLearn's design)."""
    if reference == 0:
        return np.ones(n_hours)
    if reference == 1:
        return np.zeros(n_hours)
    rng = np.random.default_rng([seed, reference])
    if hold_hours <= 1:
        draws = rng.uniform(multiplier_range[0], multiplier_range[1], n_hours)
        return np.where(rng.random(n_hours) < probability, draws, 1.0)
    lengths = rng.integers(1, hold_hours + 1, n_hours)
    blocks = np.repeat(np.arange(n_hours), lengths)[:n_hours]
    draws = rng.uniform(multiplier_range[0], multiplier_range[1], n_hours)
    return np.where(rng.random(n_hours) < probability, draws, 1.0)[blocks]


def simulate_ilv_fmu(
    fmu_path: str | os.PathLike,
    loads: pd.DataFrame,
    variables: Mapping[str, str],
    *,
    n_partial: int = 4,
    seed: int = 0,
    multiplier_range: tuple[float, float] = (0.3, 1.7),
    probability: float = 0.6,
    hold_hours: int = 6,
    start_values: Mapping[str, float] | None = None,
    holidays: set | None = None,
) -> pd.DataFrame:
    """Run the ideal replay, a free float and ``n_partial`` partial-load runs of an FMU; return the ILV table.

    Parameters
    ----------
    fmu_path : FMI 2.0 co-simulation FMU.
    loads : hourly frame, DatetimeIndex (interval-beginning, local standard time), columns
        ``direct_solar_irradiance``, ``diffuse_solar_irradiance`` (W/m2), ``outdoor_dry_bulb_temperature``
        (degC), ``occupant_count``, ``cooling_demand``, ``heating_demand`` (ideal loads, kWh per hour) and
        optionally ``indoor_dry_bulb_temperature_set_point`` (degC).
    variables : our name (see :data:`MAPPABLE`) -> FMU variable name.
    start_values : FMU parameter name -> value, applied before initialisation of every run.
    """
    description, refs = check_variables(fmu_path, variables)
    index = _check_loads(loads)
    if n_partial < 0:
        raise InputError("n_partial must be >= 0", column="n_partial")
    start_values = dict(start_values or {})
    by_name = {v.name: v.valueReference for v in description.modelVariables}
    missing = [name for name in start_values if name not in by_name]
    if missing:
        raise InputError(f"the FMU has no variable named {missing[0]!r}", file=fmu_path, column="start_values")
    from fmpy import extract  # lazy: fmpy is optional (extra fmu)

    unzipped = extract(str(fmu_path))
    try:
        runs = [
            _one_run(description, unzipped, refs, by_name, start_values, loads, reference,
                     load_multipliers(len(loads), reference, seed, multiplier_range, probability, hold_hours))
            for reference in range(n_partial + 2)
        ]
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)
    frames = []
    calendar = calendar_columns(index, holidays)
    for reference, (cooling, heating, indoor) in enumerate(runs):
        frame = pd.DataFrame({"reference": reference, "timestamp": index})
        frame = pd.concat([frame, calendar], axis=1)
        for column in LOAD_COLUMNS[:4]:
            frame[column] = loads[column].to_numpy(dtype=float)
        if "indoor_dry_bulb_temperature_set_point" in loads.columns:
            frame["indoor_dry_bulb_temperature_set_point"] = loads["indoor_dry_bulb_temperature_set_point"].to_numpy(
                dtype=float)
        frame["cooling_demand"], frame["heating_demand"] = cooling, heating
        frame["indoor_dry_bulb_temperature"] = indoor
        frames.append(frame)
    return validate_ilv(pd.concat(frames, ignore_index=True), source=f"FMU run of {fmu_path}")


def _one_run(description, unzipped, refs, by_name, start_values, loads, reference, multiplier):
    from fmpy.fmi2 import FMU2Slave  # lazy: fmpy is optional (extra fmu)

    slave = FMU2Slave(guid=description.guid, unzipDirectory=unzipped,
                      modelIdentifier=description.coSimulation.modelIdentifier, instanceName=f"ilv{reference}")
    slave.instantiate()
    try:
        slave.setupExperiment(startTime=0.0)
        if start_values:
            slave.setReal([by_name[k] for k in start_values], list(start_values.values()))
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        cooling = loads["cooling_demand"].to_numpy(dtype=float) * multiplier
        heating = loads["heating_demand"].to_numpy(dtype=float) * multiplier
        columns = {name: loads[name].to_numpy(dtype=float) for name in refs if name in loads.columns}
        columns["heating_power"] = heating * 1000.0  # kWh in one hour -> mean W
        columns["cooling_power"] = cooling * 1000.0
        columns["net_heating_power"] = (heating - cooling) * 1000.0
        names = [name for name in refs if name != "indoor_dry_bulb_temperature"]
        missing = [name for name in names if name not in columns]
        if missing:
            raise InputError("the FMU input is mapped but the loads frame has no such column",
                             column=missing[0])
        in_refs = [refs[name] for name in names]
        matrix = np.column_stack([columns[name] for name in names]) if names else np.zeros((len(loads), 0))
        out_ref = [refs["indoor_dry_bulb_temperature"]]
        indoor = np.empty(len(loads))
        for t in range(len(loads)):
            slave.setReal(in_refs, matrix[t].tolist())
            slave.doStep(currentCommunicationPoint=t * 3600.0, communicationStepSize=3600.0)
            indoor[t] = slave.getReal(out_ref)[0]
        slave.terminate()
    finally:
        slave.freeInstance()
    return cooling, heating, indoor
