"""Results and per-building reads of the compat environment (mixed into
:class:`citylearn_env.compat.citylearn.CityLearnEnv`): KPIs, metadata, building series and observations, district
series. Everything is read from the native environment when asked for."""

from __future__ import annotations

from enum import Enum
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from citylearn_env import kpis
from citylearn_env.compat.building import Building, BuildingObservations
from citylearn_env.compat.reward_function import NativeReward
from citylearn_env.errors import SchemaError
from citylearn_env.history import ADDITIVE_PREFIXES, DATA_COLUMNS

if TYPE_CHECKING:
    import pandas as pd

    from citylearn_env.env import CityLearnEnv as NativeEnv


class EvaluationCondition(Enum):
    """Upstream's KPI conditions; :meth:`CityLearnEnv.evaluate` supports the defaults only (with storage, partial
    load and PV against without storage and partial load)."""

    WITH_STORAGE_AND_PV = ""
    WITHOUT_STORAGE_BUT_WITH_PV = "_without_storage"
    WITHOUT_STORAGE_AND_PV = "_without_storage_and_pv"
    WITH_STORAGE_AND_PARTIAL_LOAD_AND_PV = ""
    WITHOUT_STORAGE_BUT_WITH_PARTIAL_LOAD_AND_PV = "_without_storage"
    WITHOUT_STORAGE_AND_PARTIAL_LOAD_BUT_WITH_PV = "_without_storage_and_partial_load"
    WITHOUT_STORAGE_AND_PARTIAL_LOAD_AND_PV = "_without_storage_and_partial_load_and_pv"


class Results:
    """KPIs, metadata and the reads behind ``env.buildings[i]`` and the district series, over :attr:`native`."""

    native: NativeEnv
    buildings: list[Building]
    series_names: frozenset[str]
    reward_function: Any
    uid: str
    _reward_names: tuple[str, ...]
    _action_index: list[np.ndarray]
    _building_boxes: list[gym.spaces.Box]
    _action_boxes: list[gym.spaces.Box]

    def evaluate(self, control_condition: EvaluationCondition | None = None,
                 baseline_condition: EvaluationCondition | None = None, comfort_band: float | None = None
                 ) -> pd.DataFrame:
        """The KPI table (cost_function, value, name, level) over the episode so far: the native
        :meth:`~citylearn_env.env.CityLearnEnv.evaluate` (default conditions only; comfort band [degC], default 2)."""
        dynamics = set(self.native.district.dynamics.tolist())
        defaults = {None} | ({EvaluationCondition.WITHOUT_STORAGE_AND_PARTIAL_LOAD_BUT_WITH_PV} if dynamics == {True}
                             else {EvaluationCondition.WITHOUT_STORAGE_BUT_WITH_PV} if dynamics == {False} else set())
        if control_condition not in (None, EvaluationCondition.WITH_STORAGE_AND_PV) or baseline_condition not in defaults:
            raise SchemaError("only the default evaluation conditions are supported (with storage, partial load and "
                              "PV against the building's no-control baseline)", column="evaluate")
        return self.native.evaluate(comfort_band=2.0 if comfort_band is None else float(comfort_band))

    def evaluate_citylearn_challenge(self) -> dict[str, dict[str, Any]]:
        """The CityLearn Challenge 2023 score: KPI -> {display_name, weight, value}, plus ``average_score``."""
        native = self.native
        table = kpis.evaluate_challenge(native.series(), native.building_names, dynamics=list(native.district.dynamics),
                                        settings=native.settings)
        return {r.kpi: {"display_name": r.display_name, "weight": None if r.kpi == "average_score" else r.weight,
                        "value": r.value} for r in table.itertuples()}

    def base_metadata(self) -> dict[str, Any]:
        """``uid``, ``random_seed``, ``simulation_time_steps`` and ``seconds_per_time_step`` [s]."""
        return {"uid": self.uid, "random_seed": self.random_seed, "seconds_per_time_step": self.seconds_per_time_step,
                "simulation_time_steps": self.episode_tracker.simulation_time_steps}

    def get_metadata(self) -> dict[str, Any]:
        """Upstream's static facts: reward class name, agent mode, shared observations, each building's metadata."""
        reward = self.reward_function
        name = reward.reward_type.rsplit(".", 1)[-1] if isinstance(reward, NativeReward) else type(reward).__name__
        return {**self.base_metadata(), "reward_function": name,
                "central_agent": self.central_agent, "shared_observations": self.shared_observations,
                "buildings": [b.get_metadata() for b in self.buildings]}

    def _parse_actions(self, actions: Any) -> list[dict[str, float]]:
        """Upstream's (private, but used by the SimBuild program) action record: per building,
        ``{"<action>_action": value}`` for its active actions."""
        vector = action_vector(actions, self._action_index, self.native.action_space.shape[0],
                               self.native.config.central_agent)
        return [{f"{self.native.action_pairs[i][0]}_action": float(vector[i]) for i in ix} for ix in self._action_index]

    # ------------------------------------------------------------------ what the building views read
    def observation_names_of(self, index: int) -> list[str]:
        return [n for n, _ in self.native.layout.pairs[self.native.layout.building_slices[index]]]

    def action_names_of(self, index: int) -> list[str]:
        return [self.native.action_pairs[i][0] for i in self._action_index[index]]

    def observations_of(self, index: int) -> list[float]:
        s = self.native.layout.building_slices[index]
        return self.native.flat_observations()[s].astype(np.float32).tolist()

    def building_observation_space(self, index: int) -> gym.spaces.Box:
        return self._building_boxes[index]

    def building_action_space(self, index: int) -> gym.spaces.Box:
        return self._action_boxes[index]

    def building_observations(self, index: int) -> BuildingObservations:
        return BuildingObservations(self.native.step_observations(), index, self._reward_names)

    def building_series(self, name: str, index: int) -> np.ndarray:
        """Building ``index``'s series ``name`` over time steps 0 .. t (read-only view where it is recorded)."""
        native, end = self.native, self.native.t + 1
        if name in native.district.recorded:
            values = native.district.recorded[name][index, :end].view()
        elif name in DATA_COLUMNS:
            values = native.district.episode[DATA_COLUMNS[name]][index, :end].view()
        else:
            return native.series()[name][index]
        values.flags.writeable = False
        return values

    def __getattr__(self, name: str) -> np.ndarray:
        """District series (``env.net_electricity_consumption`` ...): the sum over buildings, time steps 0 .. t."""
        if not name.startswith("_") and name in self.__dict__.get("series_names", ()) and (
                name.startswith(ADDITIVE_PREFIXES) or name.endswith("_electricity_consumption")):
            return self.native.series()[name].sum(axis=0)
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")


def action_vector(actions: Any, index: list[np.ndarray], n: int, central: bool) -> np.ndarray:
    """The native action vector (n,) of upstream's ``actions``: ``[[n values]]`` for a central agent, else one list
    per building (building b's values go to positions ``index[b]``)."""
    if central:
        vector = np.asarray(actions[0] if len(actions) else [], dtype=np.float64).reshape(-1)
        if vector.size != n:
            raise SchemaError(f"expected [[{n} actions]] for the central agent, got {vector.size}", column="actions")
        return vector
    if len(actions) != len(index):
        raise SchemaError(f"expected one action list per building ({len(index)}), got {len(actions)}",
                          column="actions")
    vector = np.zeros(n)
    for b, (ix, given) in enumerate(zip(index, actions, strict=True)):
        values = np.asarray(given, dtype=np.float64).reshape(-1)
        if values.size != ix.size:
            raise SchemaError(f"expected {ix.size} actions for building {b}, got {values.size}", column="actions")
        vector[ix] = values
    return vector


def available(view: Any, name: str) -> bool:
    """Whether observation ``name`` can be read from the step view (data columns a data set lacks cannot)."""
    try:
        view[name]
    except KeyError:
        return False
    return True


__all__ = ["EvaluationCondition", "Results", "action_vector", "available"]
