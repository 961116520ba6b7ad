"""The plant's building nets without storage (:func:`pipeline.optimal.plant.base_net`, shared by the episode plant
and the MPC's forecast windows) on cases worked out by hand, and a plant restricted to some buildings."""

from __future__ import annotations

import numpy as np

from citylearn_env.state import EndUseParams, TankParams
from pipeline.optimal.plant import Plant, base_net, tank_storage


def params(name: str, nominal: list[float], cop: float, demand: list[list[float]], live: bool = True,
           capacity: list[float] | None = None) -> EndUseParams:
    """An end use of len(nominal) buildings with a constant ``cop`` and tanks of ``capacity`` [kWh] (0: none)."""
    b = len(nominal)
    capacity = capacity or [0.0] * b
    tank = TankParams(capacity=np.array(capacity), loss_coefficient=np.zeros(b), one_way_efficiency=np.ones(b),
                      initial_soc=np.full(b, 0.5), max_input_power=np.full(b, np.inf),
                      max_output_power=np.full(b, np.inf))
    d = np.array(demand)
    return EndUseParams(name=name, nominal_power=np.array(nominal), cop=np.full(d.shape, cop), demand=d, tank=tank,
                        live=live, has_storage=any(c > 0 for c in capacity))


def test_base_net_by_hand():
    # one building, two steps. Cooling: 2 kW at COP 2 serves at most 4 kWh: demand 2 -> 1 kWh electric,
    # demand 6 -> 4 delivered -> 2 kWh electric (the rest unmet). DHW is not live: its demand costs nothing.
    cooling = params("cooling", [2.0], 2.0, [[2.0, 6.0]])
    dhw = params("dhw", [0.0], 1.0, [[3.0, 3.0]], live=False)
    demands = {"cooling": np.array([[2.0, 6.0]]), "dhw": np.array([[3.0, 3.0]])}
    cops = {"cooling": np.full((1, 2), 2.0), "dhw": np.ones((1, 2))}
    non_shiftable, pv = np.array([[1.0, 1.0]]), np.array([[0.5, 5.0]])
    net, surplus = base_net(non_shiftable, (cooling, dhw), demands, cops, pv, np.array([[False, False]]))
    np.testing.assert_allclose(net, [[1.0 + 1.0 - 0.5, 1.0 + 2.0 - 5.0]])
    np.testing.assert_allclose(surplus, [[0.0, 0.0]])
    # an outage at step 1: the net is 0 there and the PV left after the 3 kWh of loads is 2 kWh
    net, surplus = base_net(non_shiftable, (cooling, dhw), demands, cops, pv, np.array([[False, True]]))
    np.testing.assert_allclose(net, [[1.5, 0.0]])
    np.testing.assert_allclose(surplus, [[0.0, 2.0]])
    np.testing.assert_array_equal(non_shiftable, [[1.0, 1.0]])  # the caller's load is not changed


def test_only_keeps_each_buildings_device_parameters():
    cooling = params("cooling", [1.0, 2.0, 3.0], 2.0, [[1.0], [2.0], [3.0]], capacity=[0.0, 4.0, 6.0])
    zeros = np.zeros((3, 2))
    storages = tuple(tank_storage(cooling, b, np.full(1, 2.0), np.full(1, 1.0)) for b in (1, 2))
    full = Plant(building_names=("a", "b", "c"), base_net=zeros, price=zeros, carbon=zeros,
                 outage=zeros.astype(bool), surplus=zeros, storages=storages, end_uses=(cooling,),
                 pv_nominal_power=np.array([5.0, 6.0, 7.0]))
    part = full.only([2, 0])
    (p,) = part.end_uses
    np.testing.assert_array_equal(p.nominal_power, [3.0, 1.0])
    np.testing.assert_array_equal(p.tank.capacity, [6.0, 0.0])
    np.testing.assert_array_equal(p.demand, [[3.0], [1.0]])
    np.testing.assert_array_equal(part.pv_nominal_power, [7.0, 5.0])
    assert [(s.building, s.capacity, s.end_use) for s in part.storages] == [(0, 6.0, "cooling")]
