"""From an upstream-style ``CityLearnEnv(schema, **keywords)`` call to the typed :class:`DistrictConfig` the native
environment runs.

``schema`` is a data-set name (:mod:`citylearn_env.compat.data`), a schema path, a schema dict or a
``DistrictConfig``. Keywords that change what is read from the files -- ``root_directory``,
``simulation_start_time_step``, ``simulation_end_time_step`` and ``buildings`` (which may pick buildings the
schema excludes) -- are applied to a copy of the schema before its single load, as upstream does; every other
keyword is a typed edit of the loaded config (never of the JSON).
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import paths, ranges
from citylearn_env.compat.data import MAX_PATH, dataset_release, dataset_schema_path, is_dataset_name
from citylearn_env.compat.utilities import read_json
from citylearn_env.config import ACTION_NAMES, DistrictConfig
from citylearn_env.errors import SchemaError
from citylearn_env.schema import load_schema
from citylearn_env.settings import Behaviour

#: keywords applied to the schema before it is read (they decide which rows and files are read)
READ_KEYWORDS = ("root_directory", "simulation_start_time_step", "simulation_end_time_step", "buildings")
#: keywords applied to the loaded, typed config
TYPED_KEYWORDS = ("central_agent", "episode_time_steps", "rolling_episode_split", "random_episode_split",
                  "seconds_per_time_step", "random_seed", "shared_observations", "active_observations",
                  "inactive_observations", "active_actions", "inactive_actions", "simulate_power_outage",
                  "solar_generation")


def resolve_schema(schema: Any, release: str | None) -> str | Path | Mapping[str, Any] | DistrictConfig:
    """A data-set name becomes its cached ``schema.json`` path (of ``release``, else the one release holding it,
    else the newest; :func:`~citylearn_env.compat.data.dataset_release`); a dict gets plain Python numbers for
    numpy scalars and arrays; anything else is returned as given (a wrong type is one SchemaError line)."""
    if is_dataset_name(schema):
        return dataset_schema_path(schema, dataset_release(schema, release))
    if isinstance(schema, Mapping):
        return plain_numbers(schema)
    if isinstance(schema, str) and ("\x00" in schema or len(schema) > MAX_PATH):
        raise SchemaError(f"not a schema path or data-set name (NUL character or over {MAX_PATH} characters): "
                          f"{schema[:40]!r}...", column="schema")
    if not isinstance(schema, (str, Path, DistrictConfig)):
        raise SchemaError(f"a schema is a data-set name, a schema.json path, a dict or a DistrictConfig; got "
                          f"{type(schema).__name__}", column="schema")
    return schema


def plain_numbers(value: Any) -> Any:
    """``value`` (a schema dict, recursively) with numpy scalars and arrays as Python numbers and lists, as
    upstream's JSON-like schemas hold them (``{"simulation_end_time_step": np.int64(23)}`` is 23)."""
    if isinstance(value, Mapping):
        return {k: plain_numbers(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain_numbers(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain_numbers(value.tolist())
    return value.item() if isinstance(value, np.generic) else value


def raw_schema(schema: str | Path | Mapping[str, Any]) -> tuple[dict[str, Any], Path | None]:
    """A deep copy of the schema as a dict and the schema file's folder (None for a dict), ``root_directory``
    made absolute for a schema file and refused (one SchemaError line, the outside never read) when it leaves the
    file's folder."""
    if isinstance(schema, Mapping):
        return copy.deepcopy(dict(schema)), None
    path = Path(schema)
    try:
        found_file = path.is_file()
    except OSError as error:  # a name too long for the file system
        raise SchemaError(f"not a usable schema path or data-set name ({error.strerror}): {str(schema)[:60]!r}...",
                          column="schema") from None
    if not found_file:
        hint = "" if "/" in str(schema) or str(schema).endswith(".json") else \
            " (nor a data-set name: letters, digits, _ . - and at most 200 characters)"
        raise SchemaError(f"schema file not found{hint}", file=path if len(str(path)) <= 300 else None,
                          column=None if len(str(path)) <= 300 else "schema")
    try:
        raw = read_json(path)
    except (ValueError, OSError) as error:
        raise SchemaError(f"not a readable JSON schema ({type(error).__name__})", file=path) from None
    if not isinstance(raw, dict):
        raise SchemaError("a schema file holds one JSON object", file=path)
    folder = path.resolve().parent
    try:
        found = paths.dataset_folder(raw.get("root_directory"), folder)
    except SchemaError as error:
        raise SchemaError(str(error), file=path) from None
    raw["root_directory"] = str(found.root.resolve())
    return raw, folder


def _building_names(raw: Mapping[str, Any], buildings: Sequence[Any]) -> list[str]:
    """Schema building names of ``buildings`` (names, or indices into every schema building, as upstream)."""
    names = list(raw.get("buildings") or {})
    chosen = []
    for b in buildings:
        if isinstance(b, str) and b in names:
            chosen.append(b)
        elif isinstance(b, int) and not isinstance(b, bool) and -len(names) <= b < len(names):
            chosen.append(names[b])
        else:
            raise SchemaError(f"unknown building {b!r}; the schema has {', '.join(names)} (names or indices; "
                              "Building objects are not accepted)", column="buildings")
    return chosen


#: keyword -> (accepted types, what the error says is expected)
KEYWORD_TYPES: dict[str, tuple[tuple[type, ...], str]] = {
    **dict.fromkeys(("simulation_start_time_step", "simulation_end_time_step", "random_seed"),
                    ((int, np.integer), "an integer >= 0")),
    **dict.fromkeys(("central_agent", "rolling_episode_split", "random_episode_split", "simulate_power_outage",
                     "solar_generation"), ((bool, np.bool_), "True or False")),
    "seconds_per_time_step": ((int, float, np.integer, np.floating), "a number of seconds > 0"),
    "episode_time_steps": ((int, np.integer, list, tuple), "an integer >= 1 or a list of [start, end] pairs"),
    "root_directory": ((str, Path), "a folder path"),
    "buildings": ((list, tuple), "a list of building names or indices"),
    **dict.fromkeys(("shared_observations", "active_observations", "inactive_observations", "active_actions",
                     "inactive_actions"), ((list, tuple), "a list of names")),
    "reward_function_kwargs": ((Mapping,), "a dict of the reward's keyword arguments"),
}


def check_keywords(keywords: Mapping[str, Any]) -> None:
    """One SchemaError line for the first keyword of the wrong type or range (None means: not given)."""
    for key, (types, expected) in KEYWORD_TYPES.items():
        value = keywords.get(key)
        if value is None:
            continue
        wrong = not isinstance(value, types) or (isinstance(value, (bool, np.bool_)) and bool not in types)
        if not wrong and key in ranges.KEY_RANGES:  # the schema's own range for the key
            ranges.check_key({key: plain_numbers(value)}, key, None, where=key)
        if not wrong and key == "root_directory":
            wrong = "\x00" in str(value) or len(str(value)) > MAX_PATH
        if wrong:
            shown = repr(value) if len(repr(value)) <= 60 else f"{repr(value)[:57]}..."
            raise SchemaError(f"expected {expected}, got {shown} ({type(value).__name__})", column=key)


def read_config(schema: Any, keywords: Mapping[str, Any], settings: Behaviour) -> DistrictConfig:
    """Load ``schema`` with the read keywords applied, then apply the typed ones."""
    check_keywords(keywords)
    given = {k: plain_numbers(v) for k, v in keywords.items() if v is not None}
    if isinstance(schema, DistrictConfig):
        if any(k in given for k in READ_KEYWORDS):
            raise SchemaError(f"{', '.join(k for k in READ_KEYWORDS if k in given)} cannot change a loaded "
                              "DistrictConfig; pass the schema path or dict", column="schema")
        return apply_typed(schema, given)
    chosen = None
    if any(k in given for k in READ_KEYWORDS):
        raw, _ = raw_schema(schema)
        for key in ("root_directory", "simulation_start_time_step", "simulation_end_time_step"):
            if key in given:
                raw[key] = str(given[key]) if key == "root_directory" else given[key]
        if "buildings" in given:
            chosen = _building_names(raw, given["buildings"])
            for name, spec in raw["buildings"].items():
                if isinstance(spec, dict):
                    spec["include"] = name in chosen
        schema = raw
    config = load_schema(schema, settings=settings)
    if chosen is not None:
        config = config.with_buildings(chosen)
    return apply_typed(config, given)


def _per_building(config: DistrictConfig, field: str, drop: Sequence[str]) -> DistrictConfig:
    """Every building with the names in ``drop`` removed from its ``field`` (active observations or actions;
    ``electric_vehicle_storage`` also drops each charger's action)."""
    def keep(name: str) -> bool:
        return name not in drop and not any(name.startswith(f"{d}_") and d == "electric_vehicle_storage"
                                            for d in drop)

    return config.replace(buildings=tuple(
        dataclasses.replace(b, **{field: tuple(n for n in getattr(b, field) if keep(n))}) for b in config.buildings))


def _flat_names(value: Any, keyword: str) -> list[str]:
    """A list of names for every building; per-building lists of lists are not supported."""
    if isinstance(value, str) or not isinstance(value, Sequence) or any(not isinstance(v, str) for v in value):
        raise SchemaError("expected one list of names for every building (per-building lists are not "
                          "supported)", column=keyword)
    return list(value)


def _known(names: Any, known: set[str], keyword: str) -> None:
    """One SchemaError line naming the first of ``names`` that is not in ``known``."""
    unknown = [n for n in _flat_names(names, keyword) if n not in known]
    if unknown:
        raise SchemaError(f"unknown name {unknown[0][:80]!r}; known: {', '.join(sorted(known))}", column=keyword)


def _active(config: DistrictConfig, given: Mapping[str, Any]) -> DistrictConfig:
    """The observation and action keywords: shared, active and inactive names (one list for every building)."""
    if "shared_observations" in given:
        shared = set(_flat_names(given["shared_observations"], "shared_observations"))
        _known(sorted(shared), {n for n, _ in config.observations}, "shared_observations")
        config = config.replace(observations=tuple((n, n in shared) for n, _ in config.observations))
    if "active_observations" in given:
        config = config.with_observations(_flat_names(given["active_observations"], "active_observations"),
                                          shared=config.shared_observations)
    if "inactive_observations" in given:
        _known(given["inactive_observations"], {n for n, _ in config.observations}, "inactive_observations")
        config = _per_building(config, "active_observations",
                               _flat_names(given["inactive_observations"], "inactive_observations"))
    if "active_actions" in given:
        config = config.with_actions(_flat_names(given["active_actions"], "active_actions"))
    if "inactive_actions" in given:
        _known(given["inactive_actions"], {a for b in config.buildings for a in b.active_actions} | set(ACTION_NAMES),
               "inactive_actions")
        config = _per_building(config, "active_actions", _flat_names(given["inactive_actions"], "inactive_actions"))
    return config


def _devices(config: DistrictConfig, given: Mapping[str, Any]) -> DistrictConfig:
    """``simulate_power_outage`` (False: none; True: the schema must define some) and ``solar_generation=False``."""
    if given.get("simulate_power_outage") is False:
        config = config.without_outages()
    elif given.get("simulate_power_outage") and not any(b.outage.simulate for b in config.buildings):
        raise SchemaError("no building of the schema defines power outages to simulate",
                          column="simulate_power_outage")
    if given.get("solar_generation") is False:
        config = config.without_devices("pv")
    return config


def apply_typed(config: DistrictConfig, given: Mapping[str, Any]) -> DistrictConfig:
    """``config`` with the typed keywords in ``given`` applied (upstream's meaning of each keyword)."""
    replace = {k: given[k] for k in ("central_agent", "rolling_episode_split", "random_episode_split",
                                     "seconds_per_time_step", "random_seed") if k in given}
    if replace:
        config = config.replace(**{k: (bool(v) if k.endswith(("agent", "split")) else v) for k, v in replace.items()})
    if "episode_time_steps" in given:
        config = config.with_episode(given["episode_time_steps"])
    return _devices(_active(config, given), given)


__all__ = ["KEYWORD_TYPES", "READ_KEYWORDS", "check_keywords", "TYPED_KEYWORDS", "apply_typed", "plain_numbers", "raw_schema", "read_config",
           "resolve_schema"]
