"""Agents with upstream's import paths: :mod:`citylearn_env.compat.agents.base` (``Agent``, ``BaselineAgent``)
and :mod:`citylearn_env.compat.agents.rbc` (``RBC``, ``HourRBC``, ``BasicRBC``, ``OptimizedRBC``,
``BasicBatteryRBC``). Upstream's learning agents (``citylearn.agents.sac`` ...) are not provided: use
Stable-Baselines3 through :class:`citylearn_env.compat.wrappers.StableBaselines3Wrapper`."""
