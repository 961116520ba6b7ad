"""``env.load_agent()``: the agent a schema's ``agent`` block names (``{"type": ..., "attributes": {...}}``), built
as upstream builds it: ``Class(env=env, **attributes)``.

Which class a type string names (the rule of the reward functions, docs/compat.md):

1. upstream's ``citylearn.agents.<module>.<Class>`` (or this package's ``citylearn_env.compat.agents...``): the
   compat class of that name (``base``, ``rbc``, ``sac``, ``q_learning``, ``marlisa``);
2. ``module.Class`` of a module the running program has imported (or, as ``__main__``, defines) with a
   ``predict`` method: that class, so the program's own agent runs;
3. anything else: one SchemaError line. A schema never makes the project import the program's code.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping
from typing import Any

from citylearn_env.errors import SchemaError

MODULES = ("base", "rbc", "sac", "q_learning", "marlisa")
PREFIXES = ("citylearn.agents.", "citylearn_env.compat.agents.")


def agent_class(name: Any) -> type:
    """The agent class a type string names (module docstring); one SchemaError line otherwise."""
    if not isinstance(name, str) or not name or len(name) > 300:
        raise SchemaError(f"expected a dotted class name, got {str(name)[:100]!r}", column="agent.type")
    for prefix in PREFIXES:
        if name.startswith(prefix):
            module_name, _, class_name = name[len(prefix):].rpartition(".")
            if module_name in MODULES:
                module = importlib.import_module(f"citylearn_env.compat.agents.{module_name}")
                cls = getattr(module, class_name, None)
                if isinstance(cls, type):
                    return cls
            raise SchemaError(f"unknown agent type {name!r}: upstream's agent modules here are "
                              f"{', '.join(MODULES)}", column="agent.type")
    module_name, _, class_name = name.rpartition(".")
    cls = getattr(sys.modules.get(module_name), class_name, None) if module_name else None
    if isinstance(cls, type) and callable(getattr(cls, "predict", None)):
        return cls
    raise SchemaError(f"unknown agent type {name[:100]!r}: not upstream's and not a class the running program has "
                      "imported (a schema never makes the project import code: import its module first, or pass "
                      "load_agent(TheClass))", column="agent.type")


def load_agent(env: Any, agent: Any = None, **kwargs: Any) -> Any:
    """The agent of ``env``: ``agent`` (a class or type string; None: the schema's ``agent.type``) built with the
    schema's ``agent.attributes`` updated by ``kwargs``."""
    spec = env.schema.get("agent") or {}
    if not isinstance(spec, Mapping):
        raise SchemaError(f"expected {{\"type\": ..., \"attributes\": ...}}, got {type(spec).__name__}", column="agent")
    attributes = spec.get("attributes") or {}
    if not isinstance(attributes, Mapping):
        raise SchemaError(f"expected a dict, got {type(attributes).__name__}", column="agent.attributes")
    if agent is None:
        if "type" not in spec:
            raise SchemaError("the schema names no agent type (load_agent(TheClass) picks one)", column="agent.type")
        agent = spec["type"]
    cls = agent if isinstance(agent, type) else agent_class(agent)
    return cls(env=env, **{**attributes, **kwargs})


__all__ = ["MODULES", "agent_class", "load_agent"]
