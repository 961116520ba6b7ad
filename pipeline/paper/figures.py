"""The paper's figures from finished runs (each drawn only when the runs it needs are present).

* ``cost_emissions.png`` -- B1's test-period cost [$] and emissions [kg CO2e] per benchmark, with the two
  no-control baselines (without PV, with PV) as horizontal lines; error bars = std over seeds.
* ``actions_soc.png`` -- the agent's action and the storage SOC of B1 over the first 7 test days for each
  learning DHW / battery benchmark; TOU periods shaded by price level, carbon intensity as a filled area.
* ``daily_peak.png`` -- the district's daily peak [kW] per test day: no control with PV, peak RBC, peak SAC.
* ``soc_trajectories.png`` -- B1's storage SOC [-] over the first 7 test days under the oracle, MPC, the RBC
  and SAC, one panel per storage configuration (battery solid, DHW tank dashed); TOU periods shaded.

The m-sweep table is markdown (``multiplier_sweep.md``, :func:`pipeline.paper.sweep_table`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from citylearn_env.outputs import write_output

#: the figures' file names, in drawing order
FIGURES = ("cost_emissions.png", "actions_soc.png", "daily_peak.png", "soc_trajectories.png")
BASELINES = ("x-b1_b2-x-x", "x-b1_b2-x-pv")
STORAGE_RL = ("rlc-b1-c-dhw", "rlc-b1-e-dhw", "rlc-b1-c-bess_pv", "rlc-b1-e-bess_pv", "rlc-b1-c-dhw_bess_pv",
              "rlc-b1-e-dhw_bess_pv")
PEAK_ROWS = ("x-b1_b2-x-pv", "rbc-b1_b2-p-bess_pv", "rlc-b1_b2-p-bess_pv")


def write_figures(out: Path, results: Sequence[Mapping[str, Any]], sweep: Sequence[Mapping[str, Any]] = (),
                  references: Mapping[str, Mapping[str, Mapping[str, Any]]] | None = None) -> list[Path]:
    """Draw every figure whose runs are in ``results`` (and ``references``: configuration -> controller ->
    run of :mod:`pipeline.paper.reference`); return the files written."""
    import matplotlib  # matplotlib loads only when a figure is drawn

    matplotlib.use("Agg")
    by_id = {r["id"]: r for r in results}
    written = []
    for name, draw in zip(FIGURES, (cost_emissions, actions_soc, daily_peak,
                                    lambda rows: soc_trajectories(rows, references or {})), strict=True):
        figure = draw(by_id)
        if figure is not None:
            written.append(write_output(out, name, lambda stream, f=figure: f.savefig(
                stream, format="png", dpi=110, bbox_inches="tight"), binary=True, column="--output"))
            import matplotlib.pyplot as plt  # matplotlib loads only when a figure is drawn

            plt.close(figure)
    return written


def cost_emissions(by_id: Mapping[str, Mapping[str, Any]]):
    """Bars of B1's cost and emissions per controlled benchmark, baselines as lines; None without rows."""
    import matplotlib.pyplot as plt  # matplotlib loads only when a figure is drawn

    rows = [r for i, r in by_id.items() if i not in BASELINES and "-b1-" in f"{i}-" and "d_o" not in i]
    if not rows:
        return None
    figure, axes = plt.subplots(1, 2, figsize=(13, 4.5), sharey=False)
    for ax, key, unit in ((axes[0], "cost", "$"), (axes[1], "emissions", "kg CO2e")):
        values = [r[key] for r in rows]
        errors = [r.get(f"{key}_sd", 0.0) for r in rows]
        colours = ["tab:orange" if r["id"].startswith("rbc") else "tab:blue" for r in rows]
        ax.bar(range(len(rows)), values, yerr=errors, color=colours, capsize=3)
        for base, style in zip(BASELINES, ("--", ":"), strict=True):
            if base in by_id:
                ax.axhline(by_id[base][key], color="k", linestyle=style, label=f"{base} (B1)")
        ax.set_xticks(range(len(rows)), [r["id"] for r in rows], rotation=60, ha="right", fontsize=8)
        ax.set_ylabel(f"B1 test-period {key} [{unit}]")
        low = min(values + [by_id[b][key] for b in BASELINES if b in by_id])
        ax.set_ylim(bottom=0.9 * low)
        if any(b in by_id for b in BASELINES):
            ax.legend(fontsize=8)
    figure.suptitle("Cost and emissions of B1 over the test period (orange: RBC, blue: SAC)")
    return figure


def actions_soc(by_id: Mapping[str, Mapping[str, Any]]):
    """Action and SOC of the learning storage benchmarks over the first 7 test days; None without rows."""
    import matplotlib.pyplot as plt  # matplotlib loads only when a figure is drawn

    rows = [by_id[i] for i in STORAGE_RL if i in by_id]
    if not rows:
        return None
    figure, axes = plt.subplots(len(rows), 1, figsize=(12, 2.4 * len(rows)), sharex=True, squeeze=False)
    for ax, row in zip(axes[:, 0], rows, strict=True):
        trace = row["trace"]
        price = np.asarray(trace["electricity_pricing"])
        steps = np.arange(len(price))
        shade_tou(ax, price)
        carbon = ax.twinx()
        carbon.fill_between(steps, trace["carbon_intensity"], color="tab:green", alpha=0.15, step="post")
        carbon.set_ylabel("kg CO2e/kWh", fontsize=7, color="tab:green")
        actions = np.asarray(trace["actions"])
        for k, name in enumerate(trace["action_names"]):
            ax.step(np.arange(1, len(actions) + 1), actions[:, k], where="pre", lw=0.9,
                    label=f"action {name.split('.')[-1]}")
        for name, colour in (("dhw_storage_soc", "tab:red"), ("electrical_storage_soc", "tab:purple")):
            soc = np.asarray(trace[name])
            if any(name.removesuffix("_soc") in a for a in trace["action_names"]):
                ax.plot(steps, soc, color=colour, lw=1.2, label=name)
        ax.set_ylim(-1.05, 1.05)
        ax.set_title(row["id"], fontsize=9, loc="left")
        ax.legend(fontsize=7, loc="lower left", ncol=4)
    axes[-1, 0].set_xlabel("hour of the test period (first 7 days); shading: TOU price level")
    return figure


def shade_tou(ax, price: np.ndarray) -> None:
    """Shade each hour by its price level: darker = more expensive (the cheapest level is not shaded)."""
    levels = np.unique(np.round(price, 6))
    for k, level in enumerate(levels[1:], start=1):
        on = np.flatnonzero(np.isclose(price, level))
        for t in on:
            ax.axvspan(t, t + 1, color="tab:gray", alpha=0.12 * k, lw=0)


def daily_peak(by_id: Mapping[str, Mapping[str, Any]]):
    """District daily peak per test day for no control + PV, peak RBC and peak SAC; None without rows."""
    import matplotlib.pyplot as plt  # matplotlib loads only when a figure is drawn

    rows = [by_id[i] for i in PEAK_ROWS if i in by_id]
    if not rows:
        return None
    figure, ax = plt.subplots(figsize=(10, 3.8))
    width = 0.8 / len(rows)
    for k, row in enumerate(rows):
        peaks = np.asarray(row["trace"]["daily_peak"])
        ax.bar(np.arange(1, len(peaks) + 1) + (k - (len(rows) - 1) / 2) * width, peaks, width=width,
               label=f"{row['id']} (mean {peaks.mean():.2f} kW)")
    ax.set_xlabel("test day")
    ax.set_ylabel("district daily peak [kW]")
    ax.legend(fontsize=8)
    return figure


#: line colour of each controller in the SOC figure
CONTROLLER_COLOURS = {"oracle": "0.55", "rbc": "tab:orange", "sac": "tab:blue", "mpc": "tab:green"}
#: line width per controller (the oracle drawn first and wide, so MPC on top of it stays visible)
CONTROLLER_WIDTHS = {"oracle": 2.6}
SOC_STYLES = (("electrical_storage_soc", "-", "battery"), ("dhw_storage_soc", "--", "DHW"))


def soc_traces(by_id: Mapping[str, Mapping[str, Any]], references: Mapping[str, Mapping[str, Mapping[str, Any]]]
               ) -> dict[str, dict[str, Mapping[str, Any]]]:
    """configuration -> controller ("rbc", "sac", "mpc", "oracle") -> trace, for the storage configurations
    with at least one run of the benchmarks' own controllers or of the references (skipped ones left out)."""
    out: dict[str, dict[str, Mapping[str, Any]]] = {}
    for i, row in by_id.items():
        algo, _, config = i.partition("-")
        if algo in ("rbc", "rlc") and any(s in config for s in ("dhw", "bess")):
            out.setdefault(config, {})["sac" if algo == "rlc" else "rbc"] = row["trace"]
    for config, runs in references.items():
        for controller, run in runs.items():
            if "trace" in run:
                out.setdefault(config, {})[controller] = run["trace"]
    return out


def soc_trajectories(by_id: Mapping[str, Mapping[str, Any]],
                     references: Mapping[str, Mapping[str, Mapping[str, Any]]]):
    """B1's storage SOC over the first 7 test days under every controller, one panel per storage
    configuration; None without any reference run (the oracle or MPC)."""
    import matplotlib.pyplot as plt  # matplotlib loads only when a figure is drawn

    traces = soc_traces(by_id, references)
    traces = {c: t for c, t in traces.items() if set(t) & {"oracle", "mpc"}}
    if not traces:
        return None
    figure, axes = plt.subplots(len(traces), 1, figsize=(12, 2.3 * len(traces)), sharex=True, squeeze=False)
    for ax, (config, runs) in zip(axes[:, 0], traces.items(), strict=True):
        first = next(iter(runs.values()))
        shade_tou(ax, np.asarray(first["electricity_pricing"]))
        for controller in CONTROLLER_COLOURS:
            trace = runs.get(controller)
            if trace is None:
                continue
            for name, style, label in SOC_STYLES:
                if any(name.removesuffix("_soc") in a for a in trace["action_names"]):
                    soc = np.asarray(trace[name])
                    ax.plot(np.arange(len(soc)), soc, style, color=CONTROLLER_COLOURS[controller],
                            lw=CONTROLLER_WIDTHS.get(controller, 1.0), label=f"{controller} {label}")
        ax.set_ylim(-0.03, 1.03)
        ax.set_ylabel("SOC [-]")
        ax.set_title(config, fontsize=9, loc="left")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1, 0].set_xlabel("hour of the test period (first 7 days); shading: TOU price level")
    figure.suptitle("B1's state of charge: oracle (wide grey), MPC (24 h), RBC and SAC", fontsize=10)
    figure.tight_layout(rect=(0.0, 0.0, 1.0, 0.985))
    return figure
