"""The surrogate trainer is deterministic when other work shares the process: the build trains houses two at a
time in Prefect's thread pool, and torch's global random state is one per process. A training seeded with
``torch.manual_seed`` could draw its initial weights after another thread re-seeded or drew from that state
(one house of the default district came out different between two builds)."""

from __future__ import annotations

import threading

import pytest
import torch

from surrogates.config import TrainConfig
from surrogates.model import LSTMModel, seeded_model
from surrogates.sources.fmu import simulate_ilv_fmu
from surrogates.train import train_surrogate
from tests.surrogates.fmu.build import VARIABLE_MAP, synthetic_house

TINY = TrainConfig(epochs=2, pretrain_steps=20, chunk_hours=24, validation_hours=120, hidden_size=8,
                   progress=False)


@pytest.fixture(scope="module")
def table(room_fmu):
    house = synthetic_house(room_fmu, days=21, t_mean=6.0)
    return simulate_ilv_fmu(room_fmu, house, VARIABLE_MAP, n_partial=4, seed=0, start_values={"T0": 22.0})


def same_weights(a: torch.nn.Module, b: torch.nn.Module) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return list(sa) == list(sb) and all(torch.equal(sa[k], sb[k]) for k in sa)


@pytest.mark.parametrize("shape", [(12, 16, 2, 0), (11, 8, 1, 7), (14, 32, 3, 123)])
def test_seeded_model_is_the_default_init_without_the_global_stream(shape):
    *size, seed = shape
    torch.manual_seed(seed)
    reference = LSTMModel(*size)
    torch.manual_seed(99)
    state = torch.get_rng_state()
    model = seeded_model(*size, seed)
    assert torch.equal(torch.get_rng_state(), state)  # neither drew from nor re-seeded the global stream
    assert same_weights(model, reference)  # bit-identical to torch.manual_seed(seed); LSTMModel(...)
    window = torch.rand(2, 3, size[0])
    assert torch.equal(model(window)[0], reference(window)[0])


def test_training_leaves_the_global_random_state_alone(table):
    torch.manual_seed(5)
    state = torch.get_rng_state()
    first = train_surrogate(table, TINY)
    assert torch.equal(torch.get_rng_state(), state)
    torch.manual_seed(6)  # another global state: the same model
    assert same_weights(train_surrogate(table, TINY).model, first.model)


def test_training_alongside_a_thread_using_the_global_stream(table):
    alone = train_surrogate(table, TINY).model
    stop = threading.Event()

    def other_work():  # another task of the pool, seeding and drawing from torch's global stream
        while not stop.is_set():
            torch.manual_seed(0)
            torch.rand(64)

    other = threading.Thread(target=other_work, daemon=True)
    other.start()
    try:
        busy = [train_surrogate(table, TINY).model for _ in range(3)]
    finally:
        stop.set()
        other.join()
    assert all(same_weights(model, alone) for model in busy)


def test_cpu_seconds_count_the_training_thread_only(table):
    """The build's timings record each house's training CPU; another thread's work in the same process (here
    numpy products, which run outside the GIL) is not this training's cost. A single thread cannot use more
    CPU time than the wall time it ran."""
    import numpy as np

    stop = threading.Event()

    def other_work():
        a = np.random.default_rng(0).random((400, 400))
        while not stop.is_set():
            a = a @ a
            a /= np.abs(a).max()

    other = threading.Thread(target=other_work, daemon=True)
    other.start()
    try:
        trained = train_surrogate(table, TINY)
    finally:
        stop.set()
        other.join()
    assert 0 < trained.cpu_seconds <= trained.seconds * 1.05 + 0.05
