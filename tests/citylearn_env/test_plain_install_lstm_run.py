"""A plain ``pip install districtgen`` (no torch, no numba, no pipeline extra) runs an LSTM data set through the
CLI: ``districtgen run --schema`` on upstream's v2.4.2 citylearn_challenge_2023_phase_3_1 (LSTM dynamics, .pth
weights read without torch, the numpy LSTM path), shortened to 200 time steps in a scratch copy (2 MB)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from tests.conftest import BLOCK_IMPORTS, ROOT, SHARED, need_shared

DATASET = SHARED / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2023_phase_3_1"
#: the extras' import names a plain install lacks (pipeline extra, torch, numba)
ABSENT = ("prefect", "pydantic", "fastapi", "pvlib", "pyarrow", "openpyxl", "sklearn", "torch", "tqdm",
          "matplotlib", "rich", "highspy", "numba")
#: runs the CLI with ABSENT unimportable, then reports which of them got imported anyway (none can)
RUNNER = BLOCK_IMPORTS + """
import json
from pipeline.cli import main
status = main(sys.argv[2:])
from citylearn_env import lstm_kernels
print(json.dumps({"status": status, "numba_kernel": lstm_kernels.get_numba_kernel() is not None}))
"""


def test_cli_runs_an_lstm_dataset_without_torch_or_numba(tmp_path: Path) -> None:
    need_shared(DATASET / "schema.json")
    folder = tmp_path / "dataset"  # a copy: a schema's root_directory may not point outside its own folder
    shutil.copytree(DATASET, folder)
    path = folder / "schema.json"
    schema = json.loads(path.read_text())
    schema["simulation_end_time_step"] = schema["simulation_start_time_step"] + 199
    path.write_text(json.dumps(schema))
    done = subprocess.run([sys.executable, "-c", RUNNER, ",".join(ABSENT), "run", "--schema", str(path),
                           "--policy", "random"], cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report == {"status": 0, "numba_kernel": False}
    assert "(6 buildings, 200 time steps, policy random)" in done.stdout
    assert "discomfort" in done.stdout and "nan" not in done.stdout.split("objectives")[-1].lower()
