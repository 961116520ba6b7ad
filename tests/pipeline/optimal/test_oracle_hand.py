"""The oracle's LP on 3-step cases small enough to solve by hand: one building, one storage, the optimum
worked out in the comments (nothing here comes from running the code)."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env.devices import Curve
from pipeline.errors import InputError
from pipeline.optimal.objectives import weights_of
from pipeline.optimal.oracle import solve_plant
from pipeline.optimal.plant import BatteryTerms, Plant, Storage, curve_lines

N = 3  # controlled steps t = 1, 2, 3 after the uncontrolled t = 0


def battery(efficiency: float = 0.81, capacity: float = 10.0, power: float = 5.0) -> Storage:
    """A battery with a flat power-efficiency curve (round trip 0.81, one way 0.9), no standing loss, no fade,
    full depth of discharge, empty at t = 0, full power at every state of charge."""
    terms = BatteryTerms(nominal_power=power, lines=np.array([[1.0, 0.0]]), floor=0.0,
                         efficiency=Curve.from_points([((0.0, efficiency), (1.0, efficiency))]),
                         one_way_prev=np.full(N, np.sqrt(efficiency)), usable_capacity=np.full(N, capacity),
                         capacity_loss=0.0, initial_efficiency=efficiency, extrapolate=False)
    return Storage(building=0, slot="electrical_storage", capacity=capacity, retention=1.0, initial_energy=0.0,
                   one_way=np.full(N, np.sqrt(efficiency)), electricity=np.ones(N), charge_max=np.full(N, power),
                   discharge_max=np.full(N, np.inf), action_scale=capacity, battery=terms)


def plant(storage: Storage, base_net, price) -> Plant:
    base_net, price = np.array([base_net], float), np.array([price], float)
    return Plant(building_names=("B",), base_net=base_net, price=price, carbon=np.zeros_like(price),
                 outage=np.zeros(price.shape, bool), surplus=np.zeros_like(price), storages=(storage,))


# Net consumption without storage [kWh] at t = 0..3: 1 at t = 0, a PV surplus of 3 at t = 1, then 2 and 4.
NET = [1.0, -3.0, 2.0, 4.0]
PRICE = [0.1, 0.1, 0.1, 0.5]  # $/kWh; cheap until t = 3


def test_cost_battery_by_hand():
    # Every kWh the battery delivers at t = 3 saves 0.5 $ and needs 1 / 0.81 kWh charged at 0.1 $ or less, so the
    # battery covers all 4 kWh of t = 3 (more would be exported for nothing): it stores 4 / 0.9 = 4.444 kWh, that
    # is 4 / 0.81 = 4.938 kWh charged (within 5 kW per step and 10 kWh). The first 3 kWh come from the PV surplus
    # of t = 1 for free; the other 4 / 0.81 - 3 kWh are bought at 0.1 $ (t = 1 or t = 2). Cost =
    # t = 0: 1 x 0.1 + t = 2: (2 + 4 / 0.81 - 3) x 0.1 + t = 3: 0 = 0.1 + 0.1 x (4 / 0.81 - 1).
    result = solve_plant(plant(battery(), NET, PRICE), "cost")
    assert result.value == pytest.approx(0.1 + 0.1 * (4 / 0.81 - 1), rel=1e-6)
    assert result.baseline["cost"] == pytest.approx(0.1 + 0.2 + 2.0)  # no storage: 1 x 0.1 + 2 x 0.1 + 4 x 0.5
    assert result.schedule.energy[0, 3] == pytest.approx(-4.0, abs=1e-6)  # discharges 4 kWh at t = 3
    assert result.path_error == pytest.approx(0.0, abs=1e-9)  # a flat curve: the efficiencies are right at once


def test_consumption_battery_by_hand():
    # Grid import only: charging from the grid loses 1 - 0.81 of every kWh, so only the free PV surplus of t = 1
    # is stored: 3 kWh charged, 2.7 kWh held, 2.43 kWh delivered at t = 2 or 3. Import = 1 + 0 + 2 + 4 - 2.43.
    result = solve_plant(plant(battery(), NET, PRICE), "consumption")
    assert result.value == pytest.approx(7.0 - 3 * 0.81, rel=1e-6)


def test_average_daily_peak_battery_by_hand():
    # One (partial) day of T = 4 steps: the objective is max_t(net) x 24 / 4. The battery charges at t = 1 up to
    # the level L (c1 = L + 3) and shaves t = 2 and t = 3 down to L (discharges 2 - L and 4 - L); t = 0 (1 kWh) is
    # below L. The energy balance 0.81 (L + 3) = (2 - L) + (4 - L) gives L = 3.57 / 2.81 = 1.2705 (c1 = 4.27 kWh,
    # within 5 kW). Objective = 6 L.
    result = solve_plant(plant(battery(), NET, PRICE), "average_daily_peak")
    level = 3.57 / 2.81
    assert result.value == pytest.approx(6 * level, rel=1e-6)
    assert result.schedule.net.max() == pytest.approx(level, rel=1e-6)


def test_district_peak_counts_buildings_without_storage():
    # A second building without storage adds 3 kWh at t = 3: district net 1, -3, 2, 7. Shaving t = 3 down to a
    # level L >= 2 (t = 2's net) needs 7 - L delivered there. The battery charges at t = 1 at most 5 kWh (its power;
    # the district net there, -3 + 5 = 2, stays below L) and at t = 2 at most L - 2 (up to the level), and
    # delivers 0.81 of it: 7 - L = 0.81 (5 + L - 2), so L = (7 - 2.43) / 1.81 = 2.525 (>= 2 as assumed; a level
    # below 2 would need 9 - 2 L > 4.05 kWh from at most 5 kWh charged). Objective = 24 / 4 x L.
    two = plant(battery(), NET, PRICE)
    two = Plant(building_names=("A", "B"), base_net=np.vstack([two.base_net, [0.0, 0.0, 0.0, 3.0]]),
                price=np.vstack([two.price] * 2), carbon=np.zeros((2, 4)), outage=np.zeros((2, 4), bool),
                surplus=np.zeros((2, 4)), storages=two.storages)
    result = solve_plant(two, "average_daily_peak")
    assert result.value == pytest.approx(6 * (7 - 0.81 * 3) / 1.81, rel=1e-6)


def test_cost_tank_by_hand():
    # A DHW tank of 6 kWh losing 10 % of its content per step (retention 0.9), efficiency 1, serving demands
    # D = 1, 1, 3 kWh at t = 1..3 with a heater of COP 4, 2, 2 and 2 kW: without the tank the device draws
    # D / COP = 0.25, 0.5, 1.5 kWh. Charging is capped by the heater's headroom 2 x COP - D = 7, 3, 1 kWh and
    # discharging by the demand. Price 1 $/kWh throughout, so cost = electricity.
    # A thermal kWh charged at t = 1 costs 1/4 $ and delivers 0.9 kWh at t = 2 (saving 0.9 / 2 = 0.45 $) or 0.81
    # kWh at t = 3 (saving 0.405 $): both worth it; charging at t = 2 costs 1/2 $ and saves 0.9 / 2 = 0.45 $ at
    # t = 3: not worth it. So the tank charges 1 / 0.9 + 3 / 0.81 = 4.815 kWh at t = 1 (under 7 kWh and 6 kWh)
    # and covers t = 2 and t = 3 entirely; at t = 1 the heater serves its own demand too. Cost = t = 0 (0.5) +
    # t = 1 (1 + 4.815) / 4 + t = 2 0 + t = 3 0.
    demand, cop = np.array([1.0, 1.0, 3.0]), np.array([4.0, 2.0, 2.0])
    tank = Storage(building=0, slot="dhw_storage", capacity=6.0, retention=0.9, initial_energy=0.0,
                   one_way=np.ones(N), electricity=1.0 / cop, charge_max=2.0 * cop - demand, discharge_max=demand,
                   action_scale=6.0)
    result = solve_plant(plant(tank, [0.5, *(demand / cop)], [1.0] * 4), "cost")
    assert result.value == pytest.approx(0.5 + (1 + 1 / 0.9 + 3 / 0.81) / 4, rel=1e-6)
    assert result.baseline["cost"] == pytest.approx(0.5 + 0.25 + 0.5 + 1.5)


def test_weighted_sum_of_by_hand_objectives():
    # 0.1 x cost + consumption: a kWh bought for the battery costs 0.1 x 0.1 + 1 = 1.01 and its 0.81 kWh save at
    # most 0.81 x (0.1 x 0.5 + 1) = 0.85 at t = 3, so only the free PV surplus is stored (the consumption
    # optimum); its 2.43 kWh save 1.05 each at t = 3 against 1.01 at t = 2, so they all go to t = 3:
    # cost = 0.1 (t = 0) + 0.2 (t = 2) + 0.5 x (4 - 2.43) (t = 3).
    result = solve_plant(plant(battery(), NET, PRICE), {"cost": 0.1, "consumption": 1.0})
    assert result.objectives["consumption"] == pytest.approx(7.0 - 3 * 0.81, rel=1e-6)
    assert result.objectives["cost"] == pytest.approx(0.1 + 0.2 + 0.5 * (4 - 2.43), rel=1e-6)
    assert result.value == pytest.approx(0.1 * result.objectives["cost"] + result.objectives["consumption"])


def test_objective_names_are_checked():
    with pytest.raises(InputError, match="discomfort is not a storage objective"):
        weights_of("discomfort")
    with pytest.raises(InputError, match="known: cost, emissions"):
        weights_of({"price": 1.0})
    with pytest.raises(InputError, match="not all 0"):
        weights_of({"cost": 0.0})


def test_curve_lines_are_exact_for_a_concave_curve():
    # CityLearn's default capacity-power curve: 1.0 up to SOC 0.8, then down to 0.2 at SOC 1.0 (slope -4):
    # the minimum of its two lines, y = 1 and y = 4.2 - 4 x, is the curve itself.
    lines = curve_lines(np.array([0.0, 0.8, 1.0]), np.array([1.0, 1.0, 0.2]))
    soc = np.linspace(0.0, 1.0, 11)
    curve = np.interp(soc, [0.0, 0.8, 1.0], [1.0, 1.0, 0.2])
    assert (lines[:, :1] + lines[:, 1:] * soc).min(axis=0) == pytest.approx(curve)
