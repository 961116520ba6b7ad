"""The gymnasium environment: spaces, reset, step, history. ``step`` only coordinates.

Step timing follows CityLearn 2.1: ``reset`` puts the district at t = 0 (nothing controlled; devices serve
the data-set demands) and returns the observation at t = 0; ``step(a)`` advances to t + 1, applies ``a``
there, books consumption, runs the temperature model, computes the reward at t + 1 and returns its
observation. With ``settings.act_then_advance`` (CityLearn 2.5) ``step(a)`` applies ``a`` at t, computes the
reward there, then advances and returns the observation of t + 1 before control. Either way an episode of T
time steps has T - 1 step calls; ``terminated`` is true on the last.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from citylearn_env import kpis, rewards
from citylearn_env import observations as obs_mod
from citylearn_env.actions import DEVICE_ACTIONS, STORAGE_ACTIONS, ActionLayout
from citylearn_env.config import DistrictConfig
from citylearn_env.district import District
from citylearn_env.errors import SchemaError
from citylearn_env.history import device_history_frame, episode_series, history_frame
from citylearn_env.outages import reliability_outage_signal
from citylearn_env.schema import load_schema
from citylearn_env.settings import Behaviour, resolve
from citylearn_env.state import END_USE_SLOTS

if TYPE_CHECKING:  # pandas is imported only where a table is built (importing the package stays light)
    import pandas as pd


class CityLearnEnv(gym.Env):
    """A district of buildings as one gymnasium environment with a central Box observation and action.

    Parameters
    ----------
    schema: a CityLearn v2 schema.json path, a schema dict, or a :class:`DistrictConfig` (change a loaded
        config with its typed ``with_*`` methods rather than editing the JSON).
    settings: upstream behaviour, a :class:`citylearn_env.settings.Behaviour` or a preset name
        ("corrected", the default, or "citylearn-2.1").
    compat: shorthand for ``settings="citylearn-2.1"``: CityLearn 2.1 exactly, bugs included.
    reward_function: a reward spec (``{"type": ..., "attributes": ...}`` or a registered short name) or a
        reward object; default: the schema's.
    central_agent: override the schema's flag (decides whether the reward is central or per building).
    allow_outside_paths: let the schema's data files lie outside its folder (refused by default).
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        schema: str | Path | Mapping[str, Any] | DistrictConfig,
        *,
        settings: Behaviour | str | None = None,
        compat: bool = False,
        reward_function: Any = None,
        central_agent: bool | None = None,
        episode_time_steps: int | None = None,
        allow_outside_paths: bool = False,
    ):
        self.settings = resolve(settings, compat)
        self._legacy_drift: np.random.RandomState | None = None  # legacy_ev_drift_draws' stream
        config = schema if isinstance(schema, DistrictConfig) else load_schema(
            schema, settings=self.settings, allow_outside_paths=allow_outside_paths)
        self.config = config
        self.central_agent = config.central_agent if central_agent is None else central_agent
        self.district = District(config, settings=self.settings)
        self.layout = obs_mod.ObservationLayout(self.district)
        self.building_names = config.building_names
        self._setup_actions()
        self._setup_episodes(episode_time_steps)
        self.reward_function = self._make_reward(reward_function)
        lo, hi = self.layout.bounds()
        self._obs_low, self._obs_high = lo, hi
        ci = self.layout.central_index
        self.observation_space = gym.spaces.Box(lo[ci].astype(np.float32), hi[ci].astype(np.float32),
                                                dtype=np.float32)
        low, high = self.action_layout.low, self.action_layout.high
        self.action_space = gym.spaces.Box(low.astype(np.float32), high.astype(np.float32),
                                           dtype=np.float32)
        self.episode = -1
        self.t = self._acted = 0

    # ------------------------------------------------------------------ setup
    def _setup_actions(self) -> None:
        """The action vector's layout and bounds (:class:`citylearn_env.actions.ActionLayout`)."""
        d = self.district
        self.action_layout = ActionLayout([b.active_actions for b in self.config.buildings], self.building_names,
                                          battery=d.battery, end_uses=d.end_use_params, ev=d.ev,
                                          machines=d.machines, settings=self.settings)
        self.action_pairs = self.action_layout.pairs

    def _setup_episodes(self, override: int | None) -> None:
        cfg = self.config
        n = cfg.simulation_end_time_step - cfg.simulation_start_time_step + 1
        episode = override if override is not None else cfg.episode_time_steps
        if episode is None:
            self.splits = [(0, n)]
        elif isinstance(episode, int):
            if not 2 <= episode <= n:
                raise SchemaError(f"must be between 2 and the simulation length {n}", column="episode_time_steps")
            step = 1 if cfg.rolling_episode_split else episode
            self.splits = [(s, episode) for s in range(0, n - episode + 1, step)]
        else:
            base = cfg.simulation_start_time_step
            self.splits = [(a - base, b - a + 1) for a, b in episode]
            for a, length in self.splits:
                if a < 0 or a + length > n or length < 2:
                    raise SchemaError("split outside the simulation range", column="episode_time_steps")

    def _make_reward(self, spec: Any) -> Any:
        """The reward object of ``spec`` (None: the schema's), reset with this env's :class:`RewardContext`."""
        d = self.district
        context = rewards.RewardContext(
            central_agent=self.central_agent,
            building_names=self.building_names,
            capacity={END_USE_SLOTS[p.name].storage: p.tank.capacity for p in d.end_use_params}
            | {"electrical_storage": d.battery.capacity},
            initial_soc={END_USE_SLOTS[p.name].storage: p.tank.initial_soc for p in d.end_use_params}
            | {"electrical_storage": d.battery.initial_soc},
            active_actions={name: self.action_layout.active(name) for name in (*STORAGE_ACTIONS, *DEVICE_ACTIONS)},
            chargers=(lambda: rewards.charger_step(d, self._acted)) if d.ev is not None else None,
        )
        self._reward_context = context
        if spec is None:
            spec = self.config.reward_function
        if callable(spec) and hasattr(spec, "reset"):
            reward = spec
        else:
            reward = rewards.make_reward(spec, context, settings=self.settings)
        return reward

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Start the next episode (its split per the schema's episode settings) at t = 0; return the central
        observation (float32) and ``{"time_step": 0}``."""
        super().reset(seed=seed)
        self.episode += 1
        if self.config.random_episode_split and self.settings.legacy_random_episode_split:
            # CityLearn 2.1: legacy RandomState(seed * (episode + 1)), never the last split
            rs = np.random.RandomState((self.config.random_seed or 0) * (self.episode + 1))
            if len(self.splits) < 2:
                raise SchemaError("CityLearn 2.1 cannot pick a random split among one", column="episode_time_steps")
            start, length = self.splits[int(rs.choice(len(self.splits) - 1))]
        elif self.config.random_episode_split:
            start, length = self.splits[int(self.np_random.integers(len(self.splits)))]
        else:
            start, length = self.splits[self.episode % len(self.splits)]
        self.t = self._acted = 0
        self.episode_start = start
        self.district.reset(start, length, self._outage_signal(start, length), self._drift_draw(seed),
                            occupant_seed=self._occupant_seed(seed))
        self._static = self.layout.episode_matrix()
        self.reward_function.reset(self._reward_context)
        self.rewards = np.full(length, np.nan)
        self._refresh(0)
        return self._observation(), {"time_step": 0}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply ``action`` (the Box action vector) at the next time step (at the current one with
        ``settings.act_then_advance``); ``info`` holds the reward's named terms (``reward_terms``: name -> (B,)
        per building) and per-building rewards when not central; ``rewards[k]`` is the reward of the step
        acted on."""
        t = self.advance(action)
        value, terms = self.reward_function(self._view)
        reward = value if type(value) is float else float(np.sum(value))
        self.rewards[self._acted] = reward
        terminated = t == self.district.length - 1
        info = {"time_step": t, "reward_terms": terms}
        if not np.isscalar(value):
            info["building_rewards"] = np.asarray(value)
        return self._observation(), reward, terminated, False, info

    # ------------------------------------------------------------------ public accessors
    def advance(self, action: Any) -> int:
        """Validate ``action``, apply it and advance the district one step (no reward); return the new time
        step. :meth:`step_observations` is then the step acted on, :meth:`flat_observations` the new one (the
        same step but with ``settings.act_then_advance``)."""
        try:
            given = action if isinstance(action, np.ndarray) else np.asarray(action)
        except (ValueError, TypeError):  # ragged nesting
            raise SchemaError("action must be a flat sequence of numbers", column="action") from None
        if given.dtype.kind not in "biuf":  # strings, objects: "0.5" is not an action
            raise SchemaError(f"action must be numbers, got values of type {given.dtype}", column="action")
        a = given.astype(np.float64, copy=False).reshape(-1)
        if a.shape != self.action_layout.low.shape:
            raise SchemaError(f"action has {a.size} values, the action space has {self.action_layout.low.size} "
                              f"({', '.join(f'{self.building_names[b]}.{n}' for n, b in self.action_pairs)})",
                              column="action")
        finite = np.isfinite(a) if not np.isfinite(a.sum()) else None  # a finite sum: every value is finite
        if finite is not None:  # NaN of a cooling/heating device action: meet the ideal load (upstream's None)
            finite |= np.isnan(a) & np.isin([n for n, _ in self.action_pairs], DEVICE_ACTIONS)
        if finite is not None and not finite.all():
            i = int((~finite).argmax())
            name, b = self.action_pairs[i]
            raise SchemaError(f"action value {a[i]!r} is not finite", column=f"{self.building_names[b]}.{name}",
                              row=i)
        if self.t >= self.district.length - 1:
            raise RuntimeError("episode is over: call reset()")
        d = self.district
        if self.settings.act_then_advance:
            d.act(self.action_layout.actions(a))
            self._acted = d.t
            d.advance()
        else:
            d.step(self.action_layout.actions(a))
            self._acted = d.t
        self.t = t = d.t
        self._refresh(t, self._acted)
        return t

    def step_observations(self) -> Mapping[str, np.ndarray]:
        """Every observation of every building at the step last acted on (the current step, except with
        ``settings.act_then_advance``, where it is the one before): name -> (B,) raw values (what rewards see)."""
        return self._view

    def flat_observations(self) -> np.ndarray:
        """All buildings' active observations at the current step, float64, laid out as
        ``layout.pairs`` (the central vector is ``flat[layout.central_index]``; per-building slices in
        ``layout.building_slices``)."""
        return self._flat

    def data(self, name: str) -> np.ndarray:
        """The episode's (B, T) series of data column ``name`` (e.g. "hour", "day_type", "electricity_pricing")."""
        try:
            return self.district.episode[name]
        except KeyError:
            raise SchemaError(f"no data column {name!r}; known: {', '.join(sorted(self.district.episode.columns))}",
                              column=name) from None

    @property
    def episode_length(self) -> int:
        """Time steps of the current episode (the episode has ``episode_length - 1`` step calls). Before the first
        ``reset()``: the length of the episode that reset starts where it is known (sequential splits, or random
        ones of one length), so ``SAC.learn(total_timesteps=k * env.episode_length)`` trains k episodes; random
        splits of different lengths are a :class:`SchemaError` until then."""
        if self.episode >= 0:
            return self.district.length
        lengths = {length for _, length in self.splits}
        if not self.config.random_episode_split:
            return self.splits[0][1]
        if len(lengths) == 1:
            return lengths.pop()
        raise SchemaError("random episode splits of different lengths: the episode length is known after reset()",
                          column="episode_time_steps")

    @property
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds (float64) of every entry of :meth:`flat_observations`."""
        return self._obs_low, self._obs_high

    @property
    def reward_context(self) -> rewards.RewardContext:
        """The static facts rewards are reset with (:class:`citylearn_env.rewards.RewardContext`)."""
        return self._reward_context

    # ------------------------------------------------------------------ helpers
    def _refresh(self, t: int, acted: int | None = None) -> None:
        """The observations of step ``t`` and the reward view of step ``acted`` (default ``t``)."""
        self._view = obs_mod.StepObservations(self.district, t if acted is None else acted)
        self._flat = self.layout.vector(self._static[t], t)

    def _observation(self) -> np.ndarray:
        return self._flat[self.layout.central_index].astype(np.float32)

    def _drift_draw(self, seed: int | None) -> Callable[[int], np.ndarray] | None:
        """The draw of away EVs' SOC drift, N(1, 0.2) (None without EVs): the env's generator, or with
        ``settings.legacy_ev_drift_draws`` a ``RandomState`` seeded by ``reset(seed=...)`` (CityLearn 2.5's
        global ``numpy.random`` seeded with that number), kept across resets without a seed."""
        if self.district.ev is None:
            return None
        if not self.settings.legacy_ev_drift_draws:
            return lambda k: self.np_random.normal(1.0, 0.2, k)
        if seed is not None or self._legacy_drift is None:
            self._legacy_drift = np.random.RandomState(seed if seed is not None
                                                       else int(self.np_random.integers(2**31 - 1)))
        return lambda k, rs=self._legacy_drift: rs.normal(1.0, 0.2, k)

    def _occupant_seed(self, seed: int | None) -> int:
        """The seed of the occupants' draws (:mod:`citylearn_env.occupant`): ``reset(seed=...)``'s, else the
        schema's ``random_seed`` (upstream's), else one drawn from the env's generator; 0 without occupants."""
        if self.district.occupants is None:
            return 0
        if seed is not None:
            return int(seed)
        if self.config.random_seed is not None:
            return int(self.config.random_seed)
        return int(self.np_random.integers(2**31 - 1))

    def _outage_signal(self, start: int, length: int) -> np.ndarray:
        d = self.district
        signal = np.zeros((d.n, length))
        for b, building in enumerate(self.config.buildings):
            o = building.outage
            if not o.simulate:
                continue
            if not o.stochastic:
                signal[b] = d.signals["power_outage"][b, start : start + length]
                continue
            seed = o.random_seed
            if seed is None:
                seed = int(self.np_random.integers(2**31 - 1))
            signal[b] = reliability_outage_signal(
                length, saifi=o.saifi, caidi=o.caidi, seed=int(seed),
                seconds_per_time_step=self.config.seconds_per_time_step,
                start_time_steps=o.start_time_steps, legacy=self.settings.legacy_outage_draws,
            )
        return signal

    # ------------------------------------------------------------------ results
    @property
    def observation_names(self) -> list[str]:
        """Names of the central observation vector's entries: ``"<building>.<observation>"``, and the bare
        observation name for observations shared in the central agent (they appear once)."""
        shared = set(self.config.shared_observations)
        pairs = self.layout.pairs
        return [name if name in shared else f"{self.building_names[b]}.{name}"
                for name, b in (pairs[i] for i in self.layout.central_index)]

    @property
    def action_names(self) -> list[str]:
        """Names of the action vector's entries: ``"<building>.<action>"``."""
        return [f"{self.building_names[b]}.{name}" for name, b in self.action_pairs]

    def series(self, window: slice | None = None) -> dict[str, np.ndarray]:
        """Recorded and derived episode series, name -> (B, t + 1) arrays (see :mod:`citylearn_env.history`)."""
        return episode_series(self.district, self.t, window)

    def history(self, include_district: bool = True) -> pd.DataFrame:
        """One row per (building, time_step) so far, columns named as CityLearn's building properties."""
        return history_frame(self.district, self.t, include_district=include_district)

    def device_history(self) -> pd.DataFrame:
        """One row per (charger, EV or washing machine, time_step) so far: consumption, SOC, efficiency,
        degraded capacity (:func:`citylearn_env.history.device_history_frame`)."""
        return device_history_frame(self.district, self.t)

    def evaluate(self, *, comfort_band: float = 2.0, window: slice | None = None) -> pd.DataFrame:
        """The CityLearn KPI table (long form: cost_function, value, name, level) over the episode so far."""
        return kpis.evaluate(self.series(), self.building_names, dynamics=list(self.district.dynamics),
                             comfort_band=comfort_band, window=window, settings=self.settings)

    def objectives(self, window: slice | None = None) -> dict[str, Any]:
        """The SimBuild paper's five objectives in absolute units over ``window`` of the episode so far."""
        return kpis.objectives(self.series(), window=window,
                               one_set_point=self.settings.kpi_discomfort_against_one_set_point)
