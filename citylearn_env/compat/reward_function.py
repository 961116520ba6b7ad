"""Reward functions with upstream's API (mirrors ``citylearn.reward_function`` of CityLearn 2.1).

A reward is an object with ``env_metadata`` (``env.get_metadata()``, set by the environment), ``central_agent``,
``reset()`` (called at every ``env.reset``) and ``calculate(observations) -> list[float]``: ``observations`` is
one mapping per building of every observation name to its raw value at the step (``net_electricity_consumption``
[kWh], ``electricity_pricing`` [$/kWh], ``indoor_dry_bulb_temperature`` [degC] ...); the result holds one value for
a central agent, else one per building.

The classes here compute what the native rewards of :mod:`citylearn_env.rewards` compute (same classes, same
upstream quirks per the environment's settings); the environment runs the native reward directly, with no
per-step conversion, unless a subclass overrides ``calculate``. Then the environment calls that ``calculate``
each step with upstream's list of per-building mappings (read on access).
"""

from __future__ import annotations

import logging
import math
import sys
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from citylearn_env import rewards
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CITYLEARN_2_1, Behaviour

LOGGER = logging.getLogger("citylearn_env.compat")

#: storage slots whose capacity and initial SOC the native rewards read
STORAGES = ("cooling_storage", "heating_storage", "dhw_storage", "electrical_storage")
#: actions whose activity the native rewards read
ACTIONS = (*STORAGES, "cooling_device", "heating_device")


class StackedObservations(Mapping[str, np.ndarray]):
    """Upstream's per-building observation mappings as name -> (B,) array (what native rewards read), stacked
    on access."""

    def __init__(self, observations: Sequence[Mapping[str, float]]) -> None:
        self._observations = list(observations)

    def __getitem__(self, name: str) -> np.ndarray:
        return np.array([float(o[name]) for o in self._observations])

    def __iter__(self) -> Iterator[str]:
        return iter(self._observations[0]) if self._observations else iter(())

    def __len__(self) -> int:
        return len(self._observations[0]) if self._observations else 0


def reward_context(metadata: Mapping[str, Any]) -> rewards.RewardContext:
    """The native :class:`~citylearn_env.rewards.RewardContext` of ``env.get_metadata()``: agent mode, names,
    storage capacities [kWh] and initial SOCs [-], active actions."""
    buildings = metadata["buildings"]

    def column(slot: str, key: str) -> np.ndarray:
        return np.array([float(b[slot][key]) for b in buildings])

    return rewards.RewardContext(
        central_agent=bool(metadata["central_agent"]), building_names=[b["name"] for b in buildings],
        capacity={k: column(k, "capacity") for k in STORAGES}, initial_soc={k: column(k, "initial_soc") for k in STORAGES},
        active_actions={a: np.array([bool(b["action_metadata"].get(a, False)) for b in buildings]) for a in ACTIONS})


class RewardFunction:
    """Base and default reward: per building ``min(-e, 0)`` with e the net electricity consumption [kWh];
    central: ``min(-sum_b e_b, 0)`` on the district net (CityLearn 2.1).

    ``env_metadata`` may be None at construction (the environment sets it); ``kwargs`` are kept as
    ``self.kwargs``. ``compat_settings`` (set by the environment) decides the upstream quirks the built-in
    calculation keeps; it defaults to the CityLearn 2.1 preset.
    """

    #: the native reward type this class computes (:data:`citylearn_env.rewards.REWARDS`)
    native_type: ClassVar[str] = "citylearn.reward_function.RewardFunction"

    def __init__(self, env_metadata: Mapping[str, Any] | None = None, **kwargs: Any) -> None:
        self.env_metadata = env_metadata
        self.kwargs = kwargs
        self.compat_settings: Behaviour = CITYLEARN_2_1
        self._native: tuple[int, Behaviour, Any] | None = None

    @property
    def central_agent(self) -> bool:
        """Whether one agent controls every building (from ``env_metadata``)."""
        if self.env_metadata is None:
            raise RuntimeError(f"{type(self).__name__}: env_metadata is not set (the environment sets it)")
        return bool(self.env_metadata["central_agent"])

    def native_attributes(self) -> dict[str, Any]:
        """The native reward's attributes (the constructor arguments of this class that change its value)."""
        return {}

    def native_spec(self) -> dict[str, Any]:
        """``{"type": ..., "attributes": ...}`` of the native reward computing this reward."""
        return {"type": self.native_type, "attributes": self.native_attributes()}

    def reset(self) -> None:
        """Called by the environment at every ``reset``; the built-in rewards keep no state."""

    def calculate(self, observations: Sequence[Mapping[str, float]]) -> list[float]:
        """The reward of the step from every building's observations: ``[value]`` for a central agent, else one
        value per building."""
        key = (id(self.env_metadata), getattr(self, "compat_settings", CITYLEARN_2_1))
        cached = getattr(self, "_native", None)
        if cached is None or cached[:2] != key:
            native = rewards.make_reward(self.native_spec(), reward_context(self.env_metadata), settings=key[1])
            cached = self._native = (*key, native)
        value, _ = cached[2](StackedObservations(observations))
        return [float(value)] if np.isscalar(value) else [float(v) for v in value]


class MARL(RewardFunction):
    """``sign(-e_b) * 0.01 * e_b^2 * max(0, sum_b e_b)`` per building [kWh^3]; central: the sum."""

    native_type = "citylearn.reward_function.MARL"


class IndependentSACReward(RewardFunction):
    """``min(-e_b^3, 0)`` as intended, or ``min(-e_b, 0)`` with CityLearn 2.1's precedence bug (its preset);
    central: the sum."""

    native_type = "citylearn.reward_function.IndependentSACReward"


class SolarPenaltyReward(RewardFunction):
    """Sum over storages of ``-(1 + sign(e_b) * soc) * |e_b|`` [kWh]; central: the sum."""

    native_type = "citylearn.reward_function.SolarPenaltyReward"


class ComfortReward(RewardFunction):
    """Comfort penalty around the set point with ``band`` [degC] (default 2), ``lower_exponent`` (2) and
    ``higher_exponent`` (3) (:class:`citylearn_env.rewards.ComfortReward`); central: the sum."""

    native_type = "citylearn.reward_function.ComfortReward"

    def __init__(self, env_metadata: Mapping[str, Any] | None = None, band: float | None = None,
                 lower_exponent: float | None = None, higher_exponent: float | None = None, **kwargs: Any) -> None:
        super().__init__(env_metadata, **kwargs)
        self.band = 2.0 if band is None else band
        self.lower_exponent = 2.0 if lower_exponent is None else lower_exponent
        self.higher_exponent = 3.0 if higher_exponent is None else higher_exponent

    def native_attributes(self) -> dict[str, Any]:
        return {"band": self.band, "lower_exponent": self.lower_exponent, "higher_exponent": self.higher_exponent}


class SolarPenaltyAndComfortReward(RewardFunction):
    """``coefficients[0] * SolarPenaltyReward + coefficients[1] * ComfortReward`` (default (1, 1)); ``band`` and
    the exponents as :class:`ComfortReward`."""

    native_type = "citylearn.reward_function.SolarPenaltyAndComfortReward"

    def __init__(self, env_metadata: Mapping[str, Any] | None = None, band: float | None = None,
                 lower_exponent: float | None = None, higher_exponent: float | None = None,
                 coefficients: Sequence[float] | None = None, **kwargs: Any) -> None:
        super().__init__(env_metadata, **kwargs)
        self.comfort = ComfortReward(env_metadata, band, lower_exponent, higher_exponent)
        self.coefficients = (1.0, 1.0) if coefficients is None else tuple(coefficients)

    def native_attributes(self) -> dict[str, Any]:
        return {**self.comfort.native_attributes(), "coefficients": list(self.coefficients)}


class NativeReward(RewardFunction):
    """Any reward of the native registry (:data:`citylearn_env.rewards.REWARDS`) by its type string, e.g. a
    schema's ``"src.reward_function.SignalReward"`` (the SimBuild 2024 classes), with its attributes."""

    def __init__(self, env_metadata: Mapping[str, Any] | None = None, type: str = "default", **attributes: Any) -> None:
        super().__init__(env_metadata)
        if type not in rewards.REWARDS:
            raise SchemaError(f"unknown reward function type {type!r}; known: {', '.join(rewards.REWARDS)}",
                              column="reward_function")
        self.reward_type, self.attributes = type, attributes

    def native_spec(self) -> dict[str, Any]:
        return {"type": self.reward_type, "attributes": dict(self.attributes)}


#: the built-in classes by name
BUILT_IN: dict[str, type[RewardFunction]] = {c.__name__: c for c in (
    RewardFunction, MARL, IndependentSACReward, SolarPenaltyReward, ComfortReward, SolarPenaltyAndComfortReward)}


def computes_natively(reward: Any) -> bool:
    """Whether the environment may compute ``reward`` with its native reward: a compat reward whose class does
    not override ``calculate``."""
    return isinstance(reward, RewardFunction) and type(reward).calculate is RewardFunction.calculate


def reward_from_spec(spec: Mapping[str, Any] | str | None) -> RewardFunction:
    """The compat reward of a schema's ``reward_function`` entry (or a type string; None: the default):

    1. upstream's built-in type strings (``citylearn.reward_function.X``): this module's class;
    2. ``module.Class`` of a module the running program has imported (:func:`program_class`): that class, so
       the program's own reward runs, never a copy of it;
    3. another name of the native registry (:data:`citylearn_env.rewards.REWARDS`): a :class:`NativeReward`,
       with one notice line when the name is a program's module path (the SimBuild ``src.reward_function.*``);
    4. anything else: one SchemaError line. Nothing is ever imported.
    """
    if spec is None:
        return RewardFunction()
    if isinstance(spec, str):
        spec = {"type": spec}
    if not isinstance(spec, Mapping):
        raise SchemaError(f"expected {{\"type\": ..., \"attributes\": ...}} or a type string, got "
                          f"{type(spec).__name__}", column="reward_function")
    name, attributes = spec.get("type"), spec.get("attributes") or {}
    if not isinstance(attributes, Mapping):
        raise SchemaError(f"expected a dict, got {type(attributes).__name__}", column="reward_function.attributes")
    attributes = dict(attributes)
    short = name.rsplit(".", 1)[-1] if isinstance(name, str) else None
    if isinstance(name, str) and name.startswith(("citylearn.reward_function.", "citylearn_env.compat.reward_function.")) \
            and short in BUILT_IN:
        return _built(BUILT_IN[short], name, attributes)
    loaded = program_class(name)
    if loaded is not None:
        return _built(loaded, name, attributes)
    if isinstance(name, str) and name in rewards.REWARDS and "." in name and name.split(".", 1)[0] != "citylearn":
        LOGGER.warning("citylearn_env.compat: reward_function %s: module %s is not imported by the program, so the "
                       "project's copy in citylearn_env.rewards runs (import it first to run yours)",
                       name, name.rsplit(".", 1)[0])
    if isinstance(name, str) and name not in rewards.REWARDS:
        raise SchemaError(f"unknown reward function type {name[:100]!r}: not upstream's, not the project's "
                          f"({', '.join(rewards.REWARDS)}), and not a class the running program has imported (a "
                          "schema never makes the project import code: import its module first, or pass "
                          "reward_function=TheClass)", column="reward_function.type")
    return NativeReward(None, type=name, **attributes)


def _built(cls: type, name: str, attributes: Mapping[str, Any]) -> Any:
    """``cls(None, **attributes)`` (upstream's construction; the environment sets ``env_metadata``)."""
    try:
        reward = cls(None, **attributes)
    except TypeError as error:
        raise SchemaError(f"{name} does not take attributes {sorted(attributes)} ({error})",
                          column="reward_function.attributes") from None
    if cls in BUILT_IN.values():  # numbers the native reward computes with
        for key, value in reward.native_attributes().items():
            values = value if isinstance(value, list) else [value]
            if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values):
                raise SchemaError(f"expected a finite number, got {value!r}", column=f"reward_function.attributes.{key}")
    return reward


def program_class(name: Any) -> type | None:
    """The class a dotted ``name`` ("module.Class") names when the running program has imported (or, as
    ``__main__``, defines) that module and the class has a ``calculate`` method; None otherwise. Nothing is
    imported: only :data:`sys.modules` is read."""
    if not isinstance(name, str) or "." not in name or len(name) > 300:
        return None
    module_name, _, class_name = name.rpartition(".")
    module = sys.modules.get(module_name)
    cls = getattr(module, class_name, None) if module is not None else None
    if isinstance(cls, type) and callable(getattr(cls, "calculate", None)):
        return cls
    return None


def reward_from_keyword(value: Any, kwargs: Mapping[str, Any] | None, schema_spec: Mapping[str, Any] | None) -> Any:
    """The reward object of ``CityLearnEnv(reward_function=value, reward_function_kwargs=kwargs)``: a class (built
    as upstream does, ``cls(None, **kwargs)``), an instance, or a type string (upstream's built-in names, this
    module's, or any native type); None: the schema's entry, its attributes replaced by ``kwargs`` if given."""
    kwargs = dict(kwargs or {})
    if value is None:
        if schema_spec is None or not kwargs:
            return reward_from_spec(schema_spec)
        return reward_from_spec({"type": schema_spec.get("type"), "attributes": kwargs})
    if isinstance(value, str):
        return reward_from_spec({"type": value, "attributes": kwargs})
    if isinstance(value, type):
        return _built(value, value.__name__, kwargs)
    if not callable(getattr(value, "calculate", None)):
        raise SchemaError(f"a reward function needs a calculate(observations) method; got {type(value).__name__}",
                          column="reward_function")
    return value


__all__ = ["BUILT_IN", "MARL", "ComfortReward", "IndependentSACReward", "NativeReward", "RewardFunction",
           "SolarPenaltyAndComfortReward", "SolarPenaltyReward", "StackedObservations", "computes_natively",
           "program_class", "reward_context", "reward_from_keyword", "reward_from_spec"]
