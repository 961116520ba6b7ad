"""``CityLearnEnv`` with CityLearn's API over the native environment (mirrors ``citylearn.citylearn``).

An upstream program runs after replacing ``citylearn.`` with ``citylearn_env.compat.`` in its imports:
``CityLearnEnv(dataset name | schema path | schema dict, central_agent=, buildings=, simulation_start_time_step=,
simulation_end_time_step=, episode_time_steps=, random_seed=, reward_function=, ...)``; observations and actions
as lists of lists (one list for a central agent, one per building otherwise); rewards as lists; ``reset()`` and
``step()`` in the API of the program's CityLearn version (2.1: observations, four values; 2.2+: gymnasium's;
:mod:`citylearn_env.compat.version`);
``time_steps``, ``terminated``, ``episode_tracker``, ``rewards``, ``episode_rewards``, ``get_metadata()``,
``evaluate()`` and ``env.buildings[i]`` (:mod:`citylearn_env.compat.building`).

The physics is the native environment's (:attr:`CityLearnEnv.native`), run with ``settings`` (default: the mirrored
version's preset, "citylearn-2.1" or "citylearn-2.5", quirks included; docs/compat.md). The environment is reset once
at construction, as upstream, so ``time_steps`` (alias ``episode_length``) and the observations are known before
the first ``reset()``; the first ``reset()`` still starts episode 0.
"""

from __future__ import annotations

import copy
import dataclasses
import uuid
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from citylearn_env.compat.base import EpisodeTracker
from citylearn_env.compat.building import Building, BuildingObservations, building_view
from citylearn_env.compat.data import is_dataset_name, releases_holding
from citylearn_env.compat.loading import (
    check_keywords,
    plain_numbers,
    raw_schema,
    read_config,
    resolve_schema,
)
from citylearn_env.compat.results import EvaluationCondition, Results, action_vector, available
from citylearn_env.compat.reward_function import RewardFunction, computes_natively, reward_from_keyword
from citylearn_env.compat.utilities import read_json
from citylearn_env.compat.version import (
    MIRRORS,
    Mirror,
    choose,
    explicit_version,
    notice,
    preset_version,
    program_call,
    reset_form,
    schema_layout,
    step_form,
)
from citylearn_env.config import DistrictConfig
from citylearn_env.env import CityLearnEnv as NativeEnv
from citylearn_env.errors import SchemaError
from citylearn_env.settings import Behaviour, resolve

#: the behaviour preset of a CityLearn 2.1 program (a 2.2+ program runs "citylearn-2.5"; :mod:`.version`)
DEFAULT_SETTINGS = "citylearn-2.1"


class CityLearnEnv(Results, gym.Env):
    """CityLearn 2.1's environment API over :class:`citylearn_env.env.CityLearnEnv` (see the module docstring).

    ``settings``: a :class:`~citylearn_env.settings.Behaviour` or preset name ("citylearn-2.1", the default;
    "citylearn-2.5"; "corrected"). Other keywords as upstream; per-building lists of active observations or
    actions and ``Building`` objects are not accepted.
    """

    metadata = {"render_modes": []}

    def __init__(self, schema: Any, root_directory: str | Path | None = None, buildings: list[Any] | None = None,
                 simulation_start_time_step: int | None = None, simulation_end_time_step: int | None = None,
                 episode_time_steps: Any = None, rolling_episode_split: bool | None = None,
                 random_episode_split: bool | None = None, seconds_per_time_step: float | None = None,
                 reward_function: Any = None, reward_function_kwargs: dict[str, Any] | None = None,
                 central_agent: bool | None = None, shared_observations: list[str] | None = None,
                 active_observations: list[str] | None = None, inactive_observations: list[str] | None = None,
                 active_actions: list[str] | None = None, inactive_actions: list[str] | None = None,
                 simulate_power_outage: bool | None = None, solar_generation: bool | None = None,
                 random_seed: int | None = None, *, settings: Behaviour | str | None = None,
                 citylearn_version: str | None = None, **kwargs: Any) -> None:
        if kwargs:
            raise SchemaError(f"unsupported keyword(s) {', '.join(sorted(kwargs))}", column="CityLearnEnv")
        check_keywords({**locals(), "reward_function_kwargs": reward_function_kwargs})
        explicit = explicit_version(citylearn_version)
        named = explicit.version if explicit is not None else preset_version(settings)
        self.schema_source = resolve_schema(schema, MIRRORS[named][1] if named else None)
        #: the CityLearn version mirrored: its API, default physics and data sets (:mod:`~.version`)
        self.mirror = choose(explicit, self._layout(root_directory), settings)
        held = releases_holding(schema) if named is None and is_dataset_name(schema) else []
        if len(held) > 1:  # a name both releases hold: say that the newest was read
            self.mirror = Mirror(self.mirror.version, f"data set {schema!r} of {held[-1]} (the newest of "
                                 f"{', '.join(held)}), {self.mirror.reason}")
        notice(self.mirror)
        self.settings = resolve(self.mirror.preset if settings is None else settings)
        keywords = dict(
            root_directory=root_directory, buildings=buildings, simulation_start_time_step=simulation_start_time_step,
            simulation_end_time_step=simulation_end_time_step, episode_time_steps=episode_time_steps,
            rolling_episode_split=rolling_episode_split, random_episode_split=random_episode_split,
            seconds_per_time_step=seconds_per_time_step, central_agent=central_agent,
            shared_observations=shared_observations, active_observations=active_observations,
            inactive_observations=inactive_observations, active_actions=active_actions,
            inactive_actions=inactive_actions, simulate_power_outage=simulate_power_outage,
            solar_generation=solar_generation, random_seed=random_seed)
        base = read_config(self.schema_source, keywords, self.settings)
        self._reward = reward_from_keyword(reward_function, reward_function_kwargs, base.reward_function)
        self.uid = uuid.uuid4().hex
        self._base, self._ignored, self._no_actions = base, frozenset(), False
        self._pending: DistrictConfig | None = None
        self._rewards: list[list[float]] = [[]]
        self._episode_rewards: list[dict[str, list[float]]] = []
        self._build(episode=-1)
        #: one read-only view per building (:mod:`citylearn_env.compat.building`)
        self.buildings: list[Building] = [building_view(self, i, b.has_dynamics) for i, b in enumerate(base.buildings)]
        self._bind_reward()

    # ------------------------------------------------------------------ construction
    def _layout(self, root_directory: Any) -> str | None:
        """The data-set layout of the schema ("v2.1", "v2.2"; None for a ``DistrictConfig`` or when nothing
        tells); a schema file whose ``root_directory`` leaves its folder is refused here."""
        source = self.schema_source
        if isinstance(source, DistrictConfig):
            return None
        raw, folder = raw_schema(source)
        if root_directory is not None:
            raw["root_directory"], folder = str(root_directory), None
        return schema_layout(raw, folder)

    def _effective_config(self) -> DistrictConfig:
        """The base config with the temperature models of ``ignore_dynamics`` buildings and (BaselineAgent) every
        action removed."""
        config = self._base
        if self._ignored:
            config = config.replace(buildings=tuple(
                dataclasses.replace(b, cooling_model=None, heating_model=None) if i in self._ignored else b
                for i, b in enumerate(config.buildings)))
        return config.with_actions(()) if self._no_actions else config

    def _build(self, episode: int) -> None:
        """(Re)build the native environment, reset it once (spaces, ``time_steps``, observations known) and put its
        episode counter at ``episode`` so the next ``reset()`` starts episode ``episode + 1``."""
        native_reward = computes_natively(self._reward)
        spec = self._reward.native_spec() if native_reward else "default"
        self.native = NativeEnv(self._effective_config(), settings=self.settings, reward_function=spec)
        self._native_reward = native_reward
        native = self.native
        native.reset()
        native.episode = episode
        self.series_names = frozenset(native.series())
        view = native.step_observations()
        self._reward_names = tuple(n for n in view if available(view, n))
        lo, hi = native.observation_bounds
        pairs, layout = native.action_pairs, native.layout
        self._action_index = [np.array([i for i, (_, b) in enumerate(pairs) if b == k], dtype=np.intp)
                              for k in range(len(native.building_names))]
        self._building_boxes = [gym.spaces.Box(lo[s].astype(np.float32), hi[s].astype(np.float32), dtype=np.float32)
                                for s in layout.building_slices]
        low, high = native.action_space.low, native.action_space.high
        self._action_boxes = [gym.spaces.Box(low[ix], high[ix], dtype=np.float32) for ix in self._action_index]

    def _rebuild(self) -> None:
        if self.native.t not in (0, self.native.episode_length - 1):
            raise SchemaError("can only change the environment between episodes (before a step or at the end)",
                              column="CityLearnEnv")
        self._build(episode=self.native.episode)
        self._bind_reward()

    def _bind_reward(self) -> None:
        """Give the reward upstream's ``env_metadata`` (and a compat reward this environment's settings)."""
        if isinstance(self._reward, RewardFunction):
            self._reward.compat_settings = self.settings
        self._reward.env_metadata = self.get_metadata()

    @property
    def reward_function(self) -> Any:
        """The reward object; settable (``env.reward_function = MyReward(env.get_metadata())``): the new one is
        used from the next step on, a built-in one as the native reward (the native environment is rebuilt at
        once when no step of the episode has been taken, else at the next ``reset``)."""
        return self._reward

    @reward_function.setter
    def reward_function(self, value: Any) -> None:
        self._reward = reward_from_keyword(value, None, None)
        if computes_natively(self._reward) or self._native_reward:
            self._refresh_native_reward()
        self._bind_reward()

    def _refresh_native_reward(self) -> None:
        """Make the native environment compute the current reward (a rebuild; mid-episode a built-in reward is
        computed through its ``calculate`` until the next ``reset``)."""
        if self.native.t == 0:
            self._build(episode=self.native.episode)
        else:
            self._native_reward = False
            self._pending = self._pending or self._base

    # ------------------------------------------------------------------ upstream properties
    @property
    def config(self) -> DistrictConfig:
        """The typed config the native environment runs."""
        return self.native.config

    @property
    def time_step(self) -> int:
        return self.native.t

    @property
    def time_steps(self) -> int:
        """Time steps in the current episode (known from construction); ``time_steps - 1`` step calls."""
        return self.native.episode_length

    episode_length = time_steps

    @property
    def terminated(self) -> bool:
        return self.time_step == self.time_steps - 1

    done = terminated

    @property
    def truncated(self) -> bool:
        return False

    @property
    def episode(self) -> int:
        return max(self.native.episode, 0)

    @property
    def episode_tracker(self) -> EpisodeTracker:
        return EpisodeTracker(self)

    @property
    def episode_time_steps(self) -> Any:
        """Episode length [time steps] or inclusive (start, end) time-step splits; settable between episodes."""
        value = self.config.episode_time_steps
        return self.episode_tracker.simulation_time_steps if value is None else value

    @episode_time_steps.setter
    def episode_time_steps(self, value: Any) -> None:
        self._set_episode(episode_time_steps=value)

    def _set_episode(self, **changes: Any) -> None:
        """Episode settings take effect at the next ``reset`` (as upstream; the current episode runs on)."""
        pending = self._pending or self._base
        if "episode_time_steps" in changes:
            pending = pending.with_episode(plain_numbers(changes.pop("episode_time_steps")))
        self._pending = pending.replace(**{k: bool(v) for k, v in changes.items()}) if changes else pending

    @property
    def rolling_episode_split(self) -> bool:
        return (self._pending or self.config).rolling_episode_split

    @rolling_episode_split.setter
    def rolling_episode_split(self, value: bool) -> None:
        self._set_episode(rolling_episode_split=value)

    @property
    def random_episode_split(self) -> bool:
        return (self._pending or self.config).random_episode_split

    @random_episode_split.setter
    def random_episode_split(self, value: bool) -> None:
        self._set_episode(random_episode_split=value)

    @property
    def central_agent(self) -> bool:
        return self.config.central_agent

    @property
    def shared_observations(self) -> list[str]:
        return list(self.config.shared_observations)

    @property
    def seconds_per_time_step(self) -> float:
        return float(self.config.seconds_per_time_step)

    @property
    def random_seed(self) -> int | None:
        return self.config.random_seed

    @property
    def schema(self) -> dict[str, Any]:
        """The schema as a dict (read again from its file; a copy for a dict)."""
        source = self.schema_source
        if isinstance(source, (str, Path)):
            return read_json(source)
        return copy.deepcopy(dict(source)) if isinstance(source, dict) else {}

    @property
    def observation_space(self) -> list[gym.spaces.Box]:
        return [self.native.observation_space] if self.central_agent else list(self._building_boxes)

    @property
    def action_space(self) -> list[gym.spaces.Box]:
        return [self.native.action_space] if self.central_agent else list(self._action_boxes)

    @property
    def observation_names(self) -> list[list[str]]:
        if self.central_agent:
            return [self.native.layout.names(central=True)]
        return [self.observation_names_of(i) for i in range(len(self.buildings))]

    @property
    def action_names(self) -> list[list[str]]:
        names = [self.action_names_of(i) for i in range(len(self._action_index))]
        return [[n for b in names for n in b]] if self.central_agent else names

    @property
    def observations(self) -> list[list[float]]:
        """The observations at the current time step (float32 values as Python floats)."""
        flat = self.native.flat_observations()
        if self.central_agent:
            return [flat[self.native.layout.central_index].astype(np.float32).tolist()]
        return [flat[s].astype(np.float32).tolist() for s in self.native.layout.building_slices]

    @property
    def rewards(self) -> list[list[float]]:
        """Rewards of the current episode; ``rewards[0]`` is the empty placeholder of the reset step."""
        return self._rewards

    @property
    def episode_rewards(self) -> list[dict[str, list[float]]]:
        """min, max, sum and mean of the rewards of every finished episode."""
        return self._episode_rewards

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None) -> Any:
        """Start the next episode at t = 0 (episode settings changed since apply now); the reward function's
        ``reset()`` is called. Returns ``(observations, info)``, or the observations alone to a CityLearn 2.1
        program (:mod:`citylearn_env.compat.version`)."""
        return reset_form(self.mirror.api, self._reset(seed, options), program_call())

    def _reset(self, seed: int | None, options: dict | None) -> tuple[list[list[float]], dict]:
        super().reset(seed=seed)
        if self._pending is not None:
            self._base, self._pending = self._pending, None
            self._build(episode=self.native.episode)
            self._bind_reward()
        self.native.reset(seed=seed, options=options)
        self._reward.reset()
        self._rewards = [[]]
        return self.observations, self.get_info()

    def step(self, actions: Any) -> tuple:
        """Apply ``actions`` (``[[...]]`` for a central agent, one list per building otherwise; None for a device
        action meets the ideal load, for a storage action is 0) at t + 1. Returns gymnasium's five values, or
        ``(observations, reward, done, info)`` to a CityLearn 2.1 program."""
        return step_form(self.mirror.api, self._step(actions), program_call())

    def _step(self, actions: Any) -> tuple[list[list[float]], list[float], bool, bool, dict]:
        _, reward, terminated, truncated, info = self.native.step(action_vector(
            self._without_none(actions), self._action_index, self.native.action_space.shape[0],
            self.central_agent))
        if self._native_reward:
            values = info.get("building_rewards")
            value = [float(reward)] if values is None else [float(v) for v in values]
        else:
            value = self._reward.calculate(observations=[
                BuildingObservations(self.native.step_observations(), i, self._reward_names)
                for i in range(len(self.buildings))])
            value = [float(value)] if np.isscalar(value) else [float(v) for v in value]
        self._rewards.append(value)
        if terminated:
            r = np.array(self._rewards[1:], dtype="float32")
            self._episode_rewards.append({k: getattr(r, k)(axis=0).tolist() for k in ("min", "max", "sum", "mean")})
        return self.observations, value, terminated, truncated, self.get_info()

    def _without_none(self, actions: Any) -> Any:
        """``actions`` with upstream's None values replaced: NaN (meet the ideal load) for a cooling or heating
        device action, 0 for a storage action."""
        if not isinstance(actions, (list, tuple)) or not any(
                v is None for a in actions if isinstance(a, (list, tuple)) for v in a):
            return actions
        names = self.action_names
        return [[(np.nan if n.endswith("_device") else 0.0) if v is None else v
                 for v, n in zip(a, agent, strict=False)] for a, agent in zip(actions, names, strict=False)]

    def estimate_observation_space(self) -> list[gym.spaces.Box]:
        """Upstream's name for the observation spaces (bounds estimated over the simulation range)."""
        return self.observation_space

    def estimate_action_space(self) -> list[gym.spaces.Box]:
        """Upstream's name for the action spaces."""
        return self.action_space

    def get_info(self) -> dict[str, Any]:
        """What ``step`` and ``reset`` return as ``info`` (empty, as upstream)."""
        return {}

    def ignores_dynamics(self, index: int) -> bool:
        return index in self._ignored

    def set_ignore_dynamics(self, index: int, flag: bool) -> None:
        """Switch building ``index``'s temperature model off (True) or on; rebuilds between episodes."""
        ignored = self._ignored | {index} if flag else self._ignored - {index}
        if ignored != self._ignored:
            self._ignored = frozenset(ignored)
            self._rebuild()

    def load_agent(self, agent: Any = None, **kwargs: Any) -> Any:
        """The agent of the schema's ``agent`` block (or ``agent``, a class or type string), built as
        ``Class(env=self, **attributes)``, ``kwargs`` overriding the schema's attributes
        (:mod:`citylearn_env.compat.agents.loading`)."""
        from citylearn_env.compat.agents.loading import load_agent

        return load_agent(self, agent, **kwargs)

    def deactivate_actions(self) -> None:
        """No active action in any building (what upstream's ``BaselineAgent`` does to its environment)."""
        if not self._no_actions:
            self._no_actions = True
            self._rebuild()


__all__ = ["DEFAULT_SETTINGS", "CityLearnEnv", "EvaluationCondition"]
