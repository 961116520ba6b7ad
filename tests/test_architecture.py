"""The dependency graph of the project's own modules (issue 26): no import cycle, no module importing a
private (``_name``) of another, and the layering of DESIGN.md: the environment imports neither the pipeline
nor the surrogates, the surrogates do not import the pipeline, and the paper does not import the build.

Every import counts, at the top of a file or inside a function. Needs nothing outside the repository."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("citylearn_env", "surrogates", "pipeline")


@dataclass(frozen=True)
class Edge:
    """``source`` imports ``target`` (both module names) at ``line`` of the source file; ``names``: what a
    ``from`` import takes."""

    source: str
    target: str
    line: int
    names: tuple[str, ...] = ()


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def project_modules() -> dict[str, Path]:
    return {module_name(p): p for package in PACKAGES for p in sorted((ROOT / package).rglob("*.py"))}


def resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is a project module (``pipeline.build.cache.FileCache`` ->
    ``pipeline.build.cache``)."""
    parts = name.split(".")
    while parts:
        if ".".join(parts) in modules:
            return ".".join(parts)
        parts.pop()
    return None


def absolute(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The absolute module a (possibly relative) ``from`` import reads from."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def edges(modules: dict[str, Path]) -> Iterator[Edge]:
    for module, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets = [(a.name, ()) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = absolute(node, module, path.name == "__init__.py")
                # `from package import submodule` imports the submodule; `from module import name` the module
                targets = [(f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base, (a.name,))
                           for a in node.names]
            else:
                continue
            for name, names in targets:
                target = resolve(name, modules)
                if target is not None and target != module:
                    yield Edge(module, target, node.lineno, names)


def reachable(graph: dict[str, set[str]], start: str) -> set[str]:
    """Every module ``start`` imports, directly or through others."""
    seen: set[str] = set()
    todo = list(graph.get(start, ()))
    while todo:
        node = todo.pop()
        if node not in seen:
            seen.add(node)
            todo.extend(graph.get(node, ()))
    return seen


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The groups of modules that import each other (directly or not), each sorted; [] when acyclic."""
    reach = {node: reachable(graph, node) for node in graph}
    groups = {tuple(sorted(n for n in reach[node] if node in reach[n]))
              for node in graph if node in reach[node]}
    return sorted(list(group) for group in groups)


@pytest.fixture(scope="module")
def graph() -> tuple[dict[str, Path], list[Edge]]:
    modules = project_modules()
    return modules, list(edges(modules))


def test_finds_a_planted_cycle() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_between_project_modules(graph) -> None:
    modules, found = graph
    adjacency: dict[str, set[str]] = {m: set() for m in modules}
    for edge in found:
        adjacency[edge.source].add(edge.target)
    assert cycles(adjacency) == []


def test_no_module_imports_a_private_name_of_another(graph) -> None:
    _, found = graph
    private = [f"{e.source}:{e.line} imports {e.target}.{n}" for e in found for n in e.names
               if n.startswith("_") and not n.startswith("__")]
    private += [f"{e.source}:{e.line} imports the private module {e.target}" for e in found
                if any(part.startswith("_") and not part.startswith("__") for part in e.target.split("."))]
    assert private == []


@pytest.mark.parametrize(("lower", "upper"), [
    ("citylearn_env", "pipeline"), ("citylearn_env", "surrogates"), ("surrogates", "pipeline"),
    ("pipeline.paper", "pipeline.build"),
])
def test_layering(graph, lower: str, upper: str) -> None:
    _, found = graph
    wrong = [f"{e.source}:{e.line} imports {e.target}" for e in found
             if (e.source == lower or e.source.startswith(lower + "."))
             and (e.target == upper or e.target.startswith(upper + "."))]
    assert wrong == []
