"""The plant MPC plans over at step t: the episode plant over t .. t + H, its storages starting from the env's
states at t (:func:`horizon_plant`), and the same window with the uncertain series replaced by forecasts
(:func:`forecast_plant`; :mod:`pipeline.optimal.forecasts`).

Column 0 of a window is the present step t (already run: its values are the env's); the forecasts fill the
controlled steps t + 1 .. t + H. From forecast loads, PV yield, carbon intensity and outdoor temperature the
window's building nets without storage, heat-pump and heater COPs and the tanks' limits are rebuilt as
:func:`pipeline.optimal.plant.plant_from_env` builds them from the true series. Prices are the tariff's (known
ahead); outages are not known ahead, so a forecast window has none after t.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from citylearn_env import devices
from citylearn_env.state import END_USE_SLOTS, EndUseParams
from pipeline.optimal.objectives import DAY_STEPS
from pipeline.optimal.plant import Plant, Storage, base_net, tank_storage


def horizon_plant(full: Plant, env, t: int, length: int) -> Plant:
    """The episode plant ``full`` over steps t .. t + ``length`` (step t is the present, already run: its net is
    the env's), its storages starting from the env's states at t; for the daily peak, the window starts
    t mod 24 steps into its day, whose running district peak is the env's so far."""
    stop = t + length + 1
    net = env.district.building_record.net_electricity_consumption
    base = full.base_net[:, t:stop].copy()
    base[:, 0] = net[:, t]
    day_start = t - t % DAY_STEPS
    return dataclasses.replace(
        full, base_net=base, price=full.price[:, t:stop], carbon=full.carbon[:, t:stop],
        outage=full.outage[:, t:stop], surplus=full.surplus[:, t:stop],
        storages=tuple(_window(s, env, t, length) for s in full.storages), day_offset=t % DAY_STEPS,
        peak_floor=float(net[:, day_start:t + 1].sum(axis=0).max()), episode_steps=full.steps)


def _window(s: Storage, env, t: int, length: int) -> Storage:
    """Storage ``s`` over the controlled steps t + 1 .. t + ``length``, from its state in the env at t."""
    cut = slice(t, t + length)
    d = env.district
    if s.battery is None:
        soc = float(d.end_use(s.end_use).record.storage_soc[s.building, t])
        return dataclasses.replace(s, initial_energy=soc * s.capacity, one_way=s.one_way[cut],
                                   electricity=s.electricity[cut], charge_max=s.charge_max[cut],
                                   discharge_max=s.discharge_max[cut])
    r = d.battery_record
    efficiency, capacity = float(r.efficiency[s.building, t]), float(r.capacity[s.building, t])
    one_way = s.one_way[cut]
    terms = dataclasses.replace(s.battery, one_way_prev=np.concatenate([[np.sqrt(efficiency)], one_way[:-1]]),
                                usable_capacity=np.full(length, capacity), initial_efficiency=efficiency)
    return dataclasses.replace(s, initial_energy=float(r.soc[s.building, t]) * s.capacity, one_way=one_way,
                               electricity=s.electricity[cut], charge_max=s.charge_max[cut],
                               discharge_max=s.discharge_max[cut], battery=terms)


def forecast_plant(window: Plant, env, forecast: Mapping[str, np.ndarray]) -> Plant:
    """``window`` (a :func:`horizon_plant` at t, H controlled steps) with its controlled steps rebuilt from
    ``forecast`` (name -> (B, H), :data:`pipeline.optimal.forecasts.UNCERTAIN`): nets without storage
    (:func:`pipeline.optimal.plant.base_net` over the window's own device parameters), carbon intensity, the
    tanks' COPs and limits; no outage after t."""
    params = {p.name: p for p in window.end_uses}
    demands = {name: forecast[END_USE_SLOTS[name].demand] for name in params}
    cops = {name: device_cop(env, name, forecast["outdoor_dry_bulb_temperature"]) for name in params}
    pv = devices.pv_generation(window.pv_nominal_power[:, None], forecast["solar_generation"])
    base = window.base_net.copy()
    surplus = window.surplus.copy()
    base[:, 1:], surplus[:, 1:] = base_net(forecast["non_shiftable_load"], window.end_uses, demands, cops, pv,
                                           np.zeros(pv.shape, dtype=bool))
    carbon = window.carbon.copy()
    carbon[:, 1:] = forecast["carbon_intensity"]
    outage = window.outage.copy()
    outage[:, 1:] = False
    storages = tuple(s if s.battery is not None else _forecast_tank(s, params[s.end_use], cops, demands)
                     for s in window.storages)
    return dataclasses.replace(window, base_net=base, carbon=carbon, outage=outage, surplus=surplus,
                               storages=storages)


def _forecast_tank(s: Storage, p: EndUseParams, cops: Mapping[str, np.ndarray],
                   demands: Mapping[str, np.ndarray]) -> Storage:
    """Tank ``s`` (of end use ``p``) of a window with its COPs and limits from the forecast, its state kept."""
    fresh = tank_storage(p, s.building, cops[p.name][s.building], demands[p.name][s.building])
    return dataclasses.replace(fresh, initial_energy=s.initial_energy)


def device_cop(env, end_use: str, outdoor_c: np.ndarray) -> np.ndarray:
    """COP (heat pump: Carnot at ``outdoor_c`` [degC], (B, H)) or efficiency (heater) [-] of each building's
    device for ``end_use``, (B, H): the env's own device model (:class:`citylearn_env.district.District`)."""
    devs = [getattr(b, END_USE_SLOTS[end_use].device) for b in env.config.buildings]
    cooling = end_use == "cooling"
    return devices.conversion_table(
        [d.kind for d in devs], [d.efficiency for d in devs],
        [d.target_cooling_temperature if cooling else d.target_heating_temperature for d in devs],
        outdoor_c, cooling=cooling)
