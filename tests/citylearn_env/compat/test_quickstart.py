"""CityLearn 2.4.2's documented quickstart (a CityLearn 2.2+ program: gymnasium's API), written the upstream way and
run unchanged but for its imports on the v2.4.2 data set; every reward, observation and KPI equal to the native
environment's run with the same actions under the CityLearn 2.5 preset."""

from __future__ import annotations

import numpy as np
import pandas as pd

from citylearn_env import kpis
from citylearn_env.compat.version import VERSION_VAR
from tests.citylearn_env.compat.conftest import PHASE_1, native_env, port, replay, run

QUICKSTART = """
from citylearn.agents.base import Agent
from citylearn.citylearn import CityLearnEnv

env = CityLearnEnv(dataset_name, central_agent=True, simulation_end_time_step=1000)
model = Agent(env)

observations, _ = env.reset()

while not env.terminated:
    actions = model.predict(observations)
    observations, reward, info, terminated, truncated = env.step(actions)

kpis = model.env.evaluate()
kpis = kpis.pivot(index='cost_function', columns='name', values='value').round(3)
kpis = kpis.dropna(how='all')
"""


def test_port_changes_only_the_imports() -> None:
    ported = port(QUICKSTART)
    assert "from citylearn_env.compat.agents.base import Agent" in ported
    assert "from citylearn_env.compat.citylearn import CityLearnEnv" in ported
    assert ported.replace("citylearn_env.compat.", "citylearn.") == QUICKSTART


def test_quickstart_runs_and_equals_the_native_env(cache, monkeypatch) -> None:
    monkeypatch.delenv(VERSION_VAR)  # the name is in both releases: the newest (v2.4.2, CityLearn 2.5) is read
    ns = run(QUICKSTART, dataset_name=PHASE_1)
    assert ns["env"].mirror.version == "2.5" and "all_time_peak_average" in set(ns["kpis"].index)
    env, model = ns["env"], ns["model"]
    assert env.time_step == env.time_steps - 1 == 1000 and env.terminated
    assert isinstance(ns["kpis"], pd.DataFrame) and "District" in ns["kpis"].columns

    actions = [np.asarray(a) for a in model.actions[0][:-1]]  # what the agent chose at t = 0 .. 999
    assert len(actions) == 1000 and all(a.shape == (5,) for a in actions)
    native = native_env(PHASE_1, "citylearn-2.5", "v2.4.2", central_agent=True, simulation_end_time_step=1000)
    rewards, observations = replay(native, actions)

    np.testing.assert_array_equal([r[0] for r in env.rewards[1:]], rewards)
    central = native.layout.central_index
    np.testing.assert_array_equal(ns["observations"][0], observations[-1][central].astype(np.float32))
    pd.testing.assert_frame_equal(env.evaluate(), native.evaluate())
    challenge = env.evaluate_citylearn_challenge()
    native_challenge = kpis.evaluate_challenge(native.series(), native.building_names,
                                               dynamics=list(native.district.dynamics), settings=native.settings)
    assert challenge["average_score"]["value"] == native_challenge["value"].iloc[-1]
    assert challenge["carbon_emissions_total"]["weight"] == 0.10
    summary = env.episode_rewards[-1]
    np.testing.assert_allclose(summary["sum"], [np.float32(rewards).sum()], rtol=1e-6)
