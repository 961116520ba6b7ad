"""Build the Room2R2C test FMU (FMI 2.0 co-simulation, linux64) from ``room2r2c.c`` with gcc and the FMI
headers that fmpy ships, and compute a zone's ideal loads by driving that FMU (shared by tests and
benchmarks/surrogate_train.py)."""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
#: (name, value reference, causality, start)
VARIABLES = [
    ("T_out", 0, "input", 10.0), ("I_dir", 1, "input", 0.0), ("I_dif", 2, "input", 0.0),
    ("n_occ", 3, "input", 0.0), ("Q_heat", 4, "input", 0.0), ("Q_cool", 5, "input", 0.0),
    ("T_in", 6, "output", None), ("T_mass", 7, "output", None),
    ("T0", 8, "parameter", 21.0), ("C_air", 9, "parameter", 2.0e6), ("C_mass", 10, "parameter", 3.0e7),
    ("UA_air", 11, "parameter", 120.0), ("H_am", 12, "parameter", 900.0), ("UA_mass", 13, "parameter", 60.0),
    ("A_sol", 14, "parameter", 3.0), ("occ_gain", 15, "parameter", 100.0), ("dt_sub", 16, "parameter", 60.0),
]
#: our ILV names -> this FMU's variable names
VARIABLE_MAP = {
    "outdoor_dry_bulb_temperature": "T_out", "direct_solar_irradiance": "I_dir",
    "diffuse_solar_irradiance": "I_dif", "occupant_count": "n_occ", "heating_power": "Q_heat",
    "cooling_power": "Q_cool", "indoor_dry_bulb_temperature": "T_in",
}


def model_description() -> str:
    rows = []
    for name, vr, causality, start in VARIABLES:
        if causality == "output":
            rows.append(f'<ScalarVariable name="{name}" valueReference="{vr}" causality="output" '
                        'variability="continuous" initial="calculated"><Real/></ScalarVariable>')
        else:
            variability = "continuous" if causality == "input" else "fixed"
            rows.append(f'<ScalarVariable name="{name}" valueReference="{vr}" causality="{causality}" '
                        f'variability="{variability}"><Real start="{start}"/></ScalarVariable>')
    outputs = [i + 1 for i, v in enumerate(VARIABLES) if v[2] == "output"]
    unknowns = "".join(f'<Unknown index="{i}"/>' for i in outputs)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<fmiModelDescription fmiVersion="2.0" modelName="Room2R2C" '
        'guid="{5c1d6f0e-2r2c-4d1e-9a6b-districtgen0001}" numberOfEventIndicators="0">\n'
        '<CoSimulation modelIdentifier="Room2R2C" canHandleVariableCommunicationStepSize="true" '
        'canGetAndSetFMUstate="true"/>\n'
        '<DefaultExperiment startTime="0" stopTime="86400" stepSize="3600"/>\n'
        f"<ModelVariables>{''.join(rows)}</ModelVariables>\n"
        f"<ModelStructure><Outputs>{unknowns}</Outputs><InitialUnknowns>{unknowns}</InitialUnknowns>"
        "</ModelStructure>\n</fmiModelDescription>\n"
    )


def build_room_fmu(directory: Path) -> Path:
    """Compile room2r2c.c and zip ``directory/Room2R2C.fmu``; returns its path."""
    import fmpy

    if shutil.which("gcc") is None:
        import pytest

        pytest.skip("gcc is needed to build the test FMU")
    directory = Path(directory)
    stage = directory / "Room2R2C_build"
    binary = stage / "binaries" / "linux64" / "Room2R2C.so"
    binary.parent.mkdir(parents=True, exist_ok=True)
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", f"-I{headers}", str(HERE / "room2r2c.c"), "-o",
                    str(binary), "-lm"], check=True, capture_output=True)
    (stage / "modelDescription.xml").write_text(model_description())
    fmu = directory / "Room2R2C.fmu"
    with zipfile.ZipFile(fmu, "w") as archive:
        archive.write(stage / "modelDescription.xml", "modelDescription.xml")
        archive.write(binary, "binaries/linux64/Room2R2C.so")
    return fmu


def ideal_loads(fmu: Path, weather: dict[str, np.ndarray], heating_set_point: float, cooling_set_point: float,
                start_values: dict[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Hourly ideal heating and cooling energy (kWh) that keep the zone air of the FMU at the end of every hour
    inside [heating_set_point, cooling_set_point] degC. The zone is linear in the heat flow, so each hour is
    solved from two trial steps (0 W and 1 kW) with the FMU state saved and restored.

    ``weather`` holds arrays ``T_out`` (degC), ``I_dir``, ``I_dif`` (W/m2), ``n_occ`` (people) of equal length.
    """
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    description = read_model_description(str(fmu))
    refs = {v.name: v.valueReference for v in description.modelVariables}
    unzipped = extract(str(fmu))
    slave = FMU2Slave(guid=description.guid, unzipDirectory=unzipped,
                      modelIdentifier=description.coSimulation.modelIdentifier, instanceName="ideal")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    for name, value in (start_values or {}).items():
        slave.setReal([refs[name]], [value])
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    n = len(weather["T_out"])
    heating, cooling = np.zeros(n), np.zeros(n)
    exo = [refs[k] for k in ("T_out", "I_dir", "I_dif", "n_occ")]
    power = [refs["Q_heat"], refs["Q_cool"]]
    for t in range(n):
        slave.setReal(exo, [float(weather[k][t]) for k in ("T_out", "I_dir", "I_dif", "n_occ")])
        state = slave.getFMUstate()
        ends = []
        for trial in (0.0, 1000.0):
            slave.setFMUstate(state)
            slave.setReal(power, [trial, 0.0])
            slave.doStep(t * 3600.0, 3600.0)
            ends.append(slave.getReal([refs["T_in"]])[0])
        slave.setFMUstate(state)
        slave.freeFMUstate(state)
        gain = (ends[1] - ends[0]) / 1000.0  # K per W
        q = 0.0
        if ends[0] < heating_set_point:
            q = (heating_set_point - ends[0]) / gain
        elif ends[0] > cooling_set_point:
            q = (cooling_set_point - ends[0]) / gain
        slave.setReal(power, [max(q, 0.0), max(-q, 0.0)])
        slave.doStep(t * 3600.0, 3600.0)
        heating[t], cooling[t] = max(q, 0.0) / 1000.0, max(-q, 0.0) / 1000.0
    slave.terminate()
    slave.freeInstance()
    shutil.rmtree(unzipped, ignore_errors=True)
    return heating, cooling


def synthetic_house(fmu: Path, days: int, t_mean: float = 8.0, seed: int = 0, start: str = "2026-01-05"):
    """Hourly loads-and-weather frame for ``days`` days: a daily outdoor temperature cycle of +-6 K around
    ``t_mean`` with day-to-day weather noise, clear-sky-like solar, 3 occupants away 8-17 h on weekdays, and
    the FMU's ideal loads for a [20, 24] degC band."""
    rng = np.random.default_rng(seed)
    index = pd.date_range(start, periods=24 * days, freq="h")
    hour = index.hour.to_numpy()
    daily = np.repeat(rng.normal(0.0, 3.0, days), 24)
    t_out = t_mean + daily + 6.0 * np.sin(2 * np.pi * (hour - 9) / 24)
    sun = np.clip(np.sin(2 * np.pi * (hour - 6) / 24), 0.0, None) * np.repeat(rng.uniform(0.2, 1.0, days), 24)
    frame = pd.DataFrame({"outdoor_dry_bulb_temperature": t_out, "direct_solar_irradiance": 700.0 * sun,
                          "diffuse_solar_irradiance": 120.0 * np.sqrt(sun)}, index=index)
    frame["occupant_count"] = np.where((index.dayofweek < 5) & (hour >= 8) & (hour < 17), 0.0, 3.0)
    weather = {"T_out": t_out, "I_dir": frame["direct_solar_irradiance"].to_numpy(),
               "I_dif": frame["diffuse_solar_irradiance"].to_numpy(), "n_occ": frame["occupant_count"].to_numpy()}
    frame["heating_demand"], frame["cooling_demand"] = ideal_loads(fmu, weather, 20.0, 24.0, {"T0": 22.0})
    frame["indoor_dry_bulb_temperature_set_point"] = 22.0
    return frame


def read_epw_year(path: Path, year: int = 2026) -> pd.DataFrame:
    """Hourly T_out (degC), direct normal and diffuse horizontal irradiance (W/m2) of a TMY3 EPW, re-stamped
    on ``year`` interval-beginning (EPW hour h ends at h:00 local standard time)."""
    rows = pd.read_csv(path, skiprows=8, header=None)
    index = pd.date_range(f"{year}-01-01", periods=8760, freq="h")
    return pd.DataFrame({"outdoor_dry_bulb_temperature": rows[6].to_numpy(float)[:8760],
                         "direct_solar_irradiance": rows[14].to_numpy(float)[:8760],
                         "diffuse_solar_irradiance": rows[15].to_numpy(float)[:8760]}, index=index)


def occupants(index: pd.DatetimeIndex) -> np.ndarray:
    """A household of 3: away 8-17 h on weekdays, home otherwise."""
    weekday, hour = index.dayofweek < 5, index.hour
    return np.where(weekday & (hour >= 8) & (hour < 17), 0.0, 3.0)


def house_loads(fmu: Path, epw: Path) -> pd.DataFrame:
    """Weather, occupants and the FMU zone's ideal loads for one year."""
    loads = read_epw_year(epw)
    loads["occupant_count"] = occupants(loads.index)
    weather = {"T_out": loads["outdoor_dry_bulb_temperature"].to_numpy(), "I_dir": loads["direct_solar_irradiance"]
               .to_numpy(), "I_dif": loads["diffuse_solar_irradiance"].to_numpy(), "n_occ": loads["occupant_count"]
               .to_numpy()}
    heating, cooling = ideal_loads(fmu, weather, 20.0, 24.0, {"T0": 22.0})
    loads["heating_demand"], loads["cooling_demand"] = heating, cooling
    loads["indoor_dry_bulb_temperature_set_point"] = 22.0
    return loads
