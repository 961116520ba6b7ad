"""Array state of all buildings of a district and the per-step order of operations (CityLearn 2.1).

Every quantity is a numpy array with one element per building; a step advances all buildings together.
Order inside a step (per building, expressed with masks): demands (LSTM buildings: from the heat-pump
action) -> battery if it discharges -> for cooling, heating, DHW: device then storage (storage first if it
discharges) -> non-shiftable load -> battery if it charges. During a power outage every draw is capped by
the building's remaining supply (PV minus what was already booked this step) and net consumption is 0.
Energies are kWh per step.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from citylearn_env import devices
from citylearn_env.config import DistrictConfig

END_USES = ("cooling", "heating", "dhw")

#: series recorded every step, (B, T) each; the names of the CityLearn 2.1 building properties
RECORDED = (
    "net_electricity_consumption",
    "cooling_electricity_consumption",
    "heating_electricity_consumption",
    "dhw_electricity_consumption",
    "non_shiftable_load_electricity_consumption",
    "cooling_storage_electricity_consumption",
    "heating_storage_electricity_consumption",
    "dhw_storage_electricity_consumption",
    "electrical_storage_electricity_consumption",
    "cooling_demand",
    "heating_demand",
    "energy_from_cooling_device",
    "energy_from_heating_device",
    "energy_from_dhw_device",
    "energy_to_non_shiftable_load",
    "energy_from_cooling_storage",
    "energy_from_heating_storage",
    "energy_from_dhw_storage",
    "energy_from_electrical_storage",
    "energy_from_cooling_device_to_cooling_storage",
    "energy_from_heating_device_to_heating_storage",
    "energy_from_dhw_device_to_dhw_storage",
    "energy_to_electrical_storage",
    "cooling_storage_soc",
    "heating_storage_soc",
    "dhw_storage_soc",
    "electrical_storage_soc",
    "cooling_storage_energy_balance",
    "heating_storage_energy_balance",
    "dhw_storage_energy_balance",
    "electrical_storage_energy_balance",
    "electrical_storage_efficiency",
    "electrical_storage_capacity",
    "indoor_dry_bulb_temperature",
)


def _stack(values) -> np.ndarray:
    return np.asarray(list(values), dtype=np.float64)


class District:
    """Parameters (B,), full-range series (B, N) and the recorded episode (B, T) of a district."""

    def __init__(self, config: DistrictConfig, *, compat: bool = False):
        self.config, self.compat = config, compat
        b = config.buildings
        self.n = len(b)
        self.names = config.building_names
        names = b[0].series.keys()
        self.series: dict[str, np.ndarray] = {k: np.stack([x.series[k] for x in b]) for k in names}
        s = self.series
        self.p: dict[str, np.ndarray] = {}
        for k in END_USES:
            dev = [getattr(x, f"{k}_device") for x in b]
            tank = [getattr(x, f"{k}_storage") for x in b]
            self.p[f"{k}_nominal_power"] = _stack(d.nominal_power for d in dev)
            self.p[f"{k}_capacity"] = _stack(t.capacity for t in tank)
            self.p[f"{k}_loss"] = _stack(t.loss_coefficient for t in tank)
            self.p[f"{k}_one_way"] = np.sqrt(_stack(t.efficiency for t in tank))
            self.p[f"{k}_initial_soc"] = _stack(t.initial_soc for t in tank)
            self.p[f"{k}_max_in"] = _stack(t.max_input_power for t in tank)
            self.p[f"{k}_max_out"] = _stack(t.max_output_power for t in tank)
            s[f"{k}_device_cop"] = self._conversion(dev, k)
        bat = [x.electrical_storage for x in b]
        self.battery = {
            name: _stack(getattr(x, name) for x in bat)
            for name in ("capacity", "nominal_power", "efficiency", "loss_coefficient",
                         "capacity_loss_coefficient", "depth_of_discharge", "initial_soc")
        }
        for key, attr in (("pe", "power_efficiency_curve"), ("cp", "capacity_power_curve")):
            width = max(len(getattr(x, attr)) for x in bat)
            pad = [list(getattr(x, attr)) + [getattr(x, attr)[-1]] * (width - len(getattr(x, attr))) for x in bat]
            self.battery[f"{key}_x"] = np.array([[pt[0] for pt in c] for c in pad])
            self.battery[f"{key}_y"] = np.array([[pt[1] for pt in c] for c in pad])
            self.battery[f"{key}_slope"] = devices.curve_slopes(self.battery[f"{key}_x"], self.battery[f"{key}_y"])
        nominal = self.battery["nominal_power"]
        self.battery["inverse_nominal_power"] = np.divide(1.0, nominal, out=np.zeros_like(nominal), where=nominal > 0)
        self.pv_nominal_power = _stack(x.pv_nominal_power for x in b)
        s["pv_generation"] = devices.pv_generation(self.pv_nominal_power[:, None], s["solar_generation"])
        # which end uses can ever be non-zero: the others are skipped in the step
        self.live = {
            k: bool((self.p[f"{k}_nominal_power"] > 0).any() or (self.p[f"{k}_capacity"] > 0).any()
                    or (s[f"{k}_demand"] > 0).any())
            for k in END_USES
        }
        self.has_storage = {k: bool((self.p[f"{k}_capacity"] > 0).any()) for k in END_USES}
        self.has_battery = bool((self.battery["capacity"] > 0).any())
        self.dynamics = np.array([x.has_dynamics for x in b])
        self.inf = np.full(self.n, np.inf)
        self.zeros = np.zeros(self.n)  # read-only stand-in: nothing booked on a battery before it runs
        self.zeros.flags.writeable = False

    def _conversion(self, devs, end_use: str) -> np.ndarray:
        """COP (heat pump) or efficiency (heater) of each building's device for ``end_use``, (B, N)."""
        t_out = self.series["outdoor_dry_bulb_temperature"]
        rows = []
        for i, d in enumerate(devs):
            if d.kind == "ElectricHeater":
                rows.append(np.full(t_out.shape[1], d.efficiency))
            elif end_use == "cooling":
                rows.append(devices.carnot_cop_cooling(t_out[i], d.target_cooling_temperature, d.efficiency))
            else:
                rows.append(devices.carnot_cop_heating(t_out[i], d.target_heating_temperature, d.efficiency))
        return np.stack(rows)

    # ------------------------------------------------------------------ episode
    def reset(self, start: int, length: int, outage: np.ndarray) -> None:
        """Start an episode over simulation rows ``start .. start+length-1``; ``outage`` is (B, length) 0/1."""
        self.t = 0
        self.length = length
        self.ep = {k: v[:, start : start + length] for k, v in self.series.items()}
        self.ep["power_outage"] = outage.astype(np.float64)
        self.rec = {k: np.zeros((self.n, length)) for k in RECORDED}
        e, r, p = self.ep, self.rec, self.p
        r["indoor_dry_bulb_temperature"][:] = e["indoor_dry_bulb_temperature"]
        r["cooling_demand"][:] = e["cooling_demand"]
        r["heating_demand"][:] = e["heating_demand"]
        for k in END_USES:
            r[f"{k}_storage_soc"][:, 0] = p[f"{k}_initial_soc"]
            demand = e[f"{k}_demand"][:, 0]
            r[f"energy_from_{k}_device"][:, 0] = demand
            r[f"{k}_electricity_consumption"][:, 0] = demand / e[f"{k}_device_cop"][:, 0]
        r["electrical_storage_soc"][:, 0] = self.battery["initial_soc"]
        r["electrical_storage_efficiency"][:, 0] = self.battery["efficiency"]
        r["electrical_storage_capacity"][:, 0] = self.battery["capacity"]
        nsl = e["non_shiftable_load"][:, 0]
        r["non_shiftable_load_electricity_consumption"][:, 0] = nsl
        r["energy_to_non_shiftable_load"][:, 0] = nsl
        total = nsl + sum(r[f"{k}_electricity_consumption"][:, 0] for k in END_USES)
        net = total - e["pv_generation"][:, 0]
        r["net_electricity_consumption"][:, 0] = np.where(outage[:, 0] > 0, 0.0, net)

    def step(self, actions: Mapping[str, np.ndarray], demand_override: Mapping[str, np.ndarray] | None = None):
        """Advance to t + 1 and apply ``actions`` there (name -> (B,); storage actions as fractions of capacity).

        ``demand_override`` maps ``cooling_demand``/``heating_demand`` to (B,) arrays (NaN = keep the data).
        """
        self.t += 1
        t, e, r = self.t, self.ep, self.rec
        outage = e["power_outage"][:, t] > 0
        in_outage = bool(outage.any())
        pv = e["pv_generation"][:, t]
        total = np.zeros(self.n)

        def flex() -> np.ndarray:
            if not in_outage:
                return self.inf
            return np.where(outage, np.maximum(0.0, pv - total), np.inf)

        battery_action = actions["electrical_storage"]
        first = battery_action < 0
        if in_outage and first.any():
            total += self._battery(t, battery_action, flex(), first)
        for k in END_USES:
            if not self.live[k]:
                continue
            demand = e[f"{k}_demand"][:, t]
            if demand_override is not None and f"{k}_demand" in demand_override:
                demand = np.where(np.isnan(demand_override[f"{k}_demand"]), demand, demand_override[f"{k}_demand"])
                r[f"{k}_demand"][:, t] = demand
            total += self._end_use(k, t, demand, actions[f"{k}_storage"], flex)
        served = np.minimum(e["non_shiftable_load"][:, t], flex())
        r["non_shiftable_load_electricity_consumption"][:, t] = served
        r["energy_to_non_shiftable_load"][:, t] = served
        total += served
        if in_outage:
            total += self._battery(t, battery_action, flex(), ~first)
        else:
            total += self._battery(t, battery_action, self.inf, None)
        r["net_electricity_consumption"][:, t] = np.where(outage, 0.0, total - pv)

    def _end_use(self, k: str, t: int, demand: np.ndarray, action: np.ndarray, flex) -> np.ndarray:
        """Serve end use ``k`` with its device and storage; return the electricity booked (B,).

        Where the storage action is negative the storage discharges first and the device serves the rest;
        otherwise the device serves the demand and the storage charges with the device's remaining power.
        Both cases need one storage call: the discharge request does not depend on the device.
        """
        e, r, p = self.ep, self.rec, self.p
        cop = e[f"{k}_device_cop"][:, t]
        nominal = p[f"{k}_nominal_power"]
        f0 = flex()
        q_max = np.minimum(f0, nominal) * cop
        q_dev = np.minimum(demand, q_max)
        booked = np.maximum(0.0, q_dev / cop)
        if self.has_storage[k]:
            capacity = p[f"{k}_capacity"]
            request = action * capacity
            discharge = action < 0
            f1 = f0 if f0 is self.inf else np.where(f0 == np.inf, np.inf, f0 - booked)
            charge = np.minimum(np.minimum(f1, nominal - booked) * cop, request)
            ask = np.where(discharge, np.maximum(-demand, request), np.minimum(charge, p[f"{k}_max_in"]))
            ask = np.maximum(ask, -p[f"{k}_max_out"])
            soc, bal = devices.storage_charge(r[f"{k}_storage_soc"][:, t - 1], ask, capacity, p[f"{k}_loss"],
                                              p[f"{k}_one_way"])
            from_storage = -np.minimum(bal, 0.0)
            if discharge.any():
                q_dev = np.minimum(demand - from_storage, q_max)
                booked = np.maximum(0.0, q_dev / cop)
            to_storage = np.maximum(bal, 0.0)
            booked = booked + to_storage / cop
            r[f"{k}_storage_soc"][:, t] = soc
            r[f"{k}_storage_energy_balance"][:, t] = bal
            r[f"{k}_storage_electricity_consumption"][:, t] = bal / cop
            r[f"energy_from_{k}_storage"][:, t] = from_storage
            r[f"energy_from_{k}_device_to_{k}_storage"][:, t] = to_storage
        r[f"energy_from_{k}_device"][:, t] = q_dev
        r[f"{k}_electricity_consumption"][:, t] = booked
        return booked

    def _battery(self, t: int, action: np.ndarray, flex: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
        """Charge/discharge the batteries (only where ``mask``); return the electricity booked (B,)."""
        r, bat = self.rec, self.battery
        prev = {"efficiency": r["electrical_storage_efficiency"][:, t - 1],
                "capacity": r["electrical_storage_capacity"][:, t - 1]}
        soc_prev = r["electrical_storage_soc"][:, t - 1]
        request = np.minimum(action * bat["capacity"], flex)
        soc, bal, eff, cap = devices.battery_charge(request, soc_prev, self.zeros, bat, prev,
                                                    compat=self.compat)
        if mask is not None:
            soc = np.where(mask, soc, r["electrical_storage_soc"][:, t])
            bal = np.where(mask, bal, r["electrical_storage_energy_balance"][:, t])
            eff = np.where(mask, eff, r["electrical_storage_efficiency"][:, t])
            cap = np.where(mask, cap, r["electrical_storage_capacity"][:, t])
        r["electrical_storage_soc"][:, t] = soc
        r["electrical_storage_energy_balance"][:, t] = bal
        r["electrical_storage_efficiency"][:, t] = eff
        r["electrical_storage_capacity"][:, t] = cap
        r["electrical_storage_electricity_consumption"][:, t] = bal
        r["energy_from_electrical_storage"][:, t] = -np.minimum(bal, 0.0)
        r["energy_to_electrical_storage"][:, t] = np.maximum(bal, 0.0)
        return bal if mask is None else np.where(mask, bal, 0.0)
