"""The paper's result tables: mean and sample std over seeds per row, ``results.md`` (changes against the
baselines), the m-sweep table, ``results.csv`` / ``runs.csv`` and the figures.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.paper.benchmarks import BENCHMARKS, SWEEP_ID, RunOptions, Task
from pipeline.paper.figures import write_figures


def sweep_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The m-sweep table (markdown): one row per multiplier, changes against the first row (m = 1)."""
    base = rows[0]
    lines = ["| m | discomfort C h | over-cooling C (mean +- std) | under-cooling C (mean +- std) | "
             "consumption kWh | discomfort change | consumption change |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['multiplier']:g} | {r['discomfort']:.1f} | {r['overcooling_mean']:.2f} +- "
                     f"{r['overcooling_std']:.2f} | {r['undercooling_mean']:.2f} +- {r['undercooling_std']:.2f} | "
                     f"{r['consumption']:.2f} | {_change(r['discomfort'], base['discomfort'])} | "
                     f"{_change(r['consumption'], base['consumption'])} |")
    return "\n".join(lines) + "\n"


def _change(value: float, base: float) -> str:
    return f"{100.0 * (value - base) / base:+.1f} %" if base else "-"


#: per-run numbers averaged over seeds (the rest of a run's fields are labels or the trace)
METRICS = ("cost", "emissions", "discomfort", "consumption", "average_daily_peak", "overcooling_mean",
           "overcooling_std", "undercooling_mean", "undercooling_std", "mean_abs_action", "train_seconds",
           "train_cpu_seconds", "seconds")


def summarise(runs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Mean of :data:`METRICS` over ``runs`` (the seeds of one row), their sample std as ``<name>_std``,
    the number of seeds, and the first run's labels and trace."""
    first = runs[0]
    row = {k: v for k, v in first.items() if k not in METRICS}
    row["seeds"] = len(runs)
    for name in METRICS:
        values = np.array([r[name] for r in runs], dtype=float)
        row[name] = float(values.mean())
        row[f"{name}_sd"] = float(values.std(ddof=1)) if len(values) > 1 else 0.0
    return row


def write_results(out: Path, runs: Sequence[Mapping[str, Any]], tasks: Sequence[Task], *, multiplier: float,
                  only: Sequence[str] | None, sweep: Sequence[float], options: RunOptions,
                  seeds: int) -> dict[str, Any]:
    """results.csv / runs.csv / results.md / multiplier_sweep.md and the figures from the finished runs."""


    groups: dict[tuple[str, float], list] = {}
    for task, run in zip(tasks, runs, strict=True):
        groups.setdefault((task.id, task.multiplier), []).append(run)
    order = [b.id for b in BENCHMARKS if only is None or b.id in only]
    results = [summarise(groups[(i, multiplier)]) for i in order]
    swept = [summarise(groups[(SWEEP_ID, float(m))]) for m in sweep]
    plain = [{k: v for k, v in r.items() if k != "trace"} for r in runs]
    pd.DataFrame(plain).to_csv(out / "runs.csv", index=False)
    if results:
        pd.DataFrame([{k: v for k, v in r.items() if k != "trace"} for r in results]).to_csv(
            out / "results.csv", index=False)
        (out / "results.md").write_text(results_table(results, options, seeds))
    if swept:
        (out / "multiplier_sweep.md").write_text(sweep_table(swept))
    write_figures(out, results, swept)
    return {"results": results, "sweep": swept, "runs": list(runs)}


def _pm(row: Mapping[str, Any], name: str, digits: int) -> str:
    value = f"{row[name]:.{digits}f}"
    return value + (f" ± {row[name + '_sd']:.{digits}f}" if row["seeds"] > 1 else "")


def results_table(results: Sequence[Mapping[str, Any]], options: RunOptions, seeds: int) -> str:
    """results.md: the roles, the options, and one line per benchmark (mean ± std over seeds for SAC rows),
    with B1's cost and emissions as a change against both no-control baselines when they were run."""
    by_id = {r["id"]: r for r in results}
    roles = ", ".join(f"{role} = {name}" for role, name in zip(("B1", "B2"), options.roles or (), strict=False))
    ran = sorted({r.get("precision", "-") for r in results} - {"-"})
    threads = sorted({r.get("sac_threads", 0) for r in results} - {0})
    precision = (f" in {' and '.join(ran)} (--precision {options.precision}) on "
                 f"{' or '.join(map(str, threads))} thread(s)") if ran else ""
    lines = [f"Buildings: {roles}. Rules: {options.rules}. Environment: "
             f"{'CityLearn 2.1 preset' if options.compat else 'corrected'}. SAC: {options.sac}{precision}, "
             f"{options.sac_episodes} episodes, {seeds} seed(s) (SAC rows: mean ± std).", "",
             "| benchmark | buildings | cost $ | emissions kg | discomfort C h | consumption kWh | avg daily peak kW "
             "| cost vs x / x-pv | emissions vs x / x-pv |", "|---|---|---|---|---|---|---|---|---|"]
    base = [by_id.get("x-b1_b2-x-x"), by_id.get("x-b1_b2-x-pv")]
    for r in results:
        changes = [" / ".join(_percent(r[k], b[k]) if b else "-" for b in base) for k in ("cost", "emissions")]
        lines.append(f"| {r['id']} | {r['buildings']} | {_pm(r, 'cost', 3)} | {_pm(r, 'emissions', 2)} | "
                     f"{_pm(r, 'discomfort', 1)} | {_pm(r, 'consumption', 2)} | {_pm(r, 'average_daily_peak', 3)} | "
                     f"{changes[0]} | {changes[1]} |")
    return "\n".join(lines) + "\n"


def _percent(value: float, base: float) -> str:
    return f"{100.0 * (value - base) / base:+.1f} %" if base else "-"
