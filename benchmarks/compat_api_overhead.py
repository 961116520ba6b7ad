"""Per-step cost of the compat layer under each API generation, side by side with the native step.

Runs the upstream v2.1.2 data set 2022 phase 1 (5 buildings, central agent, 2,000 steps) with the same action
every step, best of 3 episodes, for ``citylearn_version="2.1"`` (observations alone, four step values) and
``"2.5"`` (gymnasium's API; the 2.5 preset), and the native environment under each. Needs the shared upstream
data (``DISTRICTGEN_CITYLEARN_DATA``, default ``../shared/data/citylearn/upstream``).

    PYTHONPATH=$PWD python benchmarks/compat_api_overhead.py
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

import numpy as np

from citylearn_env.compat.citylearn import CityLearnEnv

UPSTREAM = Path(os.environ.get("DISTRICTGEN_CITYLEARN_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
                               / "citylearn" / "upstream"))
SCHEMA = UPSTREAM / "v2.1.2" / "citylearn_challenge_2022_phase_1" / "schema.json"


def per_step_us(version: str, end: int = 2000, repeats: int = 3) -> tuple[float, float]:
    """(compat, native) microseconds per step, best of ``repeats`` episodes."""
    env = CityLearnEnv(str(SCHEMA), central_agent=True, simulation_end_time_step=end, citylearn_version=version)
    compat, native = [], []
    for _ in range(repeats):
        env.reset()
        start, n = time.perf_counter(), 0
        while not env.done:
            env.step([[0.1] * 5])
            n += 1
        compat.append((time.perf_counter() - start) / n * 1e6)
        env.native.reset()
        start, n, action = time.perf_counter(), 0, np.full(5, 0.1)
        while env.native.t < env.native.episode_length - 1:
            env.native.step(action)
            n += 1
        native.append((time.perf_counter() - start) / n * 1e6)
    return min(compat), min(native)


if __name__ == "__main__":
    logging.disable(logging.WARNING)
    with open("/proc/loadavg") as f:
        print("load average:", f.read().split()[:3])
    for version in ("2.1", "2.5"):
        compat, native = per_step_us(version)
        print(f"CityLearn {version} API: compat {compat:.0f} us/step, native {native:.0f} us/step, "
              f"overhead {compat - native:.0f} us")
