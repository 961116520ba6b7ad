"""The per-house surrogate warning survives the build flow: the flow runs with Prefect's ``log_prints``, which
turns a ``print`` into an INFO record of the run logger, and `make run` keeps only Prefect's warnings
(PREFECT_LOGGING_LEVEL=WARNING). A real flow on the build's temporary Prefect server on 127.0.0.1, in a
process of its own."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]

#: a flow like the build's (log_prints) that checks one house over the bound, on the build's own server
FLOW = """
from prefect import flow
from pipeline.flows import prefect_api
from pipeline.builder.surrogates import check_surrogate_errors

record = {"median_c": 0.31, "worst_c": 0.42, "passes": False, "judge_ilv": {"timesteps_per_hour": 20, "seed": 7}}

@flow(name="judged", log_prints=True)
def judged():
    check_surrogate_errors({"Building_3": record})

with prefect_api():
    judged()
"""


def test_a_house_over_the_bound_is_one_warning_line_on_stderr_inside_the_flow(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_HOME": str(tmp_path / "prefect"),
           "PREFECT_LOGGING_LEVEL": "WARNING", "PREFECT_SERVER_ANALYTICS_ENABLED": "false"}
    env.pop("PREFECT_API_URL", None)
    proc = subprocess.run([sys.executable, "-c", FLOW], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("districtgen: warning:")]
    assert lines == ["districtgen: warning: Building_3: surrogate misses the bound against a fresh EnergyPlus "
                     "run (20 timesteps/h, seed 7): monthly RMSE median 0.31 degC > 0.25"], proc.stderr
