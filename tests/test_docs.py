"""The documentation points at things that exist (issue 47, item 8).

For docs/*.md, README.md and benchmarks/README.md: every relative markdown link resolves to a file, and its
``#anchor`` to a heading of that file; every repository path written in backticks or a code block
(``pipeline/...``, ``citylearn_env/...``, ``surrogates/...``, ``benchmarks/...``, ``tests/...``, ``tools/...``)
exists; every dotted name of the project's modules in backticks (``pipeline.paper.results.results_table``)
names a module that exists and, below it, a name that module defines or imports; and every quoted section a
document cites in another markdown file (``benchmarks/README.md, "Surrogate trainer speed"``) is a heading
there. Reads files only; needs nothing outside the repository.
"""

from __future__ import annotations

import ast
import re
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md", ROOT / "benchmarks" / "README.md"]
PACKAGES = ("pipeline", "citylearn_env", "surrogates", "benchmarks")
PATH_PREFIXES = (*(p + "/" for p in PACKAGES), "tests/", "tools/")

LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
CODE_SPAN = re.compile(r"`([^`\n]+)`")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
DOTTED = re.compile(r"^(?:" + "|".join(PACKAGES) + r")(?:\.[A-Za-z_]\w*)+$")
SUFFIXES = {"py", "md", "json", "csv", "toml", "pth", "png", "parquet", "txt", "epw", "xlsx"}
SECTION = re.compile(r"([\w./-]+\.md)\)?[,:]?\s*\(?(?:section |sections? )?\"([^\"]+)\"")


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation other than '-' and '_' dropped, spaces to '-'."""
    text = re.sub(r"[`*]", "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


@cache
def _headings(path: Path, bold: bool = False) -> tuple[str, ...]:
    """The headings of a markdown file (outside code blocks), as written; with ``bold`` also the bold leads
    that open a paragraph (``**Cooling compares weathers as much as houses.**``), which documents cite too."""
    text = FENCE.sub("", path.read_text())
    heads = [m.group(1).strip() for m in re.finditer(r"^#{1,6}\s+(.+)$", text, re.M)]
    if bold:
        heads += [m.group(1) for m in re.finditer(r"^\*\*([^*]+)\*\*", text, re.M)]
    return tuple(heads)


def _code_tokens(text: str) -> list[tuple[int, str]]:
    """(line, token) for every whitespace-separated token inside a code span or a fenced block."""
    found = []
    for block in FENCE.finditer(text):
        first = text.count("\n", 0, block.start()) + 1
        for offset, line in enumerate(block.group(0).split("\n")[1:-1], start=1):
            found += [(first + offset, tok) for tok in line.split()]
    outside = FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for span in CODE_SPAN.finditer(outside):
        line = outside.count("\n", 0, span.start()) + 1
        found += [(line, tok) for tok in span.group(1).split()]
    return found


def _clean(token: str) -> str:
    """A token without surrounding punctuation or a ``:line`` suffix."""
    token = token.strip("'\"()[],;{}")
    return re.sub(r":\d+(-\d+)?$", "", token).rstrip(".:")


@cache
def _module_names(path: Path) -> frozenset[str]:
    """Top-level names a module defines, assigns or imports (and ``__all__``)."""
    tree = ast.parse(path.read_text())
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names |= {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.If | ast.Try):
            names |= {n.name for n in ast.walk(node) if isinstance(n, ast.FunctionDef | ast.ClassDef)}
    return frozenset(names)


def _class_members(path: Path, cls: str) -> frozenset[str]:
    """Methods and class-level names of ``cls`` in the module at ``path``."""
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.ClassDef) and node.name == cls:
            names = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
            names |= {t.id for n in node.body if isinstance(n, ast.AnnAssign) for t in [n.target]
                      if isinstance(t, ast.Name)}
            names |= {t.id for n in node.body if isinstance(n, ast.Assign) for t in n.targets
                      if isinstance(t, ast.Name)}
            return frozenset(names)
    return frozenset()


def dotted_problem(name: str) -> str | None:
    """Why ``name`` (``package.module.attr[.member]``) does not resolve in the repository, or None."""
    parts = name.split(".")
    module = None
    for end in range(len(parts), 0, -1):
        base = ROOT.joinpath(*parts[:end])
        for candidate in (base.with_suffix(".py"), base / "__init__.py"):
            if candidate.is_file():
                module, rest = candidate, parts[end:]
                break
        if module:
            break
    if module is None:
        return f"no module {parts[0]}"
    if not rest:
        return None
    if (module.parent / (rest[0] + ".py")).is_file() or (module.parent / rest[0]).is_dir():
        return None if module.name == "__init__.py" and len(rest) == 1 else _rest_problem(module, rest)
    if rest[0] not in _module_names(module):
        return f"{module.relative_to(ROOT)} defines no {rest[0]!r}"
    if len(rest) > 1 and (members := _class_members(module, rest[0])) and rest[1] not in members:
        return f"{module.relative_to(ROOT)}: class {rest[0]} has no {rest[1]!r}"
    return None


def path_problem(token: str) -> str | None:
    """Why the repository path ``token`` does not resolve, or None. ``file.py::test_name`` needs the test in
    the file; ``folder/module.name`` (a module path with an attribute) needs the name in the module."""
    path, _, test = token.partition("::")
    if (ROOT / path).exists():
        if test and test.split("[")[0] not in _module_names(ROOT / path):
            return f"{path} has no {test!r}"
        return None
    stem, dot, attr = path.rpartition(".")
    if dot and "/" not in attr and (ROOT / (stem + ".py")).is_file():
        return dotted_problem(stem.replace("/", ".") + "." + attr)
    return "no such file or folder"


def _rest_problem(module: Path, rest: list[str]) -> str | None:
    return dotted_problem(".".join([*module.parent.relative_to(ROOT).parts, *rest]))


def _link_problems(doc: Path, text: str) -> list[str]:
    """Relative markdown links of ``text`` (in ``doc``) to a missing file or heading."""
    problems = []
    for match in LINK.finditer(text):
        target = match.group(1)
        if re.match(r"[a-z]+:", target):
            continue
        line = text.count("\n", 0, match.start()) + 1
        file_part, _, anchor = target.partition("#")
        path = (doc.parent / file_part).resolve() if file_part else doc
        if not path.exists():
            problems.append(f"{line}: link to missing {target}")
        elif anchor and path.suffix == ".md" and anchor not in {_slug(h) for h in _headings(path)}:
            problems.append(f"{line}: no heading #{anchor} in {file_part or doc.name}")
    return problems


def _code_problems(text: str) -> list[str]:
    """Repository paths and dotted project names in code spans and blocks that do not resolve."""
    problems = []
    for line, token in _code_tokens(text):
        token = _clean(token)
        if token.startswith(PATH_PREFIXES) and not re.search(r"[<>*{$]|\.\.\.|-v\d+$", token):
            why = path_problem(token)
        elif DOTTED.match(token) and token.rsplit(".", 1)[1] not in SUFFIXES:
            why = dotted_problem(token)
        else:
            continue
        if why:
            problems.append(f"{line}: {token}: {why}")
    return problems


def _section_problems(doc: Path, text: str) -> list[str]:
    """Quoted sections cited in another markdown file (``docs/build.md, "Surrogate cache"``) that it lacks."""
    problems = []
    for match in SECTION.finditer(text):
        cited, title = match.group(1), " ".join(match.group(2).split())
        path = next((p for p in ((doc.parent / cited), ROOT / cited) if p.is_file()), None)
        line = text.count("\n", 0, match.start()) + 1
        if path is None:
            problems.append(f"{line}: cites missing {cited}")
        elif not any(title.lower() in h.lower() for h in _headings(path, bold=True)):
            problems.append(f"{line}: {cited} has no section {title!r}")
    return problems


def _problems(doc: Path, text: str | None = None) -> list[str]:
    """Every dangling reference of the markdown file ``doc`` (its ``text`` when given), one line each."""
    text = doc.read_text() if text is None else text
    where = doc.relative_to(ROOT)
    found = _link_problems(doc, text) + _code_problems(text) + _section_problems(doc, text)
    return [f"{where}:{problem}" for problem in found]


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_references_resolve(doc: Path) -> None:
    """Every link, repository path, dotted name and cited section of ``doc`` exists."""
    problems = _problems(doc)
    assert not problems, "\n".join(problems)


def test_checker_catches_what_it_should() -> None:
    """The checker itself: a missing link, anchor, path, name and section are each reported; real ones not."""
    assert dotted_problem("pipeline.paper.results.results_table") is None
    assert dotted_problem("pipeline.paper.results.no_such_table") is not None
    assert dotted_problem("pipeline.no_such_module") is not None
    assert dotted_problem("citylearn_env.dynamics.LSTMBank") is None
    assert _slug("2. Sources (csv | FMU)") == "2-sources-csv--fmu"
    probe = ('[a](architecture.md) [b](architecture.md#recipes) [c](nowhere.md) [d](architecture.md#nope)\n'
                   '`pipeline/paper/results.py` `pipeline/paper/gone.py` `pipeline.paper.results.gone`\n'
                   'see docs/architecture.md, "Recipes" and docs/architecture.md, "No such part"\n')
    problems = _problems(ROOT / "docs" / "probe.md", probe)
    joined = "\n".join(problems)
    assert len(problems) == 5, joined
    assert path_problem("pipeline/ingest/eulp.citylearn_building") is None
    assert path_problem("tests/test_docs.py::test_references_resolve") is None
    assert path_problem("tests/test_docs.py::test_gone") is not None
    for part in ("nowhere.md", "#nope", "gone.py", "results.gone", "No such part"):
        assert part in joined


CODE = sorted(p for package in (*PACKAGES, "tests", "tools") for p in (ROOT / package).rglob("*.py")
              if p != Path(__file__).resolve())
CODE_CITATION = re.compile(r"(docs/[\w-]+\.md|benchmarks/README\.md),?\s+(?:section\s+)?\"([A-Za-z][^\"()=,]{2,80})\"")


def test_code_cites_existing_documents_and_sections() -> None:
    """Comments and docstrings that cite a document (``docs/energyplus.md, "Cooling realism"``) name a file
    that exists and, when they quote one, a section it has."""
    problems = []
    for path in CODE:
        text = path.read_text()
        where = path.relative_to(ROOT)
        for match in re.finditer(r"\b(docs/[\w-]+\.md|benchmarks/README\.md)", text):
            if not (ROOT / match.group(1)).is_file():
                problems.append(f"{where}: cites missing {match.group(1)}")
        for match in CODE_CITATION.finditer(text):
            cited, title = match.group(1), " ".join(re.sub(r"\n\s*#:?", " ", match.group(2)).split())
            if not any(title.lower() in h.lower() for h in _headings(ROOT / cited, bold=True)):
                problems.append(f"{where}: {cited} has no section {title!r}")
    assert not problems, "\n".join(problems)
