"""Property-based fuzzing (hypothesis) of the two loaders a user feeds: ``citylearn_env.load_schema`` and
``pipeline.config.parse_build_config``.

A random mutation of a valid document (a value replaced by random JSON/TOML data, a key deleted, an unknown
key added, at any depth) either loads, or raises the project's own error type with ONE line that names the
mutated key (or, for a changed file name, the file). Any other exception escaping is a failure.
"""

from __future__ import annotations

import atexit
import copy
import json
import math
import os
import shutil
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import pytest

# hypothesis keeps caches in ./.hypothesis unless told otherwise: keep the working tree clean
if "HYPOTHESIS_STORAGE_DIRECTORY" not in os.environ:
    os.environ["HYPOTHESIS_STORAGE_DIRECTORY"] = tempfile.mkdtemp(prefix="districtgen_hypothesis_")
    atexit.register(shutil.rmtree, os.environ["HYPOTHESIS_STORAGE_DIRECTORY"], ignore_errors=True)
hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from citylearn_env import SchemaError, load_schema  # noqa: E402
from citylearn_env.errors import InputError  # noqa: E402
from citylearn_env.example import write_example_district  # noqa: E402
from pipeline.config import parse_build_config  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FUZZ = settings(max_examples=int(os.environ.get("FUZZ_EXAMPLES", "300")), deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

_scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.sampled_from([0, 1, -1, 0.5, 1e308, 1e6, "", ".", "..", "../x", "/etc/hostname", "inf", "nan"]),
)
_values = st.recursive(_scalars, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                         st.dictionaries(st.text(max_size=8), inner, max_size=3)),
                       max_leaves=6)


def _paths(doc: Any, prefix: tuple = ()) -> list[tuple]:
    """Every key path of a JSON-like document (dict keys and list indices), parents before children."""
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, value in items:
        out.append((*prefix, key))
        out.extend(_paths(value, (*prefix, key)))
    return out


@st.composite
def mutations(draw, base: dict) -> tuple[dict, tuple, str, Any]:
    """``(mutated copy, path, operation, new value)``: replace, delete or add-unknown-key at a random path."""
    doc = copy.deepcopy(base)
    paths = _paths(doc)
    path = draw(st.sampled_from(paths))
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    operation = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
    value = draw(_values)
    if operation == "replace":
        parent[path[-1]] = value
    elif operation == "delete" and isinstance(parent, dict):
        del parent[path[-1]]
    elif isinstance(parent, dict):
        name = draw(st.text(min_size=1, max_size=10).filter(lambda k: k not in parent))
        parent[name] = value
        path = (*path[:-1], name)
    else:
        operation = "none"
    return doc, path, operation, value


def _names(path: tuple, value: Any) -> list[str]:
    """What an error about this mutation may name: a key of the path (the deepest first), or the new text."""
    keys = [str(k) for k in reversed(path) if isinstance(k, str)]
    return keys + ([value] if isinstance(value, str) and value else [])


def _check_one_line(error: Exception, path: tuple, value: Any) -> None:
    text = str(error)
    assert "\n" not in text and "Traceback" not in text, text
    assert any(name in text or repr(name)[1:-1] in text for name in _names(path, value)[:3]), (path, text)


# ------------------------------------------------------------------------------ the schema loader
@pytest.fixture(scope="module")
def schema_base(tmp_path_factory) -> dict:
    path = write_example_district(tmp_path_factory.mktemp("fuzz_district"), n_buildings=2, hours=24, seed=3)
    raw = json.loads(path.read_text())
    raw["root_directory"] = str(path.parent)
    raw["buildings"]["Building_1"]["power_outage"] = {
        "simulate_power_outage": True, "stochastic_power_outage": True,
        "stochastic_power_outage_model": {"type": "citylearn.power_outage.ReliabilityMetricsPowerOutage",
                                          "attributes": {"saifi": 1.4, "caidi": 300.0}}}
    load_schema(raw)  # the base is valid
    return raw


def _fuzz(base: dict, load, error_type: type[Exception], names_file: str | None = None) -> None:
    """Run ``load`` on mutations of ``base``: it returns, or raises ``error_type`` as one line naming the key
    (and starting with ``names_file`` when given)."""

    @FUZZ
    @given(mutations(base))
    def run(mutation):
        doc, path, _, value = mutation
        try:
            load(doc)
        except error_type as error:
            _check_one_line(error, path, value)
            assert names_file is None or str(error).startswith(names_file), str(error)

    run()


def test_schema_loader_mutations_only_raise_schema_errors_naming_the_key(schema_base):
    _fuzz(schema_base, load_schema, SchemaError)


def test_schema_file_mutations_name_the_file(schema_base):
    """The same through a file: JSON with NaN/Infinity literals, and the file named in every message."""
    schema = Path(schema_base["root_directory"]) / "fuzz_schema.json"

    def load(doc: dict) -> None:
        schema.write_text(json.dumps(doc))
        load_schema(schema)

    _fuzz({k: v for k, v in schema_base.items() if k != "root_directory"}, load, SchemaError,
          names_file=str(schema.parent))


# ------------------------------------------------------------------------------ the build-config loader
@pytest.fixture(scope="module")
def config_base() -> dict:
    data = tomllib.loads((ROOT / "tests" / "fixtures" / "synthetic_district" / "district.toml").read_text())
    parse_build_config(data, file="district.toml")
    return data


def test_build_config_mutations_only_raise_input_errors_naming_the_key(config_base):
    def load(doc: dict) -> None:
        config = parse_build_config(doc, file="district.toml")
        assert all(math.isfinite(v) for v in _numbers(config.model_dump()))   # what validated is finite

    _fuzz(config_base, load, InputError, names_file="district.toml")


def _numbers(doc: Any) -> list[float]:
    if isinstance(doc, dict):
        return [n for v in doc.values() for n in _numbers(v)]
    if isinstance(doc, list | tuple):
        return [n for v in doc for n in _numbers(v)]
    return [doc] if isinstance(doc, float) else []
