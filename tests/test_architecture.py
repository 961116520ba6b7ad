"""The dependency graph of the project's own modules (issues 26 and 47): no import cycle, no module importing a
private (``_name``) of another, and the layering of docs/architecture.md: the environment imports neither the pipeline
nor the surrogates, the surrogates do not import the pipeline, and the paper does not import the builder; no
module reads a private attribute (`obj._x`) that only another package defines; no source or test folder has a
name that common tools skip (`build`, `dist`, `env`, ...).

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
    """The longest prefix of ``name`` that is a project module (``pipeline.builder.cache.FileCache`` ->
    ``pipeline.builder.cache``)."""
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
    ("pipeline.paper", "pipeline.builder"),
])
def test_layering(graph, lower: str, upper: str) -> None:
    _, found = graph
    wrong = [f"{e.source}:{e.line} imports {e.target}" for e in found
             if (e.source == lower or e.source.startswith(lower + "."))
             and (e.target == upper or e.target.startswith(upper + "."))]
    assert wrong == []


#: folder names that common tools skip or hide: pytest's default ``norecursedirs``, the usual Python
#: .gitignore templates, packaging and structure tools (a package or test folder so named gets lost)
SKIPPED_FOLDER_NAMES = frozenset({"build", "dist", "env", "venv", ".venv", "_build", "node_modules", "site-packages",
                                  "__pypackages__", "eggs", ".eggs", "sdist", "wheels", "lib", "lib64"})
SOURCE_TREES = (*PACKAGES, "tests", "benchmarks", "tools")


def skipped_folders(root: Path) -> list[str]:
    """The folders under ``root`` (relative paths) whose name a common tool skips."""
    return sorted(str(p.relative_to(ROOT)) for p in root.rglob("*")
                  if p.is_dir() and p.name.lower() in SKIPPED_FOLDER_NAMES and "__pycache__" not in p.parts)


def test_no_source_or_test_folder_carries_a_name_that_tools_skip() -> None:
    found = [f for tree in SOURCE_TREES if (ROOT / tree).is_dir() for f in skipped_folders(ROOT / tree)]
    assert found == []
    assert "norecursedirs" not in (ROOT / "pyproject.toml").read_text()  # pytest's own default applies


def package_of(module: str) -> str:
    """The package a module lives in (``pipeline.optimal.snapshot`` -> ``pipeline.optimal``)."""
    return module.rsplit(".", 1)[0] if "." in module else module


def private_definitions(path: Path) -> set[str]:
    """Private names a file defines as attributes or members: ``self._x = ...``, ``def _x``, ``_x: T`` in a
    class body, ``__slots__`` entries."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and node.attr.startswith("_")
                and isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
            names.add(node.attr)
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.name.startswith("_"):
            names.add(node.name)
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                targets = ([item.target] if isinstance(item, ast.AnnAssign)
                           else item.targets if isinstance(item, ast.Assign) else [])
                names.update(t.id for t in targets if isinstance(t, ast.Name) and t.id.startswith("_"))
    return {n for n in names if not n.startswith("__")}


def private_accesses(path: Path) -> Iterator[tuple[int, str]]:
    """``obj._x`` (read or written) in a file where ``obj`` is not ``self`` or ``cls`` (line, attribute)."""
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
                and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))):
            yield node.lineno, node.attr


def cross_package_private(modules: dict[str, Path]) -> list[str]:
    defined: dict[str, set[str]] = {}
    for module, path in modules.items():
        defined.setdefault(package_of(module), set()).update(private_definitions(path))
    wrong = []
    for module, path in modules.items():
        own = defined[package_of(module)]
        for line, attr in private_accesses(path):
            owners = sorted(p for p, names in defined.items() if attr in names and p != package_of(module))
            if owners and attr not in own:
                wrong.append(f"{module}:{line} reads {attr} of {', '.join(owners)}")
    return wrong


def test_finds_a_planted_cross_package_private_access(tmp_path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    (tmp_path / "a" / "state.py").write_text("class S:\n    def __init__(self):\n        self._hidden = 1\n")
    (tmp_path / "b" / "user.py").write_text("def f(s):\n    return s._hidden\n")
    (tmp_path / "a" / "peer.py").write_text("def g(s):\n    return s._hidden\n")
    found = cross_package_private({"a.state": tmp_path / "a" / "state.py", "b.user": tmp_path / "b" / "user.py",
                                   "a.peer": tmp_path / "a" / "peer.py"})
    assert found == ["b.user:2 reads _hidden of a"]


def test_no_module_reads_a_private_attribute_defined_in_another_package(graph) -> None:
    modules, _ = graph
    assert cross_package_private(modules) == []
