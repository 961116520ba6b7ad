"""The build report: ``report/summary.md`` (sizing, surrogate fit, objectives) and ``report/district_net.png``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def write_report(report_dir: Path, name: str, schema: dict, results: dict, surrogates_dir: Path) -> Path:
    """Write summary.md and the district net-load plot; ``results`` maps policy -> objectives and net (T,)."""
    lines = [f"# District {name}", "", "## Devices (sized by pipeline/sizing.py)", "",
             "| building | heat pump kW | DHW heater kW | DHW tank kWh | battery kWh / kW | PV kWp |",
             "|---|---|---|---|---|---|"]
    for building, spec in schema["buildings"].items():
        if not spec.get("include", True):
            continue
        attrs = {k: (spec.get(k) or {}).get("attributes", {}) for k in
                 ("cooling_device", "dhw_device", "dhw_storage", "electrical_storage", "pv")}
        lines.append(f"| {building} | {attrs['cooling_device'].get('nominal_power', 0):.2f} | "
                     f"{attrs['dhw_device'].get('nominal_power', 0):.2f} | {attrs['dhw_storage'].get('capacity', 0):.2f} | "
                     f"{attrs['electrical_storage'].get('capacity', 0):.1f} / "
                     f"{attrs['electrical_storage'].get('nominal_power', 0):.2f} | {attrs['pv'].get('nominal_power', 0):.2f} |")
    metrics = sorted(surrogates_dir.glob("*.metrics.json")) if surrogates_dir.is_dir() else []
    if metrics:
        lines += ["", "## Surrogates (held-out runs, closed loop)", "",
                  "| building | monthly RMSE median / max degC | training s |", "|---|---|---|"]
        for path in metrics:
            m = json.loads(path.read_text())
            rmse = m["test"]["monthly_rmse_c"]
            lines.append(f"| {m['building']} | {rmse['median']:.2f} / {rmse['max']:.2f} | "
                         f"{m['training'].get('train_seconds', float('nan')):.1f} |")
    policies = list(results)
    lines += ["", "## Objectives over the period", "", "| objective | " + " | ".join(policies) + " |",
              "|---|" + "---|" * len(policies)]
    for key in results[policies[0]]["objectives"]:
        lines.append(f"| {key} | " + " | ".join(f"{results[p]['objectives'][key]:.3f}" for p in policies) + " |")
    lines += ["", "![district net consumption](district_net.png)"]
    (report_dir / "summary.md").write_text("\n".join(lines) + "\n")
    _plot(report_dir / "district_net.png", {p: r["net"] for p, r in results.items()})
    return report_dir / "summary.md"


def _plot(path: Path, series: dict[str, np.ndarray]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 3.2))
    for label, values in series.items():
        ax.plot(np.arange(values.size), values, lw=0.8, label=label.replace("_", " "))
    ax.set_xlabel("time step [h]")
    ax.set_ylabel("district net consumption [kWh]")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
