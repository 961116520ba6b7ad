"""The paper's result tables: mean and sample std over seeds per row, ``results.md`` (changes against the
baselines), the regret table (``regret.md`` / ``regret.csv``: each controller's objective next to the oracle's
and the share of the oracle's saving it captures), the m-sweep table, ``results.csv`` / ``runs.csv``, the
figures, and the documentation's page of them (:func:`write_docs_page`, ``districtgen paper --docs PAGE``).
"""

from __future__ import annotations

import datetime as dt
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from citylearn_env.outputs import output_file, write_output
from pipeline.controllers import MISFIT_REASON
from pipeline.paper.benchmarks import BENCHMARKS, SWEEP_ID, RunOptions, Task, configuration
from pipeline.paper.figures import write_figures
from pipeline.paper.reference import OBJECTIVE_FIELDS, REFERENCES, unsupported
from surrogates.precision import capability

#: the run folder's tables the documentation page holds, in order, with their section titles
DOCS_TABLES = (("The 17 benchmarks", "results.md"), ("Against the oracle and MPC", "regret.md"),
               ("The m-sweep of the heat-pump reward", "multiplier_sweep.md"))


def sweep_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The m-sweep table (markdown): one row per multiplier, changes against the first row (m = 1);
    discomfort and consumption as mean ± std over seeds where a row has more than one (the over/under
    columns: mean +- std over the test period's hours, of the seeds' mean)."""
    base = rows[0]
    below, above = (side.replace("cooling", "-cooling").replace("heating", "-heating")
                    for side in str(base.get("below_above", "overcooling/undercooling")).split("/"))
    lines = [f"| m | discomfort C h | {below} C (mean +- std) | {above} C (mean +- std) | "
             "consumption kWh | discomfort change | consumption change |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['multiplier']:g} | {_pm(r, 'discomfort', 1)} | {r['overcooling_mean']:.2f} +- "
                     f"{r['overcooling_std']:.2f} | {r['undercooling_mean']:.2f} +- {r['undercooling_std']:.2f} | "
                     f"{_pm(r, 'consumption', 2)} | {_percent(r['discomfort'], base['discomfort'])} | "
                     f"{_percent(r['consumption'], base['consumption'])} |")
    return "\n".join(lines) + "\n"


#: where and when a run ran (:func:`provenance`): in runs.csv and on the docs page, not in the summarised rows
PROVENANCE = ("machine", "load_average", "finished_utc")

#: per-run numbers averaged over seeds (the rest of a run's fields are labels or the trace)
METRICS = ("cost", "emissions", "discomfort", "consumption", "average_daily_peak", "overcooling_mean",
           "overcooling_std", "undercooling_mean", "undercooling_std", "mean_abs_action", "train_seconds",
           "train_cpu_seconds", "seconds")


def summarise(runs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Mean of :data:`METRICS` over ``runs`` (the seeds of one row), their sample std as ``<name>_sd``,
    the number of seeds, and the first run's labels and trace."""
    first = runs[0]
    row = {k: v for k, v in first.items() if k not in METRICS and k not in PROVENANCE}
    row["seeds"] = len(runs)
    for name in METRICS:
        values = np.array([r[name] for r in runs], dtype=float)
        row[name] = float(values.mean())
        row[f"{name}_sd"] = float(values.std(ddof=1)) if len(values) > 1 else 0.0
    return row


def write_results(out: Path, runs: Sequence[Mapping[str, Any]], tasks: Sequence[Task], *, multiplier: float,
                  only: Sequence[str] | None, sweep: Sequence[float], options: RunOptions,
                  seeds: int) -> dict[str, Any]:
    """results.csv / runs.csv / results.md / regret.md / regret.csv / multiplier_sweep.md and the figures from
    the finished runs; returns {"results": summarised rows, "sweep", "runs": the benchmark runs, "references":
    configuration -> controller -> reference run, "regret": :func:`regret_rows`} (runs.csv holds both kinds of
    run, told apart by ``controller``)."""
    groups: dict[tuple[str, float], list] = {}
    references: dict[str, dict[str, Mapping[str, Any]]] = {}
    for task, run in zip(tasks, runs, strict=True):
        if task.controller:
            references.setdefault(configuration(task.id), {})[task.controller] = run
        else:
            groups.setdefault((task.id, task.multiplier), []).append(run)
    order = [b.id for b in BENCHMARKS if (only is None or b.id in only) and (b.id, multiplier) in groups]
    results = [annotate(summarise(groups[(i, multiplier)]), references) for i in order]
    swept = [summarise(groups[(SWEEP_ID, float(m))]) for m in sweep if (SWEEP_ID, float(m)) in groups]
    plain = [{k: v for k, v in r.items() if k not in ("trace", "baseline")} for r in runs]
    write_csv(out, "runs.csv", pd.DataFrame(plain))
    regret = regret_rows(results, references)
    if results:
        write_csv(out, "results.csv", pd.DataFrame([{k: v for k, v in r.items() if k != "trace"} for r in results]))
        write_output(out, "results.md", results_table(results, options, seeds), column="--output")
    if regret:
        write_csv(out, "regret.csv", pd.DataFrame(regret))
        write_output(out, "regret.md", regret_table(regret), column="--output")
    if swept:
        write_output(out, "multiplier_sweep.md", sweep_table(swept), column="--output")
    write_figures(out, results, swept, references)
    own = [run for task, run in zip(tasks, runs, strict=True) if not task.controller]
    return {"results": results, "sweep": swept, "runs": own, "references": references, "regret": regret}


def write_csv(out: Path, name: str, frame: pd.DataFrame) -> Path:
    """Write ``frame`` (no index) as ``out / name`` through :func:`citylearn_env.outputs.write_output`."""
    return write_output(out, name, lambda stream: frame.to_csv(stream, index=False), column="--output")


def captured(baseline: float, value: float, best: float) -> float:
    """The share of the oracle's saving a controller captures: (baseline - value) / (baseline - best) [-];
    NaN when the oracle saves nothing (|baseline - best| <= 1e-9 x |baseline|) or a value is missing."""
    saving = baseline - best
    if not np.isfinite(saving) or not np.isfinite(value) or abs(saving) <= 1e-9 * max(abs(baseline), 1e-12):
        return float("nan")
    return float((baseline - value) / saving)


def _baseline(refs: Mapping[str, Mapping[str, Any]]) -> Mapping[str, float] | None:
    """The configuration's no-control values from its reference runs (None when none ran)."""
    return next((refs[c]["baseline"] for c in REFERENCES if c in refs and "baseline" in refs[c]), None)


def _objective(refs: Mapping[str, Mapping[str, Any]], controller: str, field: str) -> float:
    """``field`` of the reference run of ``controller`` (NaN when it did not run or skipped)."""
    run = refs.get(controller)
    return float(run[field]) if run is not None and "skipped" not in run else float("nan")


def annotate(row: dict[str, Any], references: Mapping[str, Mapping[str, Mapping[str, Any]]]) -> dict[str, Any]:
    """``row`` with its configuration's ``objective`` (the paper's) and, for storage configurations,
    ``no_control``, ``oracle`` and ``mpc`` values of that objective and the row's ``captured`` share."""
    bench = next(b for b in BENCHMARKS if b.id == row["id"])
    if bench.objective not in OBJECTIVE_FIELDS:
        return row
    field = OBJECTIVE_FIELDS[bench.objective][0]
    refs = references.get(configuration(bench.id), {})
    base = _baseline(refs)
    baseline = float(base[field]) if base is not None else float("nan")
    best = _objective(refs, "oracle", field)
    return {**row, "objective": field, "no_control": baseline, "oracle": best,
            "mpc": _objective(refs, "mpc", field), "captured": captured(baseline, row[field], best)}


def regret_rows(results: Sequence[Mapping[str, Any]], references: Mapping[str, Mapping[str, Mapping[str, Any]]]
                ) -> list[dict[str, Any]]:
    """One row per (configuration, controller) of the controlled benchmarks: the objective's value [its unit],
    its std over seeds (SAC), the configuration's no-control and oracle values and the captured share; a
    configuration the references do not apply to keeps its RBC/SAC rows with the reason in ``note``."""
    rows = []
    for row in results:
        bench = next(b for b in BENCHMARKS if b.id == row["id"])
        if bench.control == "none":
            continue
        rows.append(_regret_row(row, bench.control, row, _note(bench)))
    for config, refs in references.items():
        owner = next((r for r in results if configuration(r["id"]) == config), None)
        for controller in REFERENCES:
            run = refs.get(controller)
            if run is None:
                continue
            bench = next(b for b in BENCHMARKS if b.id == run["id"])
            if "skipped" in run:
                rows.append({"configuration": config, "controller": controller, "note": run["skipped"]})
                continue
            context = owner or annotate(dict(run), references)
            rows.append(_regret_row(run, controller, context, _note(bench)))
    order = {c: i for i, c in enumerate(dict.fromkeys(configuration(b.id) for b in BENCHMARKS))}
    rank = {"rbc": 0, "sac": 1, "mpc": 2, "oracle": 3}
    return sorted(rows, key=lambda r: (order[r["configuration"]], rank[r["controller"]]))


def _note(bench) -> str:
    """"no oracle: <why>" for a configuration the references do not apply to, else ""."""
    reason = unsupported(bench)
    return f"no oracle: {reason}" if reason else ""


def _regret_row(run: Mapping[str, Any], controller: str, context: Mapping[str, Any], note: str) -> dict[str, Any]:
    """A regret row of ``run`` (a summarised benchmark row or a reference run) under ``controller``; the
    no-control and oracle values come from ``context`` (the configuration's annotated row)."""
    bench = next(b for b in BENCHMARKS if b.id == run["id"])
    field, unit = OBJECTIVE_FIELDS.get(bench.objective, ("discomfort", "C h"))
    baseline, best = context.get("no_control", float("nan")), context.get("oracle", float("nan"))
    value = float(run[field])
    return {"configuration": configuration(bench.id), "objective": field, "unit": unit, "controller": controller,
            "value": value, "value_sd": float(run.get(f"{field}_sd", 0.0)), "seeds": int(run.get("seeds", 1)),
            "no_control": baseline, "oracle": best, "captured": captured(baseline, value, best), "note": note}


def regret_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """regret.md: per configuration, each controller's objective value and the share of the oracle's saving
    it captures, (no control - controller) / (no control - oracle)."""
    by_config: dict[str, dict[str, Mapping[str, Any]]] = {}
    for r in rows:
        by_config.setdefault(r["configuration"], {})[r["controller"]] = r
    lines = ["Objective over the test period: B1's cost [$] or emissions [kg], the district's average daily peak "
             "[kW]; the configuration's objective for its oracle. Each cell: value (share of the oracle's saving "
             "captured = (no control - value) / (no control - oracle)). No control: the same configuration with "
             "its storage idle. MPC: 24-step horizon, perfect forecasts.", "",
             "| configuration | objective | no control | RBC | SAC | MPC | oracle |", "|---|---|---|---|---|---|---|"]
    notes = []
    for config, controllers in by_config.items():
        note = next((r["note"] for r in controllers.values() if r.get("note", "").startswith("no oracle")), "")
        if note:
            notes.append(f"{config}: {note}.")
            continue
        lines.append(_regret_line(config, controllers))
        rbc = controllers.get("rbc", {})
        if "value" in rbc and rbc["value"] > rbc["no_control"]:
            notes.append(f"{config}: the RBC does worse than no control on its own objective ("
                         f"{_percent(rbc['value'], rbc['no_control'])}): {MISFIT_REASON.format(period='test period')}.")
    return "\n".join([*lines, *([""] + notes if notes else [])]) + "\n"


def _regret_line(config: str, controllers: Mapping[str, Mapping[str, Any]]) -> str:
    """One line of the regret table."""
    full = [r for r in controllers.values() if "value" in r]
    if not full:
        return f"| {config} | - | - | - | - | - | - |"
    first = full[0]
    digits = 3 if first["objective"] != "emissions" else 2
    cells = []
    for c in ("rbc", "sac", "mpc", "oracle"):
        r = controllers.get(c)
        if r is None:
            cells.append("-")
        elif "value" not in r:
            cells.append(f"n/a ({r['note']})")
        else:
            share = "" if c == "oracle" or not np.isfinite(r["captured"]) else f" ({100 * r['captured']:.1f} %)"
            cells.append(f"{_pm(r, 'value', digits)}{share}")
    base = first["no_control"]
    base_cell = f"{base:.{digits}f}" if np.isfinite(base) else "-"
    return f"| {config} | {first['objective']} {first['unit']} | {base_cell} | {' | '.join(cells)} |"


def _pm(row: Mapping[str, Any], name: str, digits: int) -> str:
    """``row[name]``, with `` ± <name>_sd`` where the row has more than one seed."""
    value = f"{row[name]:.{digits}f}"
    return value + (f" ± {row[name + '_sd']:.{digits}f}" if row.get("seeds", 1) > 1 else "")


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
    notes = [f"- {r['id']}: {note}" for r in results for note in r.get("notes", ())]
    if notes:
        lines += ["", "What the test period cannot exercise (the rows ran as configured):", *notes]
    return "\n".join(lines) + "\n"


def _percent(value: float, base: float) -> str:
    return f"{100.0 * (value - base) / base:+.1f} %" if base else "-"


def provenance() -> dict[str, Any]:
    """Where and when a task finished, for its result: this machine's CPU (:func:`surrogates.precision.capability`),
    its one-minute load average and the UTC time."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return {"machine": capability().describe(), "load_average": load,
            "finished_utc": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M")}


def runs_provenance(out: Path) -> str:
    """One sentence on where and when the runs of ``out``'s runs.csv finished: the time span and each CPU (its
    load averages' range) with the number of runs, and the runs whose task file predates the record."""
    if not (out / "runs.csv").is_file():
        return ""
    runs = pd.read_csv(out / "runs.csv")
    if not set(PROVENANCE) <= set(runs.columns):
        return f"The {len(runs)} runs' task files do not record their machine (written before it was kept)."
    known = runs.dropna(subset=["machine", "finished_utc"])
    machines = [f"{len(group)} on {cpu} (load average {group['load_average'].min():.1f}-"
                f"{group['load_average'].max():.1f})" for cpu, group in known.groupby("machine", sort=False)]
    text = ""
    if len(known):
        text = (f"The runs finished {known['finished_utc'].min()} to {known['finished_utc'].max()} UTC: "
                f"{'; '.join(machines)}.")
    missing = len(runs) - len(known)
    if missing:
        text += (" " if text else "") + (f"{missing} earlier run's task file does not record its machine."
                                         if missing == 1 else
                                         f"{missing} earlier runs' task files do not record their machine.")
    return text


def docs_page(out: Path, *, command: str, machine: str, finished: str) -> str:
    """The markdown page of a finished run folder ``out`` for the documentation: how it was made (``command``,
    the UTC time ``finished`` the page was written and that ``machine``), where and when the runs themselves
    finished (:func:`runs_provenance`: a page rewritten from a finished folder names the machines the runs
    had, not only its own), the SAC trainings' seconds from ``results.csv``, then results.md, regret.md and
    multiplier_sweep.md as the run wrote them (a table the run did not make is left out). The tables are the
    run's files, never retyped."""
    lines = ["# The paper's benchmarks: results of the last documented run", "",
             f"Generated by `{command}`, page written {finished} on {machine}. Do not edit: rerun the command "
             "(finished tasks in the output folder are reused, so only what is missing runs). "
             f"{runs_provenance(out)}".rstrip()]
    if (out / "results.csv").is_file():
        seconds = pd.read_csv(out / "results.csv").get("train_seconds", pd.Series(dtype=float))
        seconds = seconds[seconds > 0]
        if len(seconds):
            span = f"{seconds.min():.0f}" + (f"-{seconds.max():.0f}" if len(seconds) > 1 else "")
            lines += ["", f"SAC training: {span} s wall per configuration ({len(seconds)} trained)."]
    for title, name in DOCS_TABLES:
        if (out / name).is_file():
            lines += ["", f"## {title}", "", (out / name).read_text().rstrip()]
    return "\n".join(lines) + "\n"


def write_docs_page(out: str | Path, page: str | Path, *, command: str) -> Path:
    """Write :func:`docs_page` of the run folder ``out`` to ``page`` (:func:`citylearn_env.outputs.write_output`:
    a new sibling renamed into place, never through a link, never into a built district), naming this machine's CPU and load average; returns the page's path."""
    here = provenance()
    machine = f"{here['machine']}, load average {here['load_average']:.1f} (a machine possibly shared)"
    finished = f"{here['finished_utc']} UTC"
    folder, name = output_file(page, column="--docs")
    return write_output(folder, name, docs_page(Path(out), command=command, machine=machine, finished=finished),
                        column="--docs")
