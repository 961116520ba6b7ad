"""Occupant set-point overrides (CityLearn 2.4+'s ``LogisticRegressionOccupantInteractionBuilding``).

Upstream (intelligent-environments-lab/CityLearn: ``citylearn/occupant.py`` ``LogisticRegressionOccupant``,
``citylearn/building.py`` ``LogisticRegressionOccupantInteractionBuilding.update_set_points``,
``citylearn/citylearn.py`` ``_load_building``, ``citylearn/data.py`` ``LogisticRegressionOccupantParameters``),
learnt from its code and re-expressed here as small functions; per occupant building b at step t, after the LSTM
predicted the indoor temperature T[t] (only where the model predicted, i.e. is warm):

* the set point in play is the cooling one in hvac_mode 1 and the heating one in hvac_mode 2 (upstream raises in
  auto mode 3 and fails on an undefined name in mode 0; here the occupant does not act in modes 0 and 3);
* probabilities of raising and of lowering it [-]: ``p = 1 / (1 + exp(-(a[t] + b[t] T[t])))`` with the
  per-step logistic parameters ``a_increase, b_increase`` / ``a_decrease, b_decrease`` of the occupant's
  parameter file (one row per data row, like the building file);
* one draw ``r`` = the first uniform number of ``numpy.random.RandomState(max(seed, 1) + t)`` (upstream: seed =
  the schema's ``random_seed``; here the seed of ``reset(seed=...)``, else the schema's, else one drawn from the
  env's generator);
* both probabilities below ``r``, or both at or above it: no change. Only ``p_increase >= r``: the increase
  model (a scikit-learn LogisticRegression, :func:`read_logistic_regression`) classifies the features
  ``[S[t], S[t-1], T[t-1] - S[t-1]]`` (S the set point in play) and ``delta_output_map[class]`` [K] is added;
  only ``p_decrease >= r``: the decrease model's mapped delta is subtracted;
* a non-zero delta sets the set point in play from t to the episode end to ``S[t] + delta`` and starts the hold
  counter at ``set_point_hold_time_steps`` (upstream: never read from the schema, so no limit); each step
  without a change counts it down, and at 0 both set points from t + 1 on return to the data set's.

The models are read WITHOUT unpickling arbitrary code: a restricted unpickler admits only the LogisticRegression
class (as a plain attribute holder, nothing of scikit-learn imported or run) and numpy's array rebuilders; any
other global is refused with one SchemaError naming it.
"""

from __future__ import annotations

import io
import math
import pickle
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import dataset, paths
from citylearn_env.errors import SchemaError
from citylearn_env.registry import resolve_type

#: the parameter file's columns (logistic intercepts and slopes [1/K], per data row)
PARAMETER_COLUMNS = ("a_increase", "b_increase", "a_decrease", "b_decrease")
#: features the set-point models classify: current and previous set point [degC], previous T - S [K]
N_FEATURES = 3
#: the scikit-learn classes admitted (current and pre-0.22 module paths)
_MODEL_CLASSES = {("sklearn.linear_model._logistic", "LogisticRegression"),
                  ("sklearn.linear_model.logistic", "LogisticRegression")}
#: numpy's array and scalar rebuilders (numpy 1.x and 2.x module paths)
_NUMPY = {(m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray") for n in ("_reconstruct", "scalar")}
_NUMPY |= {("numpy", "ndarray"), ("numpy", "dtype")}


class _ModelState:
    """Stand-in for the pickled estimator: keeps the attribute dict it is given, runs nothing."""

    def __setstate__(self, state: Any) -> None:
        self.state = state


class _ModelUnpickler(pickle.Unpickler):
    """Admits only :data:`_MODEL_CLASSES` (as :class:`_ModelState`) and numpy's rebuilders."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in _MODEL_CLASSES:
            return _ModelState
        if (module, name) in _NUMPY:
            import importlib

            return getattr(importlib.import_module(module), name)
        raise pickle.UnpicklingError(f"global '{module}.{name}' is not allowed in an occupant model file "
                                     "(only a scikit-learn LogisticRegression and numpy arrays)")


@dataclass(frozen=True)
class LogisticModel:
    """A fitted logistic-regression classifier as plain arrays: ``coef`` (K, F), ``intercept`` (K,) and the
    class labels ``classes`` (C,); K = 1 for two classes, else K = C."""

    coef: np.ndarray
    intercept: np.ndarray
    classes: np.ndarray

    def predict(self, features: np.ndarray) -> int:
        """The class label of one feature vector (F,): the sign of the score for two classes, else the class of
        the largest score (what scikit-learn's ``predict`` does)."""
        scores = self.coef @ features + self.intercept
        index = int(scores[0] > 0.0) if len(scores) == 1 else int(np.argmax(scores))
        return int(self.classes[index])


def read_logistic_regression(path: str | Path, *, where: str) -> LogisticModel:
    """The scikit-learn LogisticRegression pickled at ``path`` as a :class:`LogisticModel` (its ``coef_``,
    ``intercept_`` and ``classes_``), read by a restricted unpickler; one SchemaError (naming the file and the
    schema key ``where``) for anything else, a refused global included."""
    path = Path(path)
    try:
        obj = _ModelUnpickler(io.BytesIO(path.read_bytes())).load()
    except OSError as error:
        raise SchemaError(f"cannot read the occupant model: {error.strerror or error}", file=path,
                          column=where) from None
    except pickle.UnpicklingError as error:
        raise SchemaError(f"refusing to load: {error}", file=path, column=where) from None
    except Exception as error:  # a corrupt or truncated pickle: one line, no traceback
        raise SchemaError(f"cannot unpickle the occupant model: {type(error).__name__}: {error}", file=path,
                          column=where) from None
    state = getattr(obj, "state", None)
    if not isinstance(obj, _ModelState) or not isinstance(state, dict):
        raise SchemaError(f"not a pickled scikit-learn LogisticRegression (found {type(obj).__name__})", file=path,
                          column=where)
    return _model_from_state(state, path, where)


def _model_from_state(state: Mapping[str, Any], path: Path, where: str) -> LogisticModel:
    """coef_ (K, 3), intercept_ (K,) and integer classes_ of a fitted model, finite, consistent in size."""
    try:
        coef = np.asarray(state["coef_"], dtype=np.float64)
        intercept = np.asarray(state["intercept_"], dtype=np.float64).reshape(-1)
        classes = np.asarray(state["classes_"])
    except KeyError as error:
        raise SchemaError(f"the model is not fitted: no {error.args[0]}", file=path, column=where) from None
    except (TypeError, ValueError) as error:
        raise SchemaError(f"unreadable model arrays: {error}", file=path, column=where) from None
    k = 1 if len(classes) == 2 else len(classes)
    if coef.ndim != 2 or coef.shape != (k, N_FEATURES) or intercept.shape != (k,) or len(classes) < 2:
        raise SchemaError(f"expected a classifier of {N_FEATURES} features (set point, previous set point, previous "
                          f"temperature - set point); coef_ has shape {coef.shape}, {len(classes)} classes",
                          file=path, column=where)
    if not (np.isfinite(coef).all() and np.isfinite(intercept).all()):
        raise SchemaError("the model's coefficients are not finite", file=path, column=where)
    if classes.dtype.kind not in "iuf" or not np.array_equal(classes, np.round(classes.astype(np.float64))):
        raise SchemaError(f"class labels must be integers (keys of delta_output_map), got {classes.tolist()!r}",
                          file=path, column=where)
    return LogisticModel(coef, intercept, classes.astype(np.int64))


@dataclass(frozen=True)
class OccupantConfig:
    """One building's occupant: the two set-point models, ``delta_output_map`` (class label -> set-point change
    [K]), the per-step logistic parameters over the simulation range (float32-rounded, as upstream holds them)
    and the hold time [time steps] after which an override returns to the data set's set points (None: none)."""

    increase: LogisticModel
    decrease: LogisticModel
    delta_output_map: Mapping[int, float]
    a_increase: np.ndarray
    b_increase: np.ndarray
    a_decrease: np.ndarray
    b_decrease: np.ndarray
    set_point_hold_time_steps: int | None = None

    @property
    def largest_delta(self) -> float:
        """The largest set-point change [K] the occupant can make (the observation's bound)."""
        return max((abs(v) for v in self.delta_output_map.values()), default=0.0)


def parse_delta_output_map(value: Any, models: Sequence[LogisticModel], where: str) -> dict[int, float]:
    """``delta_output_map`` (JSON object: class label -> change [K], keys as strings) with an entry for every
    class either model can give."""
    if not isinstance(value, Mapping) or not value:
        raise SchemaError("expected an object mapping each model class to a set-point change [K]", column=where)
    out: dict[int, float] = {}
    for key, delta in value.items():
        try:
            label = int(key)
        except (TypeError, ValueError):
            raise SchemaError(f"key {key!r} is not an integer class label", column=where) from None
        if isinstance(delta, bool) or not isinstance(delta, int | float) or not math.isfinite(delta):
            raise SchemaError(f"expected a finite number [K], got {delta!r}", column=f"{where}.{key}")
        out[label] = float(delta)
    missing = sorted({int(c) for m in models for c in m.classes} - set(out))
    if missing:
        raise SchemaError(f"no change given for model class(es) {missing}", column=where)
    return out


def read_parameters(path: Path, n_rows: int, start: int, *, where: str) -> dict[str, np.ndarray]:
    """The occupant parameter file's :data:`PARAMETER_COLUMNS` (finite numbers, at least ``n_rows`` data rows)
    over the simulation range from row ``start``, float32-rounded."""
    frame = dataset.read_frame(path)
    out = {}
    for name in PARAMETER_COLUMNS:
        if name not in frame.columns:
            raise SchemaError(f"missing column; expected {', '.join(PARAMETER_COLUMNS)}", file=path, column=name)
        text = frame[name].to_numpy()
        if len(text) < n_rows:
            raise SchemaError(f"has {len(text)} data rows; the simulation range needs {n_rows}", file=path,
                              column=name, row=len(text))
        try:
            values = np.asarray(text[:n_rows], dtype=np.float64)
        except ValueError:
            bad = dataset.first_non_number(text[:n_rows])
            raise SchemaError(f"not a number: {text[bad]!r}", file=path, column=name,
                              row=dataset.row_label(bad)) from None
        if not np.isfinite(values).all():
            bad = int(np.argmin(np.isfinite(values)))
            raise SchemaError("missing or infinite value", file=path, column=name, row=dataset.row_label(bad))
        out[name] = values[start:].astype(np.float32).astype(np.float64)
    return out


def parse_occupant(entry: Any, root: paths.DatasetFolder, span: tuple[int, int], where: str,
                   hold: Any = None) -> OccupantConfig:
    """A building's schema ``occupant`` entry (upstream's keys: ``type``, ``parameters_filename``, ``attributes``
    with ``setpoint_increase_model_filename``, ``setpoint_decrease_model_filename`` and ``delta_output_map``;
    files relative to the dataset folder) over the simulation range ``span`` (start, end). ``hold``: the
    building's ``set_point_hold_time_steps`` (null: no limit, upstream's only behaviour)."""
    if not isinstance(entry, Mapping):
        raise SchemaError(f"expected an object, got {type(entry).__name__}", column=where)
    resolve_type("occupant", entry.get("type"), where=f"{where}.type")
    attributes = entry.get("attributes")
    if not isinstance(attributes, Mapping):
        raise SchemaError("expected an object with the model file names and delta_output_map",
                          column=f"{where}.attributes")
    models = [read_logistic_regression(root.file(attributes.get(key), where=f"{where}.attributes.{key}"),
                                       where=f"{where}.attributes.{key}")
              for key in ("setpoint_increase_model_filename", "setpoint_decrease_model_filename")]
    deltas = parse_delta_output_map(attributes.get("delta_output_map"), models, f"{where}.attributes.delta_output_map")
    start, end = span
    parameters = read_parameters(root.file(entry.get("parameters_filename"), where=f"{where}.parameters_filename"),
                                 end + 1, start, where=f"{where}.parameters_filename")
    if hold is not None and (isinstance(hold, bool) or not isinstance(hold, int) or hold < 0):
        raise SchemaError(f"expected an integer >= 0 or null, got {hold!r}",
                          column=f"{where.rpartition('.')[0]}.set_point_hold_time_steps")
    return OccupantConfig(models[0], models[1], deltas, **parameters, set_point_hold_time_steps=hold)


# ------------------------------------------------------------------------------------------ the rule
def interaction_probability(a: float, b: float, temperature_c: float) -> float:
    """Probability [-] that the occupant acts at indoor temperature ``temperature_c`` [degC]: the logistic
    ``1 / (1 + exp(-(a + b T)))`` with intercept ``a`` [-] and slope ``b`` [1/K]."""
    z = a + b * temperature_c
    return 1.0 / (1.0 + math.exp(-z)) if z >= -700.0 else 0.0


def occupant_draw(seed: int, t: int) -> float:
    """The step's uniform number: first draw of ``RandomState(max(seed, 1) + t)`` (upstream's stream)."""
    return float(np.random.RandomState((max(int(seed), 1) + int(t)) % 2**32).uniform())


def set_point_change(occupant: OccupantConfig, t: int, features: np.ndarray, temperature_c: float, r: float) -> float:
    """The set-point change [K] the occupant makes at episode step ``t`` (its parameter rows are the episode's)
    given the step's features (see :data:`N_FEATURES`), indoor temperature [degC] and draw ``r``."""
    up = interaction_probability(occupant.a_increase[t], occupant.b_increase[t], temperature_c)
    down = interaction_probability(occupant.a_decrease[t], occupant.b_decrease[t], temperature_c)
    if (up >= r) == (down >= r):
        return 0.0
    if up >= r:
        return occupant.delta_output_map[occupant.increase.predict(features)]
    return -occupant.delta_output_map[occupant.decrease.predict(features)]


class OccupantModel:
    """The occupants of a district's buildings over an episode: set-point columns the overrides write into
    (copies of the data set's) and the recorded change per step [K].

    ``occupants``: (building index, OccupantConfig) pairs. Stepped by the district after the thermal model."""

    SET_POINTS = ("indoor_dry_bulb_temperature_cooling_set_point", "indoor_dry_bulb_temperature_heating_set_point",
                  "indoor_dry_bulb_temperature_set_point")

    def __init__(self, occupants: Sequence[tuple[int, OccupantConfig]], n_buildings: int):
        self.occupants = list(occupants)
        self.n = n_buildings

    def reset(self, columns: Mapping[str, np.ndarray], start: int, length: int, seed: int) -> dict[str, np.ndarray]:
        """Episode start over simulation rows ``start .. start + length - 1``: writable copies of the set-point
        columns (B, T) of the episode ``columns`` (returned, to replace the read-only views), the parameters'
        episode rows, the draw seed, zero changes and no hold running."""
        self.seed = int(seed)
        self.data = {k: np.array(columns[k]) for k in self.SET_POINTS}
        self.columns = {k: v.copy() for k, v in self.data.items()}
        self.hvac_mode = columns["hvac_mode"]
        self.episode = [(b, _window(o, start, length)) for b, o in self.occupants]
        self.delta = np.zeros((self.n, length))
        self.hold: dict[int, int | None] = {b: None for b, _ in self.occupants}
        return self.columns

    def update(self, t: int, temperature: np.ndarray, warm: np.ndarray) -> None:
        """Apply the occupants' overrides at step ``t`` (t >= 1) from the indoor temperatures (B, T) [degC];
        only buildings whose LSTM predicted at t (``warm``, (B,) bool) interact, as upstream."""
        r = None
        for b, occupant in self.episode:
            if not warm[b]:
                continue
            mode = self.hvac_mode[b, t]
            key = {1.0: self.SET_POINTS[0], 2.0: self.SET_POINTS[1]}.get(float(mode))
            delta = 0.0
            if key is not None:
                r = occupant_draw(self.seed, t) if r is None else r
                s = self.columns[key][b]
                features = np.array([s[t], s[t - 1], temperature[b, t - 1] - s[t - 1]])
                delta = set_point_change(occupant, t, features, float(temperature[b, t]), r)
            self.delta[b, t] = delta
            self._apply(b, t, key, delta, occupant.set_point_hold_time_steps)

    def _apply(self, b: int, t: int, key: str | None, delta: float, hold: int | None) -> None:
        """Write a change from ``t`` on and run the hold counter (see the module docstring); the comfort set
        point (heating one in hvac_mode 2, else cooling) follows wherever they changed."""
        changed = delta != 0.0
        if changed:
            column = self.columns[key][b]
            column[t:] = column[t] + delta
            self.hold[b] = hold
        elif self.hold[b] is not None:
            self.hold[b] -= 1
        if self.hold[b] == 0:
            for name in self.SET_POINTS[:2]:
                self.columns[name][b, t + 1:] = self.data[name][b, t + 1:]
            self.hold[b], changed = None, True
        if changed:
            cooling, heating, single = (self.columns[name][b] for name in self.SET_POINTS)
            single[t:] = np.where(self.hvac_mode[b, t:] == 2.0, heating[t:], cooling[t:])


def _window(occupant: OccupantConfig, start: int, length: int) -> OccupantConfig:
    """``occupant`` with its parameter rows cut to the episode (simulation rows ``start .. start + length - 1``)."""
    cut = {name: getattr(occupant, name)[start:start + length] for name in PARAMETER_COLUMNS}
    return OccupantConfig(occupant.increase, occupant.decrease, occupant.delta_output_map, **cut,
                          set_point_hold_time_steps=occupant.set_point_hold_time_steps)
