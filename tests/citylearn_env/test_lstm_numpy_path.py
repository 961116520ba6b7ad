"""The numpy LSTM path (the plain install's, citylearn_env.lstm_kernels.NumpyGroupStep) against the numba kernel
on random models of several shapes: 1-3 layers (the wavefront's partial first and last waves), lookback 1-12,
inputs in another order (the temperature column differs between models of a group), separate heating models
(non-consecutive active slots) and hvac-mode switches (warm-up restarts, a new set of active slots)."""

from __future__ import annotations

import numpy as np
import pytest

from citylearn_env.dataset import DynamicsBlock
from citylearn_env.dynamics import LSTMBank, LSTMSpec
from citylearn_env.settings import CITYLEARN_2_1, CORRECTED

NAMES = ("direct_solar_irradiance", "outdoor_dry_bulb_temperature", "cooling_demand", "heating_demand",
         "hour_sin", "hour_cos", "day_type_sin", "indoor_dry_bulb_temperature")
BUILDINGS, STEPS = 5, 60


def random_spec(rng: np.random.Generator, hidden: int, layers: int, lookback: int, order: list[int]) -> LSTMSpec:
    """A model with random torch-layout weights and bounds, inputs NAMES in ``order``."""
    names = tuple(NAMES[i] for i in order)
    state = {"l_linear.weight": rng.normal(0, 0.3, (1, hidden)), "l_linear.bias": rng.normal(0, 0.1, 1)}
    for layer in range(layers):
        width = len(names) if layer == 0 else hidden
        state[f"l_lstm.weight_ih_l{layer}"] = rng.normal(0, 0.4, (4 * hidden, width))
        state[f"l_lstm.weight_hh_l{layer}"] = rng.normal(0, 0.4, (4 * hidden, hidden))
        state[f"l_lstm.bias_ih_l{layer}"] = rng.normal(0, 0.2, 4 * hidden)
        state[f"l_lstm.bias_hh_l{layer}"] = rng.normal(0, 0.2, 4 * hidden)
    low = rng.uniform(-1.0, 0.0, len(names))
    high = low + rng.uniform(1.0, 30.0, len(names))
    block = DynamicsBlock("m.pth", names, tuple(low), tuple(high), hidden_size=hidden, num_layers=layers,
                          lookback=lookback)
    return LSTMSpec(state, block)


def run(bank: LSTMBank, rows: list[dict], modes: list[np.ndarray]) -> np.ndarray:
    return np.array([bank.step(row, mode) for row, mode in zip(rows, modes, strict=True)])


@pytest.mark.parametrize(("hidden", "layers", "lookback"), [(16, 2, 12), (8, 1, 5), (6, 3, 4), (16, 2, 1)])
def test_numpy_path_matches_the_numba_kernel(hidden: int, layers: int, lookback: int) -> None:
    pytest.importorskip("numba")
    rng = np.random.default_rng(hidden * 100 + layers * 10 + lookback)
    natural = list(range(len(NAMES)))
    cooling = [random_spec(rng, hidden, layers, lookback, list(rng.permutation(len(NAMES))) if b % 3 == 0
                           else natural) for b in range(BUILDINGS)]
    heating = [random_spec(rng, hidden, layers, lookback, natural) if b % 2 else None for b in range(BUILDINGS)]
    rows = [{"direct_solar_irradiance": rng.uniform(0, 900, BUILDINGS),
             "outdoor_dry_bulb_temperature": rng.uniform(10, 40, BUILDINGS),
             "cooling_demand": rng.uniform(0, 5, BUILDINGS), "heating_demand": rng.uniform(0, 5, BUILDINGS),
             "hour": np.full(BUILDINGS, t % 24 + 1.0), "day_type": np.full(BUILDINGS, t // 24 % 7 + 1.0),
             "indoor_dry_bulb_temperature": rng.uniform(18, 27, BUILDINGS)} for t in range(STEPS)]
    modes = [np.where(rng.uniform(size=BUILDINGS) < (0.5 if t in (25, 40) else 0.0), 2.0, 1.0)
             for t in range(STEPS)]
    for settings, atol in ((CORRECTED, 1e-12), (CITYLEARN_2_1, 1e-5)):  # float32 rounding: ulp(27 degC) ~ 2e-6
        fast = LSTMBank(cooling, heating, settings=settings, backend="numba")
        plain = LSTMBank(cooling, heating, settings=settings, backend="numpy")
        expected, got = run(fast, rows, modes), run(plain, rows, modes)
        assert np.array_equal(np.isnan(got), np.isnan(expected))
        assert not np.isnan(got[-1]).all()
        np.testing.assert_allclose(got, expected, rtol=0, atol=atol)
        np.testing.assert_array_equal(plain.is_warm, fast.is_warm)
        for ours, theirs in zip(plain._groups, fast._groups, strict=True):
            np.testing.assert_array_equal(ours.count, theirs.count)
            np.testing.assert_allclose(ours.h, theirs.h, rtol=0, atol=1e-11)
            np.testing.assert_allclose(ours.c, theirs.c, rtol=0, atol=1e-10)


def test_a_copied_numpy_bank_continues_like_the_original() -> None:
    """copy.deepcopy / pickle of a bank mid-episode (a rollout snapshot, a vector env's worker): the copy's
    numpy step rebuilds its plans (their work arrays are views of each other) and continues identically."""
    import copy
    import pickle

    rng = np.random.default_rng(7)
    spec = random_spec(rng, 8, 2, 4, list(range(len(NAMES))))
    rows = [{name: rng.uniform(0, 1, 2) for name in ("direct_solar_irradiance", "outdoor_dry_bulb_temperature",
                                                      "cooling_demand", "heating_demand", "hour", "day_type",
                                                      "indoor_dry_bulb_temperature")} for _ in range(12)]
    modes = [np.ones(2)] * 12
    bank = LSTMBank([spec, spec], backend="numpy")
    run(bank, rows[:8], modes[:8])
    copies = [copy.deepcopy(bank), pickle.loads(pickle.dumps(bank))]
    expected = run(bank, rows[8:], modes[8:])
    for other in copies:
        np.testing.assert_array_equal(run(other, rows[8:], modes[8:]), expected)
