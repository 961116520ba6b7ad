"""CityLearn's API over citylearn_env: an upstream program runs after replacing ``citylearn.`` with
``citylearn_env.compat.`` in its imports, with the API and physics of the CityLearn version it was written for
(2.1.2 or 2.5.0; :mod:`~citylearn_env.compat.version`).

Modules mirror upstream's import paths: :mod:`~citylearn_env.compat.citylearn` (``CityLearnEnv``,
``EvaluationCondition``), :mod:`~citylearn_env.compat.agents.base`, :mod:`~citylearn_env.compat.agents.rbc`,
:mod:`~citylearn_env.compat.wrappers`, :mod:`~citylearn_env.compat.building`,
:mod:`~citylearn_env.compat.energy_model`, :mod:`~citylearn_env.compat.reward_function`,
:mod:`~citylearn_env.compat.base`, :mod:`~citylearn_env.compat.utilities` and :mod:`~citylearn_env.compat.data`
(data-set names, resolved offline through a cache folder). Every object is a thin adapter over the native
:class:`citylearn_env.env.CityLearnEnv`; the behaviour preset follows the mirrored version (docs/compat.md).
"""
