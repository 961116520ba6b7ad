"""Validation of a built district: the environment loads the schema and runs no control and the cost RBC;
KPI tables and the report.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env import load_schema
from pipeline.builder.report import oracle_bounds, report_series, write_report
from pipeline.controllers import run_policy


def validate_district(schema_path: Path, report_dir: Path, name: str | None = None,
                      schema: Mapping[str, Any] | None = None) -> dict:
    """Load the schema once, run no control and the cost RBC on it; write KPI tables and the report.

    ``schema``: the schema as a dict when the caller has it (else ``schema_path`` is read for the report).
    """

    report_dir.mkdir(parents=True, exist_ok=True)
    district = load_schema(schema_path)
    results, envs = {}, {}
    for policy in ("no_control", "cost_rbc"):
        env = envs[policy] = run_policy(district, policy)
        kpis = env.evaluate()
        kpis.to_csv(report_dir / f"kpis_{policy}.csv", index=False)
        objectives = env.objectives()
        results[policy] = {"objectives": {k: v for k, v in objectives.items() if np.isscalar(v)},
                           "per_building": objectives["per_building"], "kpis": kpis, "series": report_series(env)}
    schema = dict(schema) if schema is not None else json.loads(Path(schema_path).read_text())
    write_report(report_dir, name or schema_path.parent.name, schema, results, schema_path.parent / "surrogates",
                 bounds=oracle_bounds(district, env=envs["no_control"]))
    return results
