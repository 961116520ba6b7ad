"""The oracle's certified lower bound (issue 51): no executable schedule beats it, the best plan is close to it,
and on a one-building case the plan is within 0.1 % of an independent dynamic program that runs the
environment's own battery step (``citylearn_env.devices.battery_charge``) over a grid of states of charge.

The dynamic program knows nothing of the LP: the building's net consumption without storage comes from a
no-control episode of the env, the transitions from the env's battery function, and its schedule's cost is the
env's own when the schedule is replayed as actions. Upstream datasets skip when ../shared is absent.
"""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, devices
from pipeline.controllers import run_episode
from pipeline.optimal import certify
from pipeline.optimal.lp import build
from pipeline.optimal.objectives import weights_of
from pipeline.optimal.optimum import district, optimal
from pipeline.optimal.oracle import group_bound, oracle, solve_plant
from pipeline.optimal.plant import plant_from_env
from pipeline.optimal.relax import efficiency_lines, power_regions, relaxed_plant, upper_hull
from pipeline.optimal.replay import replay
from pipeline.optimal.solver import solve
from pipeline.runners import InProcessRunner
from tests.conftest import SHARED, need_shared

pytest.importorskip("highspy")

UPSTREAM = SHARED / "data" / "citylearn" / "upstream" / "v2.1.2"
PHASE_1 = UPSTREAM / "citylearn_challenge_2022_phase_1" / "schema.json"
#: states of charge of the dynamic program: 6.4 kWh in steps of 20 Wh
GRID = 321


def one_building(rows: tuple[int, int]) -> CityLearnEnv:
    config = district(PHASE_1, start=rows[0], end=rows[1])
    env = CityLearnEnv(config.with_buildings(config.building_names[:1]))
    env.reset(seed=0)
    return env


def tiled(bat: devices.BatteryParams, m: int) -> devices.BatteryParams:
    """Building 0's battery repeated ``m`` times (one per transition the program tries)."""
    rows = np.zeros(m, dtype=np.intp)

    def curve(c: devices.Curve) -> devices.Curve:
        return devices.Curve(c.xs[rows], c.ys[rows], c.slopes[rows])

    return devices.BatteryParams(
        capacity=bat.capacity[rows], nominal_power=bat.nominal_power[rows], efficiency=bat.efficiency[rows],
        loss_coefficient=bat.loss_coefficient[rows], capacity_loss_coefficient=bat.capacity_loss_coefficient[rows],
        depth_of_discharge=bat.depth_of_discharge[rows], initial_soc=bat.initial_soc[rows],
        power_efficiency=curve(bat.power_efficiency), capacity_power=curve(bat.capacity_power))


def transitions(env: CityLearnEnv) -> tuple[np.ndarray, np.ndarray]:
    """(energy [kWh, device side], reachable) for every move between two grid states, (GRID, GRID): the energy
    is found by bisection on the env's battery step, and a move counts only if that step lands on the target
    (within 1e-7 of capacity) without the env clipping the request."""
    bat = env.district.battery
    capacity, power = float(bat.capacity[0]), float(bat.nominal_power[0])
    soc = np.linspace(0.0, 1.0, GRID)
    start, target = (a.ravel() for a in np.meshgrid(soc, soc, indexing="ij"))
    params = tiled(bat, start.size)
    flag = env.settings.battery_curve_extrapolates_first_segment

    def step(energy: np.ndarray):
        return devices.battery_charge(energy, start, np.zeros_like(energy), params, np.full_like(energy, 0.9),
                                      np.full_like(energy, capacity), extrapolate_first_segment=flag)

    low, high = np.where(target >= start, 0.0, -power), np.where(target >= start, power, 0.0)
    for _ in range(60):  # the stored energy rises with the request: bisection on the request
        mid = (low + high) / 2
        above = step(mid)[0] > target
        high, low = np.where(above, mid, high), np.where(above, low, mid)
    energy = (low + high) / 2
    landed, balance = step(energy)[:2]
    reachable = (np.abs(landed - target) * capacity < 1e-7) & (np.abs(balance - energy) < 1e-9)
    return energy.reshape(GRID, GRID), reachable.reshape(GRID, GRID)


def dynamic_program(env: CityLearnEnv, net: np.ndarray, price: np.ndarray) -> np.ndarray:
    """The cheapest grid path's device-side energies for the controlled steps 1 .. T - 1 (T,) [kWh; 0 at step 0]:
    cost of a step = max(net without storage + energy, 0) x price."""
    energy, reachable = transitions(env)
    steps = net.size
    value = np.zeros(GRID)
    choice = np.zeros((steps, GRID), dtype=np.intp)
    for t in range(steps - 1, 0, -1):
        cost = np.maximum(net[t] + energy, 0.0) * price[t] + value[None, :]
        cost[~reachable] = np.inf
        choice[t] = cost.argmin(axis=1)
        value = cost[np.arange(GRID), choice[t]]
    state = int(round(float(env.district.battery.initial_soc[0]) * (GRID - 1)))
    plan = np.zeros(steps)
    for t in range(1, steps):
        nxt = choice[t, state]
        plan[t], state = energy[state, nxt], nxt
    return plan


def env_cost(env: CityLearnEnv, plan: np.ndarray) -> float:
    """The env's cost of the device-side energies ``plan`` (T,), sent as actions (energy / capacity)."""
    scale = float(env.district.battery.capacity[0])
    steps = iter(plan[1:] / scale)
    run_episode(env, lambda _: np.array([next(steps)]), 0)
    return float(env.objectives()["cost"])


def test_plan_is_within_a_tenth_of_a_percent_of_a_dynamic_program():
    need_shared(PHASE_1)
    env = one_building((312, 359))
    assert list(env.action_pairs) == [("electrical_storage", 0)]
    run_episode(env, lambda _: np.zeros(1), 0)  # no control: the net consumption without storage
    net = np.asarray(env.district.building_record.net_electricity_consumption[0, :env.episode_length], float)
    price = np.asarray(env.data("electricity_pricing")[0], float)
    dp = env_cost(env, dynamic_program(env, net, price))
    env.reset(seed=0)
    result = oracle(env, "cost")
    assert float((np.maximum(net, 0) * price).sum()) > dp  # the battery is worth something here
    assert result.value <= dp * 1.001
    assert result.bound <= dp  # certified: the DP's executed schedule does not beat it
    assert result.bound <= result.value


@pytest.mark.parametrize("rows", [(312, 719), (0, 719)])
def test_bound_is_below_the_replayed_plan_and_near_it(rows):
    need_shared(PHASE_1)
    result = optimal(PHASE_1, "cost", *rows, quiet=True, certify=0.0)  # the linear relaxation's bound
    assert not result.oracle.exact  # batteries: a bound, not a minimum
    assert result.bound < result.value < result.oracle.baseline["cost"]
    assert result.gap < 0.025
    assert "certified lower bound" in result.summary() and "minimum" not in result.summary()


def test_power_range_choice_tightens_the_bound_below_the_dynamic_program():
    # the same 48 steps: with every step's charge and discharge power range a choice (pipeline.optimal.certify)
    # the bound rises above the linear relaxation's, yet stays below the cost of the DP's executed schedule (the
    # DP knows nothing of either); the gap to the plan falls under the 0.5 %
    need_shared(PHASE_1)
    env = one_building((312, 359))
    run_episode(env, lambda _: np.zeros(1), 0)
    net = np.asarray(env.district.building_record.net_electricity_consumption[0, :env.episode_length], float)
    price = np.asarray(env.data("electricity_pricing")[0], float)
    dp = env_cost(env, dynamic_program(env, net, price))
    env.reset(seed=0)
    linear = oracle(env, "cost")
    tight = oracle(env, "cost", certify=60.0)
    assert linear.bound < tight.bound <= min(dp, tight.value)
    assert (tight.value - tight.bound) / tight.bound <= 0.005


def test_blocks_with_the_relaxation_duals_sum_to_the_relaxation():
    # Lagrangian decoupling priced by the LP's own duals: the blocks' LP optima add up to the LP's (duality),
    # so a block solved with the power-range choice can only raise the bound
    need_shared(PHASE_1)
    env = one_building((312, 407))
    plant = plant_from_env(env)
    lp = build(relaxed_plant(plant), weights_of("cost"), relaxed=True)
    solution = solve(lp)
    blocks = certify._Blocks(lp, solution.row_dual)
    assert blocks.count == 4
    total = sum(certify._lp_value(blocks.program(b)) for b in range(blocks.count)) + lp.constant
    assert total == pytest.approx(solution.objective, rel=1e-7)


def test_power_regions_split_where_the_curve_rises():
    # the default curve rises from 0.83 at 0.3 to 0.9 at 0.7: ranges [0, 0.3], [0.3, 0.5] (the rising piece's
    # middle), [0.5, top]; a curve that only falls offers no choice; the lines of a range hold on it
    curve = devices.Curve.from_points([((0.0, 0.83), (0.3, 0.83), (0.7, 0.9), (0.8, 0.9), (1.0, 0.85))])
    assert power_regions(curve, 1.0) == pytest.approx([0.0, 0.3, 0.5, 1.0])
    falling = devices.Curve.from_points([((0.0, 0.95), (1.0, 0.9))])
    assert power_regions(falling, 1.0) == pytest.approx([0.0, 1.0])
    store, remove = efficiency_lines(curve, 0.5, xmin=0.3)
    x = np.linspace(0.3, 0.5, 200_001)
    eff = np.interp(x, curve.xs[0], curve.ys[0])
    assert np.all(x * np.sqrt(eff) <= (store[:, :1] * x + store[:, 1:]).min(axis=0))
    assert np.all(x / np.sqrt(eff) >= (remove[:, :1] * x + remove[:, 1:]).max(axis=0))
    # tighter than the whole range's chord at the rising piece's middle (0.4)
    whole = efficiency_lines(curve, 1.0)[0]
    assert (store[:, 0] * 0.4 + store[:, 1]).min() < (whole[:, 0] * 0.4 + whole[:, 1]).min() - 1e-3


def test_tank_only_lp_is_exact():
    # citylearn_challenge_2020_climate_zone_1 with its cooling and DHW tanks only (batteries inactive): the LP is
    # the env's problem, the bound equals the plan, and the summary says "minimum"
    schema = UPSTREAM / "citylearn_challenge_2020_climate_zone_1" / "schema.json"
    need_shared(schema)
    config = district(schema, start=0, end=167)
    config = config.with_actions(["cooling_storage", "dhw_storage"])
    env = CityLearnEnv(config)
    env.reset(seed=0)
    result = oracle(env, "emissions")
    assert result.exact
    assert result.bound == pytest.approx(result.value, rel=1e-6)


def test_efficiency_lines_hold_everywhere_and_hug_a_flat_curve():
    # CityLearn's default power-efficiency curve: x sqrt(eff) below the store lines and x / sqrt(eff) above the
    # remove lines at a million points; a flat curve (0.81) gives the one line 0.9 x and 1 / 0.9 x
    curve = devices.Curve.from_points([((0.0, 0.83), (0.3, 0.83), (0.7, 0.9), (0.8, 0.9), (1.0, 0.85))])
    store, remove = efficiency_lines(curve, 1.0)
    x = np.linspace(0.0, 1.0, 1_000_001)
    eff = np.interp(x, curve.xs[0], curve.ys[0])
    assert np.all(x * np.sqrt(eff) <= (store[:, :1] * x + store[:, 1:]).min(axis=0))
    assert np.all(x / np.sqrt(eff) >= (remove[:, :1] * x + remove[:, 1:]).max(axis=0))
    # at 0.8 of nominal power the hull touches the curve's best point, 0.8 x sqrt(0.9), but for the shift that
    # makes the lines hold between their samples (12 per piece: (1/60)^2 / 8 x |phi''| < 2e-5 on [0.8, 1])
    assert (store[:, 0] * 0.8 + store[:, 1]).min() == pytest.approx(0.8 * np.sqrt(0.9), abs=2e-5)
    flat = devices.Curve.from_points([((0.0, 0.81), (1.0, 0.81))])
    store, remove = efficiency_lines(flat, 1.0)
    assert store.shape == remove.shape == (1, 2)
    assert store[0] == pytest.approx([0.9, 0.0], abs=1e-9) and remove[0] == pytest.approx([1 / 0.9, 0.0], abs=1e-9)


def test_upper_hull_of_a_few_points():
    # points (0, 0), (1, 2), (2, 1), (3, 3): the hull runs (0, 0) -> (1, 2) -> (3, 3); (2, 1) lies below
    lines = upper_hull(np.array([0.0, 1.0, 2.0, 3.0]), np.array([0.0, 2.0, 1.0, 3.0]))
    assert lines == pytest.approx(np.array([[2.0, 0.0], [0.5, 1.5]]))


def test_lockstep_peak_plan_replays_and_its_bound_is_the_joint_relaxation():
    # citylearn_challenge_2022_phase_all's first 3 buildings (batteries that are scaled copies), one week, the
    # district peak: the merged plan runs in the env as planned, and the merged battery's relaxation has the
    # joint relaxation's optimum (a separate LP over the 3 batteries)
    schema = UPSTREAM / "citylearn_challenge_2022_phase_all" / "schema.json"
    need_shared(schema)
    config = district(schema, start=0, end=167)
    env = CityLearnEnv(config.with_buildings(config.building_names[:3]))
    env.reset(seed=0)
    plant = plant_from_env(env)
    merged = solve_plant(plant, "average_daily_peak", lockstep=True)
    assert merged.size[0] < solve_plant(plant, "average_daily_peak", lockstep=False, bound=False).size[0]
    joint_bound, _ = group_bound(plant, weights_of("average_daily_peak"))
    assert merged.bound == pytest.approx(joint_bound, rel=1e-6)
    assert merged.bound < merged.value < merged.baseline["average_daily_peak"]
    played = replay(env, merged.schedule)
    assert abs(played.gap["average_daily_peak"]) < 1e-4


def test_groups_mapped_on_a_runner_give_the_same_plan():
    need_shared(PHASE_1)
    env = CityLearnEnv(district(PHASE_1, start=312, end=359))
    env.reset(seed=0)
    here = oracle(env, "cost")
    mapped = oracle(env, "cost", runner=InProcessRunner())
    # the bound is an LP optimum (one value); the plans are local optima reached from other warm starts (in one
    # process each building starts from the previous one's basis, on a runner each call starts cold)
    assert mapped.bound == pytest.approx(here.bound, rel=1e-7)
    assert mapped.value == pytest.approx(here.value, rel=1e-4)
