"""No-control district energy of citylearn_env on upstream's v2.4.2 datasets against CityLearn 2.5.0.

The upstream side is the stored reference run `benchmarks/upstream_2_5_0/no_control.json` (made by
`benchmarks/ev_upstream.py` with CityLearn 2.5.0; every action inactive). Ours: the same schema, every action
inactive (the typed config's `with_actions([])`), one episode, in the corrected default. Prints a Markdown
table: dataset, upstream kWh, ours kWh, relative difference.

    .venv/bin/python benchmarks/fidelity_2_5.py [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from citylearn_env import CityLearnEnv, SchemaError, load_schema

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.4.2"
REFERENCE = ROOT / "benchmarks" / "upstream_2_5_0" / "no_control.json"


def no_control_energy(schema: Path) -> float:
    """District net electricity consumption [kWh] of one no-control episode (every action inactive)."""
    env = CityLearnEnv(load_schema(schema).with_actions([]))
    env.reset(seed=0)
    done = env.episode_length <= 1
    while not done:
        _, _, done, _, _ = env.step(np.zeros(0))
    return float(env.series()["net_electricity_consumption"].sum())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    reference = json.loads(REFERENCE.read_text())
    rows = []
    for name, upstream in reference.items():
        if upstream.get("mode") != "no_control":
            continue
        theirs = upstream["district_net_electricity_consumption_sum"]
        try:
            ours = no_control_energy(DATA / name / "schema.json")
        except SchemaError as error:  # e.g. the EV dataset until EVs are wired in
            rows.append({"dataset": name, "upstream_2_5_0_kwh": theirs, "ours_kwh": None, "error": str(error)})
            continue
        rows.append({"dataset": name, "upstream_2_5_0_kwh": theirs, "ours_kwh": ours,
                     "relative": (ours - theirs) / theirs})
    print(f"load average {os.getloadavg()}")
    print("| dataset | CityLearn 2.5.0 kWh | citylearn_env kWh | relative |\n|---|---|---|---|")
    for r in rows:
        if r["ours_kwh"] is None:
            print(f"| {r['dataset']} | {r['upstream_2_5_0_kwh']:,.1f} | not loaded: {r['error'][-80:]} | |")
            continue
        print(f"| {r['dataset']} | {r['upstream_2_5_0_kwh']:,.1f} | {r['ours_kwh']:,.1f} | {r['relative']:+.4%} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
