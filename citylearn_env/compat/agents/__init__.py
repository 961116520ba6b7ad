"""Agents with upstream's import paths: :mod:`~.base` (``Agent``, ``BaselineAgent``), :mod:`~.rbc` (``RBC``,
``HourRBC``, ``BasicRBC``, ``OptimizedRBC``, ``BasicBatteryRBC``), :mod:`~.sac` (``SAC`` and its RBC-guided
variants), :mod:`~.marlisa` (``MARLISA``, without information sharing), :mod:`~.q_learning`
(``TabularQLearning``, with :class:`citylearn_env.compat.wrappers.TabularQLearningWrapper`) and :mod:`~.rlc`
(``RLC``); :mod:`~.loading` is what ``env.load_agent()`` runs. Torch is imported when a learning agent is built.
"""
