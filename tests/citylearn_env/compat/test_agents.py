"""Upstream's agents behind upstream's import paths (issue 49 item 2): the SAC family, tabular Q-learning and its
wrapper, ``env.load_agent()``, the RLlib wrappers' one-line refusal without ray. Expected numbers are worked by hand
from upstream's documented formulas; runs are one building for a few days, torch on one thread."""

from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from citylearn_env.compat.agents.encoders import (
    Normalize,
    OnehotEncoding,
    PeriodicNormalization,
    RemoveFeature,
    encode,
)
from citylearn_env.compat.agents.loading import agent_class
from citylearn_env.compat.agents.q_learning import TabularQLearning
from citylearn_env.compat.agents.rbc import BasicRBC
from citylearn_env.compat.citylearn import CityLearnEnv
from citylearn_env.compat.wrappers import (
    ClippedObservationWrapper,
    RLlibMultiAgentEnv,
    RLlibSingleAgentWrapper,
    TabularQLearningWrapper,
    mixed_radix,
)
from citylearn_env.errors import SchemaError
from tests.citylearn_env.compat.conftest import PHASE_1, run

torch = pytest.importorskip("torch", reason="torch (the rl extra) is not installed")

WEEK = 167  # one week: 168 time steps


@pytest.fixture(autouse=True)
def one_thread():
    """Torch on one thread (the machine is shared; many threads slow these tiny networks 10x)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def small_env(end: int = WEEK, **kwargs) -> CityLearnEnv:
    kwargs.setdefault("random_seed", 0)
    return CityLearnEnv(PHASE_1, central_agent=True, buildings=["Building_1"], simulation_end_time_step=end, **kwargs)


# CityLearn 2.1.2 keywords: the cache fixture makes these tests CityLearn 2.1 programs
SMALL_SAC = dict(hidden_dimension=[32, 32], batch_size=32, standardize_start_time_step=40, end_exploration_time_step=60)


# ---------------------------------------------------------------------------- encoders
def test_encoders_follow_upstreams_formulas():
    assert np.allclose(PeriodicNormalization(24) * 6, [1.0, 0.5])  # sin(pi/2) = 1 -> 1; cos = 0 -> 0.5
    assert np.allclose(12 * PeriodicNormalization(24), [0.5, 0.0])  # sin(pi) = 0 -> 0.5; cos = -1 -> 0
    assert np.allclose(PeriodicNormalization(24, scaled=False) * 6, [1.0, 0.0])  # CityLearn 2.1.2: sin, cos
    assert list(OnehotEncoding([1, 2, 3, 4, 5, 6, 7, 8]) * 3) == [0, 0, 1, 0, 0, 0, 0, 0]
    assert Normalize(0.0, 10.0) * 2.5 == 0.25
    assert Normalize(4.0, 4.0) * 9.0 == 0
    assert RemoveFeature() * 1.0 is None
    out = encode([PeriodicNormalization(24), RemoveFeature(), Normalize(0.0, 2.0)], [6, 123.0, 1.0])
    assert out.tolist() == [1.0, 0.5, 0.5]


def test_sac_encodes_as_upstream(cache):
    from citylearn_env.compat.agents.sac import SAC

    env = small_env()
    agent = SAC(env, **SMALL_SAC)
    names = env.observation_names[0]
    # hour and month: 2 values each; day_type: 8; daylight_savings_status: 2; net_electricity_consumption: dropped
    width = {"hour": 2, "month": 2, "day_type": 8, "daylight_savings_status": 2, "net_electricity_consumption": 0}
    assert agent.observation_dimension == [sum(width.get(n, 1) for n in names)]
    assert agent.policy_net[0].linear1.in_features == agent.observation_dimension[0]
    # CityLearn 2.1.2's schedule defaults: standardise at the episode length - 1, explore for one episode
    default = SAC(env, hidden_dimension=[8, 8])
    assert (default.standardize_start_time_step, default.end_exploration_time_step) == (WEEK, WEEK + 1)
    assert default.start_training_time_step == WEEK  # one attribute, both names
    # hour and month unscaled (sin, cos) as CityLearn 2.1.2: hour 24 of period 24 -> (0, 1)
    hour = names.index("hour")
    encoded = default.get_encoded_observations(0, [24.0 if n == "hour" else 1.0 for n in names])
    offset = sum(width.get(n, 1) for n in names[:hour])
    assert encoded[offset:offset + 2] == pytest.approx([0.0, 1.0], abs=1e-6)
    # defaults kept where not given
    assert (agent.discount, agent.tau, agent.alpha, agent.lr, agent.reward_scaling, agent.update_per_time_step) == \
        (0.99, 5e-3, 0.2, 3e-4, 5.0, 2)
    assert agent.action_scaling_coefficient == 0.5 and agent.replay_buffer_capacity == 1e5


# ---------------------------------------------------------------------------- SAC
def sac_run(seed: int, episodes: int = 2) -> tuple:
    from citylearn_env.compat.agents.sac import SAC

    env = small_env(end=95, random_seed=seed)
    agent = SAC(env, **SMALL_SAC)
    agent.learn(episodes=episodes, deterministic_finish=True)
    weights = [p.detach().clone() for p in agent.policy_net[0].parameters()]
    return agent, weights, env.episode_rewards


def test_sac_is_deterministic_under_a_seed(cache):
    a, weights_a, rewards_a = sac_run(0)
    b, weights_b, rewards_b = sac_run(0)
    c, weights_c, _ = sac_run(1)
    assert all(torch.equal(x, y) for x, y in zip(weights_a, weights_b, strict=True))
    assert rewards_a == rewards_b
    assert not all(torch.equal(x, y) for x, y in zip(weights_a, weights_c, strict=True))
    # the policy was trained: its weights left their seeded initial values
    assert a.normalized == [True] and len(a.replay_buffer[0]) == 95  # the deterministic last episode pushes none
    initial = sac_run(0, episodes=0)[1]
    assert not all(torch.equal(x, y) for x, y in zip(weights_a, initial, strict=True))


def test_sac_explores_then_uses_its_policy(cache):
    from citylearn_env.compat.agents.sac import SAC

    env = small_env(end=95)
    agent = SAC(env, **SMALL_SAC)
    agent.learn(episodes=1)
    actions = np.array([a for a in agent.actions[0][:95]], dtype=float)
    # exploration: uniform samples of [-1, 1] times 0.5; afterwards the policy's tanh-squashed actions, also in
    # [-0.5, 0.5] (scale 0.5, bias 0)
    assert np.all(np.abs(actions) <= 0.5 + 1e-6)
    assert len({tuple(a) for a in actions[:61]}) == 61


def test_an_upstream_sac_program_runs_unchanged(cache):
    program = """
from citylearn.agents.sac import SAC as Agent
from citylearn.citylearn import CityLearnEnv

env = CityLearnEnv(dataset_name, central_agent=True, buildings=['Building_1'], simulation_end_time_step=71)
model = Agent(env, hidden_dimension=[32, 32], batch_size=32, standardize_start_time_step=30,
              end_exploration_time_step=40)
model.learn(episodes=2, deterministic_finish=True)
kpis = env.evaluate()
"""
    namespace = run(program, dataset_name=PHASE_1)
    assert type(namespace["model"]).__module__ == "citylearn_env.compat.agents.sac"
    assert len(namespace["env"].episode_rewards) == 2
    assert np.isfinite(namespace["kpis"]["value"].dropna()).all()


def test_torch_missing_is_one_line(monkeypatch):
    from citylearn_env.compat.agents.rlc import require_torch

    monkeypatch.setitem(sys.modules, "torch", None)
    with pytest.raises(ModuleNotFoundError, match=r"pip install torch==2\.13\.0 .*districtgen\[rl\]"):
        require_torch()


# ---------------------------------------------------------------------------- tabular Q-learning
def test_tabular_wrapper_enumerates_as_itertools_product():
    radices = [3, 4, 2]
    for position, digits in enumerate(itertools.product(*(range(r) for r in radices))):
        assert mixed_radix(digits, radices) == position


def q_env(cache_unused=None) -> TabularQLearningWrapper:
    env = small_env(end=71, active_observations=["hour"])
    return TabularQLearningWrapper(env, observation_bin_sizes=[{"hour": 24}],
                                   action_bin_sizes=[{"electrical_storage": 5}])


def test_tabular_wrapper_spaces_and_values(cache):
    env = q_env()
    assert env.observation_space[0].n == 25 - 1  # upstream: combinations of 0..24, minus one
    assert env.action_space[0].n == 5
    observations = env.reset()  # the test is a CityLearn 2.1 program (the cache fixture)
    assert observations == [[23]]  # the data set starts at hour 24: the last of 24 bins over [1, 24]
    observations, *_ = env.step([[2]])
    assert observations == [[0]]  # hour 1: the first bin
    # action index i is linspace(low, high, 5)[i]: 4 is the space's upper bound, 2 its midpoint
    box = env.unwrapped.action_space[0]
    discrete = env.env.env  # TabularQLearningActionWrapper -> DiscreteActionWrapper
    assert discrete.action([[4]]) == [[pytest.approx(float(box.high[0]))]]
    assert discrete.action([[2]]) == [[pytest.approx((float(box.low[0]) + float(box.high[0])) / 2)]]
    assert env.env.action([[3]]) == [[3]]  # one action per agent: the combination is the index itself


def test_tabular_q_update_keeps_upstreams_bootstrap(cache):
    agent = TabularQLearning(q_env(), learning_rate=0.5, discount_factor=0.9)
    assert agent.corrected_bootstrap is False  # the CityLearn 2.1 preset: upstream's behaviour
    agent.q[0][:] = np.nan
    agent.q[0][3, :] = [7.0, 2.0, np.nan, 1.0, 0.5]  # best next action: index 0, value 7
    agent.update([[2]], [[1]], [1.0], [[3]], terminated=False, truncated=False)
    assert agent.q[0][2, 1] == pytest.approx(0.0 + 0.5 * (1.0 + 0.9 * 0 - 0.0))  # the index, 0, bootstraps
    agent.corrected_bootstrap = True
    agent.update([[2]], [[1]], [1.0], [[3]], terminated=False, truncated=False)
    assert agent.q[0][2, 1] == pytest.approx(0.5 + 0.5 * (1.0 + 0.9 * 7.0 - 0.5))
    # a next state never visited (all NaN) bootstraps 0
    agent.update([[5]], [[0]], [2.0], [[9]], terminated=False, truncated=False)
    assert agent.q[0][5, 0] == pytest.approx(1.0)


def test_tabular_q_epsilon_decays_per_episode_and_runs_are_seeded(cache):
    runs = []
    for _ in range(2):
        agent = TabularQLearning(q_env(), epsilon_decay=0.5)
        agent.learn(episodes=3)
        runs.append(agent)
    a, b = runs
    # after three episodes of 72 steps: epsilon = max(0.01, 1.0 * exp(-0.5 * episode of the last step = 2))
    assert a.epsilon == pytest.approx(math.exp(-0.5 * 2))
    assert np.array_equal(a.q[0], b.q[0], equal_nan=True)
    assert a.q_exploration[0].sum() + a.q_exploitation[0].sum() == 3 * 71  # 71 steps per episode
    assert np.isfinite(a.q[0]).sum() > 10  # cells were learned


# ---------------------------------------------------------------------------- load_agent
class ProgramAgent(BasicRBC):
    """An agent class the running program defines."""


def test_load_agent_builds_the_schemas_agent(cache):
    env = small_env()
    agent = env.load_agent()
    assert type(agent) is BasicRBC  # phase 1's schema names citylearn.agents.rbc.BasicRBC
    sac = env.load_agent("citylearn.agents.sac.SAC", hidden_dimension=[16, 16], batch_size=8)
    assert sac.hidden_dimension == [16, 16] and sac.batch_size == 8 and sac.discount == 0.99
    own = env.load_agent(f"{__name__}.ProgramAgent")
    assert type(own) is ProgramAgent
    assert type(env.load_agent(ProgramAgent)) is ProgramAgent


def test_load_agent_refuses_unknown_names_in_one_line():
    with pytest.raises(SchemaError, match="not a class the running program has imported"):
        agent_class("my_package_never_imported.Agent")
    with pytest.raises(SchemaError, match="upstream's agent modules"):
        agent_class("citylearn.agents.ppo.PPO")
    assert agent_class("citylearn.agents.q_learning.TabularQLearning") is TabularQLearning


# ---------------------------------------------------------------------------- RLlib
def test_rllib_wrappers_name_the_install_without_ray(cache):
    if _has_ray():
        pytest.skip("ray is installed")
    for cls in (RLlibSingleAgentWrapper, RLlibMultiAgentEnv):
        with pytest.raises(ModuleNotFoundError, match=r"pip install 'ray\[rllib\]'"):
            cls({})


def _has_ray() -> bool:
    import importlib.util

    return importlib.util.find_spec("ray") is not None


def test_clipped_observation_wrapper_keeps_values_in_the_space(cache):
    env = ClippedObservationWrapper(small_env(end=23))
    observations = env.reset()  # a CityLearn 2.1 program (the cache fixture)
    space = env.observation_space[0]
    for _ in range(23):
        assert np.all(np.array(observations[0]) >= space.low) and np.all(np.array(observations[0]) <= space.high)
        observations, *_ = env.step([[0.5]])


# ---------------------------------------------------------------------------- MARLISA
def test_marlisa_compresses_with_pca_and_is_seeded(cache):
    pytest.importorskip("sklearn", reason="scikit-learn (the pipeline extra) is not installed")
    from citylearn_env.compat.agents.marlisa import MARLISA

    runs = []
    for _ in range(2):
        env = CityLearnEnv(PHASE_1, buildings=["Building_1", "Building_2"], simulation_end_time_step=119,
                           random_seed=0)
        agent = MARLISA(env, hidden_dimension=[16, 16], batch_size=40, standardize_start_time_step=30,
                        end_exploration_time_step=90, information_sharing=False, start_regression_time_step=29)
        assert agent.regression_frequency == 2500
        agent.learn(episodes=1)
        runs.append(agent)
    a, b = runs
    assert a.pca_flag == [True, True] and a.regression_flag == [2, 2]
    # transitions are pushed from the second regression update on: time steps 31..119 of 120
    assert len(a.replay_buffer[0]) == 119 - 30
    components = a.pca[0].n_components_
    assert components == a.observation_dimension[0]  # pca_compression 1.0 keeps every component
    assert all(len(t[0]) == components for t in a.replay_buffer[0].buffer)
    assert all(torch.equal(x, y) for x, y in zip(a.policy_net[1].parameters(), b.policy_net[1].parameters(),
                                                  strict=True))
    # CityLearn 2.1.2's default shares information: not mirrored, one line
    with pytest.raises(SchemaError, match="information_sharing=True is not mirrored"):
        MARLISA(CityLearnEnv(PHASE_1, buildings=["Building_1"], simulation_end_time_step=23))
    default = MARLISA(CityLearnEnv(PHASE_1, buildings=["Building_1"], simulation_end_time_step=23),
                      information_sharing=False)
    assert (default.start_regression_time_step, default.hidden_dimension, default.batch_size) == (2, [400, 300], 100)


# ---------------------------------------------------------------------------- against upstream itself
UPSTREAM_PYTHON = Path(os.environ.get("DISTRICTGEN_UPSTREAM_PYTHON", "/work/upstream-venv/bin/python"))


def test_sac_and_q_learning_equal_upstream_2_1_2_bit_for_bit(cache):
    """Upstream CityLearn 2.1.2's SAC and TabularQLearning against these, on the same environment with the same
    seeds (upstream's unseeded generators seeded alike): every action, the trained weights, the Q table and the
    KPIs equal exactly. Needs a separate venv holding citylearn==2.1.2 (docs/compat.md says how it was made)."""
    if not UPSTREAM_PYTHON.exists():
        pytest.skip(f"no upstream CityLearn venv at {UPSTREAM_PYTHON} (set $DISTRICTGEN_UPSTREAM_PYTHON)")
    script = Path(__file__).with_name("upstream_agents_check.py")
    done = subprocess.run([str(UPSTREAM_PYTHON), str(script), "95"], capture_output=True, text=True, timeout=900,
                          env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[3])}, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    sac, q = (json.loads(line) for line in done.stdout.splitlines() if line.startswith("{"))
    assert sac["sac_initial_weights_equal"] and sac["encoded_obs_equal"]
    assert sac["max_abs_action_diff"] == 0.0 and sac["max_abs_final_policy_weight_diff"] == 0.0
    assert sac["kpi_max_abs_diff"] == 0.0
    assert q["q_tables_equal"] and q["explore_counts_equal"] and q["epsilon"][0] == q["epsilon"][1]
