"""The compiled device kernels (citylearn_env/device_kernels.py) give exactly the numbers of the numpy
reference functions (citylearn_env/devices.py), on random inputs around every branch and over whole episodes.

Energies kWh per 1-h step, powers kW, states of charge and efficiencies fractions; one element per building.
"""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env import CityLearnEnv, devices
from citylearn_env.config import DEFAULT_CAPACITY_POWER_CURVE, DEFAULT_POWER_EFFICIENCY_CURVE
from citylearn_env.settings import CITYLEARN_2_1, CITYLEARN_2_5, CORRECTED
from citylearn_env.state import TankParams
from tests.citylearn_env.golden import golden_schema

pytest.importorskip("numba")
from citylearn_env import device_kernels  # noqa: E402

N = 64  # buildings per random draw


@pytest.fixture(scope="module")
def kernels() -> device_kernels.DeviceKernels:
    found = device_kernels.get_kernels()
    assert found is not None
    return found


def _same(a: np.ndarray | None, b: np.ndarray | None) -> None:
    assert (a is None) == (b is None)
    if a is not None:
        np.testing.assert_array_equal(a, b)  # bit for bit (NaN in the same places)


def _tank(rng: np.random.Generator) -> TankParams:
    capacity = rng.choice([0.0, 0.5, 2.0, 7.5], N)
    return TankParams(capacity=capacity, loss_coefficient=rng.uniform(0.0, 0.05, N),
                      one_way_efficiency=np.sqrt(rng.uniform(0.8, 1.0, N)), initial_soc=np.zeros(N),
                      max_input_power=rng.uniform(0.0, 5.0, N), max_output_power=rng.uniform(0.0, 5.0, N))


def _outputs(n: int, count: int) -> tuple[np.ndarray, ...]:
    return tuple(np.full(n, -7.0) for _ in range(count))  # -7: untouched outputs stay recognisable


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("with_tank", [True, False])
def test_serve_end_use_kernel_equals_numpy(kernels, seed, with_tank):
    rng = np.random.default_rng(seed)
    demand = np.where(rng.random(N) < 0.2, 0.0, rng.uniform(0.0, 6.0, N))
    nominal = rng.uniform(0.0, 4.0, N)
    cop = rng.uniform(0.9, 6.0, N)
    # outside an outage every supply is inf; during one some buildings have only the PV left (0 included)
    supply = np.full(N, np.inf) if seed % 2 else np.where(rng.random(N) < 0.5, np.inf, rng.choice([0.0, 1.5], N))
    action = rng.uniform(-1.0, 1.0, N) if seed != 3 else rng.uniform(0.0, 1.0, N)  # seed 3: no tank discharges
    scale = rng.uniform(0.0, 8.0, N)
    soc_prev = rng.uniform(0.0, 1.0, N)
    tank = _tank(rng) if with_tank else None
    args = (demand, nominal, cop, supply, action, scale, soc_prev, tank)
    expected = devices.serve_end_use(*args)
    numpy_out, kernel_out = _outputs(N, 6), _outputs(N, 6)
    device_kernels.serve_end_use_into(numpy_out, *args, kernels=None)
    device_kernels.serve_end_use_into(kernel_out, *args, kernels=kernels)
    for field, a, b in zip(devices.EndUseStep._fields, kernel_out, numpy_out, strict=True):
        _same(a, b)
        value = getattr(expected, field)
        _same(a, value if value is not None else np.full(N, -7.0))


def test_serve_end_use_kernel_may_write_over_the_previous_soc(kernels):
    rng = np.random.default_rng(11)
    tank = _tank(rng)
    soc = rng.uniform(0.0, 1.0, N)
    args = (rng.uniform(0.0, 6.0, N), rng.uniform(0.0, 4.0, N), rng.uniform(0.9, 6.0, N), np.full(N, np.inf),
            rng.uniform(-1.0, 1.0, N), rng.uniform(0.0, 8.0, N))
    expected = devices.serve_end_use(*args, soc.copy(), tank)
    out = _outputs(N, 6)
    out = (out[0], out[1], soc, *out[3:])  # the new SOC written where the previous one is read
    device_kernels.serve_end_use_into(out, *args, soc, tank, kernels=kernels)
    for field, a in zip(devices.EndUseStep._fields, out, strict=True):
        _same(a, getattr(expected, field))


def _battery(rng: np.random.Generator, curves: str) -> devices.BatteryParams:
    if curves == "default":
        power, capacity_power = [DEFAULT_POWER_EFFICIENCY_CURVE] * N, [DEFAULT_CAPACITY_POWER_CURVE] * N
    else:  # random curves of different lengths (padded), with a zero-width segment in some
        def curve(k: int, low: float) -> list[tuple[float, float]]:
            xs = np.sort(rng.uniform(0.0, 1.0, k))
            xs[0] = 0.0
            if rng.random() < 0.3:
                xs[1] = xs[0]
            return [(float(x), float(y)) for x, y in zip(xs, rng.uniform(low, 1.0, k), strict=True)]
        power = [curve(int(rng.integers(2, 6)), 0.8) for _ in range(N)]
        capacity_power = [curve(int(rng.integers(2, 6)), 0.2) for _ in range(N)]
    return devices.BatteryParams(
        capacity=rng.choice([0.0, 4.0, 6.4, 13.5], N), nominal_power=rng.choice([0.0, 3.32, 5.0], N),
        efficiency=rng.uniform(0.85, 0.96, N), loss_coefficient=rng.uniform(0.0, 1e-3, N),
        capacity_loss_coefficient=rng.uniform(0.0, 1e-4, N), depth_of_discharge=rng.uniform(0.7, 1.0, N),
        initial_soc=np.zeros(N), power_efficiency=devices.Curve.from_points(power),
        capacity_power=devices.Curve.from_points(capacity_power))


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("curves", ["default", "random"])
@pytest.mark.parametrize("extrapolate", [False, True])
@pytest.mark.parametrize("from_request", [False, True])
def test_battery_kernel_equals_numpy(kernels, seed, curves, extrapolate, from_request):
    rng = np.random.default_rng(seed)
    battery = _battery(rng, curves)
    energy = rng.uniform(-8.0, 8.0, N)
    energy[::7] = 0.0
    soc_prev = rng.uniform(0.0, 1.0, N)
    booked = np.where(rng.random(N) < 0.5, 0.0, rng.uniform(0.0, 2.0, N))
    efficiency_prev = rng.uniform(0.8, 0.96, N)
    capacity_prev = np.where(rng.random(N) < 0.1, 0.0, battery.capacity * rng.uniform(0.9, 1.0, N))
    args = (energy, soc_prev, booked, battery, efficiency_prev, capacity_prev)
    flags = {"extrapolate_first_segment": extrapolate, "efficiency_from_request": from_request}
    expected = devices.battery_charge(*args, **flags)
    numpy_out, kernel_out = _outputs(N, 4), _outputs(N, 4)
    device_kernels.battery_charge_into(numpy_out, *args, kernels=None, **flags)
    device_kernels.battery_charge_into(kernel_out, *args, kernels=kernels, **flags)
    for a, b, c in zip(kernel_out, numpy_out, expected, strict=True):
        _same(a, c)
        _same(b, c)
    # written over the previous step's SOC, efficiency and capacity (a record column acted on twice)
    soc, efficiency, capacity = soc_prev.copy(), efficiency_prev.copy(), capacity_prev.copy()
    out = (soc, np.empty(N), efficiency, capacity)
    device_kernels.battery_charge_into(out, energy, soc, booked, battery, efficiency, capacity, kernels=kernels,
                                       **flags)
    for a, c in zip(out, expected, strict=True):
        _same(a, c)


def _episode(scenario: str, settings, backend: str) -> tuple[list[np.ndarray], np.ndarray]:
    """A whole episode of random actions: every record field and the rewards."""
    env = CityLearnEnv(golden_schema(scenario), settings=settings)
    env.district.use_backend(backend)
    assert env.district.backend == backend
    env.reset(seed=0)
    if scenario.endswith("outage"):  # the supply-capped branches run
        assert env.district._outage_steps.any()
    rng = np.random.default_rng(7)
    table = rng.uniform(env.action_space.low, env.action_space.high,
                        (env.episode_length - 1, env.action_space.shape[0]))
    rewards = np.array([env.step(a)[1] for a in table])
    return [np.asarray(getattr(r, f)) for r in env.district.records() for f in r.__dataclass_fields__], rewards


@pytest.mark.parametrize(("scenario", "settings"), [
    ("full_random", CITYLEARN_2_1), ("full_random", CITYLEARN_2_5), ("full_random", CORRECTED),
    # the corrected outage draws of this schema give no outage in its month: the legacy ones do
    ("full_random_outage", CITYLEARN_2_1), ("full_random_outage", CITYLEARN_2_5)],
    ids=["2.1", "2.5", "corrected", "outage-2.1", "outage-2.5"])
def test_district_backends_give_the_same_episode(scenario, settings):
    records_numpy, rewards_numpy = _episode(scenario, settings, "numpy")
    records_numba, rewards_numba = _episode(scenario, settings, "numba")
    np.testing.assert_array_equal(rewards_numba, rewards_numpy)
    for a, b in zip(records_numba, records_numpy, strict=True):
        _same(a, b)


def test_unknown_backend_is_refused():
    env = CityLearnEnv(golden_schema("full_random"))
    with pytest.raises(ValueError, match="backend"):
        env.district.use_backend("gpu")


@pytest.mark.parametrize("seed", range(4))
def test_heat_pump_demand_kernel_equals_numpy(kernels, seed):
    rng = np.random.default_rng(seed)
    action = rng.uniform(-0.5, 1.5, N)  # outside 0..1 too: clipped to 0..P
    use = rng.random(N) < 0.7
    action[~use & (rng.random(N) < 0.5)] = np.nan  # an inactive device action
    available = (rng.integers(0, 4, (N, 3)) == 1)[:, 1]  # a strided column, as the episode's (B, T) rows
    args = (action, available, rng.uniform(0.0, 4.0, N), rng.uniform(1.0, 6.0, N), use)
    expected = devices.heat_pump_demand(*args)
    _same(device_kernels.heat_pump_demand(*args, kernels=kernels), expected)
    _same(device_kernels.heat_pump_demand(*args, kernels=None), expected)
    assert np.isnan(expected[~use]).all() and (expected[use & ~available] == 0.0).all()
