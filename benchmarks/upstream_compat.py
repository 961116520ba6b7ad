"""Does an emitted district run in upstream CityLearn 2.1.2, with the same numbers as citylearn_env?

    .venv/bin/python benchmarks/upstream_compat.py --upstream /path/to/python-with-citylearn-2.1.2

Builds the default district (raw/district.toml) in the v2.1 file layout with a short surrogate training
(2 epochs), runs one zero-action episode in upstream CityLearn (a separate interpreter) and in
``citylearn_env`` (compat=True), and prints the largest per-step differences of net consumption and indoor
temperature. Upstream 2.1.2 installs here from its PyPI wheel with ``--no-deps`` plus numpy 1.26.4, pandas
1.5.3, gym 0.26.2, scikit-learn, simplejson, matplotlib and torch.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

UPSTREAM = r"""
import json, sys, numpy as np
from citylearn.citylearn import CityLearnEnv
env = CityLearnEnv(sys.argv[1], central_agent=True)
env.reset()
done = False
while not done:
    _, _, done, _ = env.step([[0.0] * env.action_space[0].shape[0]])
print(json.dumps({"net": [list(map(float, b.net_electricity_consumption)) for b in env.buildings],
                  "temp": [list(map(float, b.indoor_dry_bulb_temperature)) for b in env.buildings]}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream", required=True, help="a Python interpreter with citylearn==2.1.2")
    args = parser.parse_args()
    import tomllib

    from citylearn_env import CityLearnEnv
    from pipeline.builder.driver import build_district_local
    from pipeline.config import parse_build_config

    data = tomllib.loads((ROOT / "raw" / "district.toml").read_text())
    data["layout"], data["surrogate"]["epochs"] = "v2.1", 2
    config = parse_build_config(data, file="raw/district.toml (v2.1 layout)", base=ROOT / "raw")
    with tempfile.TemporaryDirectory() as scratch:
        schema = build_district_local(config, scratch) / "schema.json"
        run = subprocess.run([args.upstream, "-c", UPSTREAM, str(schema)], capture_output=True, text=True)
        if run.returncode != 0:
            raise SystemExit(f"upstream CityLearn failed on {schema}:\n{run.stderr[-3000:]}")
        upstream = json.loads(run.stdout.strip().splitlines()[-1])
        env = CityLearnEnv(schema, compat=True)
        env.reset()
        done = False
        while not done:
            _, _, done, _, _ = env.step(np.zeros(env.action_space.shape))
        series = env.series()
    for key, name in (("net", "net_electricity_consumption"), ("temp", "indoor_dry_bulb_temperature")):
        diff = np.abs(np.array(upstream[key]) - series[name]).max()
        print(f"{name}: max |upstream - ours| = {diff:.2e} over {series[name].size} building-steps")


if __name__ == "__main__":
    main()
