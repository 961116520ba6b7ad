"""CityLearn 2.1's API over citylearn_env: an upstream program runs after replacing ``citylearn.`` with
``citylearn_env.compat.`` in its imports.

Modules mirror upstream's import paths: :mod:`~citylearn_env.compat.citylearn` (``CityLearnEnv``,
``EvaluationCondition``), :mod:`~citylearn_env.compat.agents.base`, :mod:`~citylearn_env.compat.agents.rbc`,
:mod:`~citylearn_env.compat.wrappers`, :mod:`~citylearn_env.compat.building`,
:mod:`~citylearn_env.compat.energy_model`, :mod:`~citylearn_env.compat.reward_function`,
:mod:`~citylearn_env.compat.base`, :mod:`~citylearn_env.compat.utilities` and :mod:`~citylearn_env.compat.data`
(data-set names, resolved offline through a cache folder). Every object is a thin adapter over the native
:class:`citylearn_env.env.CityLearnEnv`; the default behaviour preset is "citylearn-2.1" (docs/compat.md).
"""
