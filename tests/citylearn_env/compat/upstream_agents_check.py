"""Upstream CityLearn 2.1.2's SAC and TabularQLearning against citylearn_env.compat's, on the same compat
environment (one building of 2022 phase 1, central agent), seeded alike. Run with a Python that has
``citylearn==2.1.2`` installed and this repository on PYTHONPATH: ``python upstream_agents_check.py <end step>``;
prints one JSON line per agent. Upstream's unseeded draws (its action-space samples, the global ``random`` module
of its replay buffer) are seeded as the compat agents seed theirs."""

from __future__ import annotations

import json
import os
import random
import sys

import numpy as np
import torch

SEED = 0
DATA = "/work/shared/data/citylearn/upstream"
SAC_KW = dict(hidden_dimension=[32, 32], batch_size=32, standardize_start_time_step=40, end_exploration_time_step=60)


def env(end: int, **kwargs):
    from citylearn_env.compat.citylearn import CityLearnEnv

    return CityLearnEnv("citylearn_challenge_2022_phase_1", central_agent=True, buildings=["Building_1"],
                        simulation_end_time_step=end, random_seed=SEED, **kwargs)


def run_sac(kind: str, end: int) -> tuple:
    e = env(end)
    if kind == "upstream":
        from citylearn.agents.sac import SAC

        e.action_space[0].seed(SEED)  # upstream samples the environment's space
        random.seed(SEED)  # upstream's minibatches come from the global random module
    else:
        from citylearn_env.compat.agents.sac import SAC
    agent = SAC(e, **SAC_KW)
    nets = (agent.policy_net[0], agent.soft_q_net1[0])
    initial = [p.detach().clone() for net in nets for p in net.parameters()]
    agent.learn(episodes=2, deterministic_finish=True)
    actions = np.array([np.asarray(x, dtype=np.float64) for x in agent.actions[0] if len(x)])
    final = [p.detach().clone() for p in agent.policy_net[0].parameters()]
    encoded = agent.get_encoded_observations(0, e.observations[0])
    return initial, actions, final, encoded, e.evaluate()["value"].to_numpy(float)


def run_q(kind: str, end: int):
    from citylearn_env.compat.wrappers import TabularQLearningWrapper

    wrapped = TabularQLearningWrapper(env(end, active_observations=["hour"]), observation_bin_sizes=[{"hour": 24}],
                                      action_bin_sizes=[{"electrical_storage": 5}])
    if kind == "upstream":
        from citylearn.agents.q_learning import TabularQLearning

        agent = TabularQLearning(wrapped, epsilon_decay=0.5)
        agent.action_space[0].seed(SEED)  # the agent's own copy of the wrapper's space
    else:
        from citylearn_env.compat.agents.q_learning import TabularQLearning

        agent = TabularQLearning(wrapped, epsilon_decay=0.5)
    agent.learn(episodes=3)
    return agent


def main(end: int) -> None:
    torch.set_num_threads(1)
    os.environ.setdefault("DISTRICTGEN_CITYLEARN_DATA", DATA)
    os.environ.setdefault("DISTRICTGEN_CITYLEARN_VERSION", "2.1")
    up, ours = run_sac("upstream", end), run_sac("ours", end)
    print(json.dumps({
        "sac_initial_weights_equal": all(torch.equal(x, y) for x, y in zip(up[0], ours[0], strict=True)),
        "encoded_obs_equal": bool(np.array_equal(up[3], ours[3])),
        "max_abs_action_diff": float(np.max(np.abs(up[1] - ours[1]))),
        "max_abs_final_policy_weight_diff": max(float((x - y).abs().max()) for x, y in zip(up[2], ours[2],
                                                                                            strict=True)),
        "kpi_max_abs_diff": float(np.nanmax(np.abs(up[4] - ours[4]))),
    }))
    qu, qo = run_q("upstream", end), run_q("ours", end)
    print(json.dumps({
        "q_tables_equal": bool(np.array_equal(qu.q[0], qo.q[0], equal_nan=True)),
        "explore_counts_equal": bool(np.array_equal(qu.q_exploration[0], qo.q_exploration[0])),
        "epsilon": [qu.epsilon, qo.epsilon],
    }))


if __name__ == "__main__":
    main(int(sys.argv[1]))
