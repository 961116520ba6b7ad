"""How far the corrected default moves the golden scenarios from the CityLearn 2.1 preset's numbers.

    .venv/bin/python benchmarks/compat_deltas.py

Runs the four golden scenarios of ../shared/reference/citylearn-2.1.2 with settings=CITYLEARN_2_1 and
settings=CORRECTED and prints district net consumption, cost, the LSTM temperature difference and a few KPIs
side by side.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from citylearn_env.settings import CITYLEARN_2_1, CORRECTED  # noqa: E402
from tests.citylearn_env.golden import run_scenario  # noqa: E402

KPIS = ("cost_total", "discomfort_proportion", "daily_peak_average", "power_outage_normalized_unserved_energy_total")


def main() -> None:
    print("| scenario | quantity | CITYLEARN_2_1 preset | CORRECTED (default) |")
    print("|---|---|---|---|")
    for scenario in ("no_control", "storage_pv_random", "full_random", "full_random_outage"):
        runs = {upstream: run_scenario(scenario, settings=CITYLEARN_2_1 if upstream else CORRECTED)
                for upstream in (True, False)}
        series = {c: env.series() for c, env in runs.items()}
        kpis = {c: env.evaluate().query("name == 'District'").set_index("cost_function")["value"]
                for c, env in runs.items()}
        net = {c: s["net_electricity_consumption"].sum() for c, s in series.items()}
        print(f"| {scenario} | district net kWh | {net[True]:.2f} | {net[False]:.2f} |")
        dt = np.abs(series[True]["indoor_dry_bulb_temperature"] - series[False]["indoor_dry_bulb_temperature"])
        print(f"| {scenario} | max / mean abs indoor T change degC | 0 | {dt.max():.3f} / {dt.mean():.3f} |")
        for k in KPIS:
            print(f"| {scenario} | {k} | {kpis[True][k]:.4f} | {kpis[False][k]:.4f} |")


if __name__ == "__main__":
    main()
