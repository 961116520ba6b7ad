"""Episode series for KPIs and the ``history()`` table, derived from the recorded arrays after the fact.

Counterfactual ("baseline") series follow CityLearn 2.1 (kWh per step; cost in $, emission in kg):
``without_storage`` removes every storage's electricity (and the EV chargers', as CityLearn 2.5 does; the
washing machines' load stays), ``and_pv`` adds the PV generation back, and
``without_storage_and_partial_load`` also adds back the heat-pump electricity an LSTM building saved by
serving less than its ideal load: (ideal - served demand) / COP.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from citylearn_env.district import District

if TYPE_CHECKING:  # pandas is imported where a table is built (importing citylearn_env stays light)
    import pandas as pd

#: data columns copied into the history (name in history -> data-set column of the episode)
DATA_COLUMNS = {
    "dhw_demand": "dhw_demand",
    "non_shiftable_load": "non_shiftable_load",
    "cooling_demand_without_partial_load": "cooling_demand",
    "heating_demand_without_partial_load": "heating_demand",
    "indoor_dry_bulb_temperature_without_partial_load": "indoor_dry_bulb_temperature",
    "indoor_dry_bulb_temperature_set_point": "indoor_dry_bulb_temperature_set_point",
    "indoor_dry_bulb_temperature_cooling_set_point": "indoor_dry_bulb_temperature_cooling_set_point",
    "indoor_dry_bulb_temperature_heating_set_point": "indoor_dry_bulb_temperature_heating_set_point",
    "occupant_count": "occupant_count",
    "hvac_mode": "hvac_mode",
    "outdoor_dry_bulb_temperature": "outdoor_dry_bulb_temperature",
    "electricity_pricing": "electricity_pricing",
    "carbon_intensity": "carbon_intensity",
}
#: end use -> its COP column in the history
COP_COLUMNS = {"cooling": "cooling_device_cop", "heating": "heating_device_cop"}
#: end use -> (served demand, ideal demand) columns, for the partial-load counterfactual
PARTIAL_LOAD = {"cooling": ("cooling_demand", "cooling_demand_without_partial_load"),
                "heating": ("heating_demand", "heating_demand_without_partial_load")}
STORAGE_CONSUMPTION = ("cooling_storage_electricity_consumption", "heating_storage_electricity_consumption",
                       "dhw_storage_electricity_consumption", "electrical_storage_electricity_consumption")
#: counterfactual suffix -> (remove storage, add partial load back, remove PV)
BASELINES = {
    "": (False, False, False),
    "_without_storage": (True, False, False),
    "_without_storage_and_pv": (True, False, True),
    "_without_storage_and_partial_load": (True, True, False),
    "_without_storage_and_partial_load_and_pv": (True, True, True),
}

#: series that add up over buildings (the district rows of the history)
ADDITIVE_PREFIXES = ("net_electricity_consumption", "energy_", "solar_generation", "non_shiftable_load",
                     "dhw_demand", "cooling_demand", "heating_demand", "power_outage")


def episode_series(district: District, t_end: int, window: slice | None = None) -> dict[str, np.ndarray]:
    """All recorded and derived series over time steps 0..t_end (optionally a ``window`` of them), (B, T)."""
    n = t_end + 1
    e = district.episode
    out = {k: v[:, :n] for k, v in district.recorded.items()}
    balance = district.battery_record.energy_balance[:, :n]
    out["energy_from_electrical_storage"] = -np.minimum(balance, 0.0)
    out["energy_to_electrical_storage"] = np.maximum(balance, 0.0)
    out.update({k: e[src][:, :n] for k, src in DATA_COLUMNS.items()})
    out["power_outage"] = e.outage[:, :n]
    for end_use, column in COP_COLUMNS.items():
        out[column] = district.end_use(end_use).cop[:, :n]
    out["solar_generation"] = -e.pv_generation[:, :n]
    out["pv_nominal_power"] = np.repeat(district.pv_nominal_power[:, None], n, axis=1)
    if district.settings.first_step_booked_three_times:  # CityLearn 2.5 books row 0's battery balance twice
        doubled = out["electrical_storage_electricity_consumption"].copy()
        doubled[:, 0] *= 2.0
        out["electrical_storage_electricity_consumption"] = doubled
    price, carbon = out["electricity_pricing"], out["carbon_intensity"]
    net = out["net_electricity_consumption"]
    storage = sum(out[k] for k in STORAGE_CONSUMPTION)
    if "chargers_electricity_consumption" in out:  # EV charging counts as storage (CityLearn 2.5); machines not
        storage = storage + out["chargers_electricity_consumption"]
    partial = partial_load_saving(out, district, n)
    for suffix, (no_storage, add_partial, no_pv) in BASELINES.items():
        values = net - storage if no_storage else net
        if add_partial:
            values = values + partial
        if no_pv:
            values = values - out["solar_generation"]
        out["net_electricity_consumption" + suffix] = values
        out["net_electricity_consumption_cost" + suffix] = values * price
        out["net_electricity_consumption_emission" + suffix] = np.maximum(0.0, values * carbon)
    if window is not None:
        out = {k: v[:, window] for k, v in out.items()}
    return out


def partial_load_saving(out: dict[str, np.ndarray], district: District, n: int) -> np.ndarray:
    """(B, n) heat-pump electricity [kWh] each LSTM building saved by serving less than its ideal load:
    (ideal - served demand) / COP for cooling and heating (0 for the other buildings). With
    ``settings.kpi_partial_load_heating_cop_of_last_step`` the heating difference is divided by the heating COP
    of the last of the n steps at every step, as CityLearn 2.1 and 2.5 do."""
    partial = np.zeros((district.n, n))
    for end_use, (served, ideal) in PARTIAL_LOAD.items():
        cop = district.end_use(end_use).cop[:, :n]
        if end_use == "heating" and district.settings.kpi_partial_load_heating_cop_of_last_step:
            cop = cop[:, n - 1:n]
        saved = (out[ideal] - out[served]) / cop
        partial += np.where(district.dynamics[:, None], saved, 0.0)
    return partial


def history_frame(district: District, t_end: int, *, include_district: bool = True) -> pd.DataFrame:
    """A long DataFrame: one row per (building, time_step); district sums as building ``"District"``."""
    import pandas as pd  # lazy: importing citylearn_env does not import pandas (package docstring)

    series = episode_series(district, t_end)
    names = list(district.names)
    n = t_end + 1
    frame = pd.DataFrame({k: v.reshape(-1) for k, v in series.items()})
    frame.insert(0, "time_step", np.tile(np.arange(n), len(names)))
    frame.insert(0, "building", np.repeat(names, n))
    if include_district:
        district_rows = {"building": ["District"] * n, "time_step": np.arange(n)}
        for k, v in series.items():
            additive = k.startswith(ADDITIVE_PREFIXES) or k.endswith("_electricity_consumption")
            district_rows[k] = v.sum(axis=0) if additive else np.full(n, np.nan)
        frame = pd.concat([frame, pd.DataFrame(district_rows)], ignore_index=True)
    return frame


def device_history_frame(district: District, t_end: int) -> pd.DataFrame:
    """A long DataFrame of the EV chargers, EVs and washing machines over time steps 0..t_end: one row per
    (device, time_step) with ``kind`` ("charger", "electric_vehicle", "washing_machine"), ``building`` (the
    owner; empty for an EV), ``electricity_consumption`` [kWh] (chargers, machines), ``soc`` [-],
    ``efficiency`` [-] and ``capacity`` [kWh] (EVs; NaN for the others). Empty without such devices."""
    import pandas as pd  # lazy: importing citylearn_env does not import pandas (package docstring)

    n = t_end + 1
    frames = []

    def frame(kind: str, names: Sequence[str], buildings: Sequence[str], **columns: np.ndarray) -> None:
        rows = {"kind": kind, "device": np.repeat(list(names), n), "building": np.repeat(list(buildings), n),
                "time_step": np.tile(np.arange(n), len(names))}
        frames.append(pd.DataFrame(rows | {k: v[:, :n].reshape(-1) for k, v in columns.items()}))

    if district.ev is not None:
        chargers = district.ev.chargers
        frame("charger", chargers.names, [district.names[b] for b in chargers.building],
              electricity_consumption=district.charger_record.electricity_consumption)
        r = district.ev_record
        frame("electric_vehicle", district.ev.vehicles.names, [""] * len(district.ev.vehicles.names),
              soc=r.soc, efficiency=r.efficiency, capacity=r.capacity)
    if district.machines is not None:
        frame("washing_machine", district.machines.names, [district.names[b] for b in district.machines.building],
              electricity_consumption=district.machine_record.electricity_consumption)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(
        columns=["kind", "device", "building", "time_step"])
