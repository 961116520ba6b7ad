"""Fidelity against upstream CityLearn 2.1.2 on every v2.1.2 dataset, and what each correction of the default moves.

    .venv/bin/python benchmarks/fidelity.py --upstream-python /tmp/cl212/bin/python \
        [--datasets NAME ...] [--upstream-cache /tmp/fidelity_upstream.json ...] [--json OUT] [--skip-corrections] \
        [--store]

For every dataset under ../shared/data/citylearn/upstream/v2.1.2/ (read in place, unchanged), one no-control
episode (every action 0 at every step, the whole simulation range) is run

* in upstream CityLearn 2.1.2, in its own interpreter (``--upstream-python``; a subprocess running this file
  with ``--child``), on the same schema path: ``CityLearnEnv(schema, central_agent=True)``, ``reset()``,
  ``step([zeros])`` until done, then ``evaluate()``;
* in citylearn_env with the 2.1 preset, ``CityLearnEnv(schema, settings="citylearn-2.1")``, the same way.

Compared: the district no-control energy (sum over the episode of the district's net electricity
consumption, kWh), and every KPI of ``evaluate()`` at district and building level (relative difference; NaN
on both sides, or both below 1e-9 in magnitude, counts as equal). Target: <= 1e-4 relative.

Then the corrected default (``CORRECTED``) on the same episode, and, for every field of
:class:`citylearn_env.settings.Behaviour`, ``dataclasses.replace(CORRECTED, field=<its CityLearn 2.1 value>)``:
the change of the district energy that reverting that one correction causes is that correction's effect.
Upstream results are cached in ``--upstream-cache`` (JSON, keyed by schema path; several files may be given,
new runs go to the first) because the 4-year set takes minutes upstream; delete the file to rerun them.
``--store`` copies the upstream records of the datasets compared into ``benchmarks/upstream_2_1_2/no_control.json``
(keyed by dataset name: steps, district and building energy [kWh], every KPI row), the reference that
``tests/citylearn_env/test_fidelity_tables.py`` reads without the scratch venv.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STORE = ROOT / "benchmarks" / "upstream_2_1_2" / "no_control.json"
UPSTREAM_DIR = ROOT.parent / "shared" / "data" / "citylearn" / "upstream" / "v2.1.2"
THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


# --------------------------------------------------------------------------- child side (upstream venv)
def _upstream_child(schema: str, out: str) -> None:
    """One no-control episode of upstream CityLearn 2.1.2; writes energy sums and the KPI table (JSON)."""
    import resource

    import torch
    from citylearn.citylearn import CityLearnEnv

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    env = CityLearnEnv(schema, central_agent=True)
    env.reset()
    zeros = [[0.0] * env.action_space[0].shape[0]]
    done, steps = False, 0
    while not done:
        done = env.step(zeros)[2]
        steps += 1
    kpis = env.evaluate()
    result = {
        "steps": steps, "wall_s": time.perf_counter() - t0,
        "district_energy_kwh": float(sum(env.net_electricity_consumption)),
        "building_energy_kwh": {b.name: float(sum(b.net_electricity_consumption)) for b in env.buildings},
        "kpis": [[r.cost_function, r.name, None if r.value is None else float(r.value)]
                 for r in kpis.itertuples()],
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    Path(out).write_text(json.dumps(result))


# --------------------------------------------------------------------------- our side
def no_control_episode(schema, settings):
    """citylearn_env on ``schema`` (a path or a DistrictConfig) with ``settings`` after one episode of zero
    actions (no storage use; no actions at all for a schema without them): (env, steps)."""
    import numpy as np

    from citylearn_env import CityLearnEnv

    env = CityLearnEnv(schema, settings=settings)
    env.reset(seed=0)
    zeros = np.zeros(env.action_space.shape)
    done, steps = env.episode_length <= 1, 0
    while not done:
        _, _, terminated, truncated, _ = env.step(zeros)
        done, steps = terminated or truncated, steps + 1
    return env, steps


def kpi_rows(env) -> list[list]:
    """The KPI table of a finished episode as rows ``[kpi, name, value]``."""
    return [[r.cost_function, r.name, float(r.value)] for r in env.evaluate().itertuples()]


def run_ours(schema: str | Path, settings) -> dict:
    """One no-control episode of citylearn_env with ``settings``: district energy [kWh] and the KPI table."""
    import numpy as np

    env, steps = no_control_episode(schema, settings)
    return {"steps": steps, "district_energy_kwh": float(np.sum(env.series()["net_electricity_consumption"])),
            "kpis": kpi_rows(env)}


#: KPI values smaller than this in magnitude count as 0 (upstream's float32 sizing leaves ~1e-11 of unserved
#: energy where ours, in float64, serves everything)
ZERO = 1e-9


def relative(a: float | None, b: float | None) -> float:
    """|a - b| / max(|b|, 1e-12); 0 when both are NaN (or None) or both below :data:`ZERO` in magnitude, inf
    when only one is NaN."""
    a = math.nan if a is None else a
    b = math.nan if b is None else b
    if math.isnan(a) and math.isnan(b):
        return 0.0
    if math.isnan(a) or math.isnan(b):
        return math.inf
    if math.isinf(a) or math.isinf(b):
        return 0.0 if a == b else math.inf
    if abs(a) < ZERO and abs(b) < ZERO:
        return 0.0
    return abs(a - b) / max(abs(b), 1e-12)


def compare_kpis(ours: list, upstream: list) -> list[tuple[str, str, float | None, float | None, float]]:
    """(kpi, name, ours, upstream, relative difference) for every KPI row upstream reports (ours None if
    we lack it)."""
    mine = {(k, n): v for k, n, v in ours}
    return [(k, n, mine.get((k, n)), v, relative(mine.get((k, n)), v) if (k, n) in mine else math.inf)
            for k, n, v in upstream]


def upstream_result(python: str, schema: Path, caches: list[Path]) -> dict:
    """Upstream's no-control result for ``schema``, from one of ``caches`` or a fresh subprocess (stored in the
    first cache)."""
    import os
    import tempfile

    for cache in caches[1:]:
        found = json.loads(cache.read_text()).get(str(schema)) if cache.exists() else None
        if found is not None:
            return found
    cache = caches[0]
    store = json.loads(cache.read_text()) if cache.exists() else {}
    if str(schema) not in store:
        with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as handle:
            out = handle.name
        env = {**os.environ, **THREADS}
        subprocess.run([python, __file__, "--child", str(schema), out], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        store[str(schema)] = json.loads(Path(out).read_text())
        cache.write_text(json.dumps(store))
    return store[str(schema)]


def corrections(schema: Path) -> dict[str, float]:
    """District no-control energy [kWh] of CORRECTED and of CORRECTED with each field set to its 2.1 value."""
    import dataclasses

    from citylearn_env.settings import CITYLEARN_2_1, CORRECTED, Behaviour

    out = {"CORRECTED": run_ours(schema, CORRECTED)["district_energy_kwh"]}
    for field in Behaviour.field_names():
        flipped = dataclasses.replace(CORRECTED, **{field: getattr(CITYLEARN_2_1, field)})
        out[field] = run_ours(schema, flipped)["district_energy_kwh"]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--upstream-python", default="/tmp/cl212/bin/python")
    parser.add_argument("--datasets", nargs="*", default=None)
    parser.add_argument("--upstream-cache", nargs="+", type=Path, default=[Path("/tmp/fidelity_upstream.json")])
    parser.add_argument("--json", default=None)
    parser.add_argument("--skip-corrections", action="store_true")
    parser.add_argument("--store", action="store_true", help=f"merge the upstream records into {STORE}")
    parser.add_argument("--corrections-only", action="store_true",
                        help="only the table of each correction's effect (no upstream, no KPI comparison)")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    names = args.datasets or sorted(p.name for p in UPSTREAM_DIR.iterdir() if (p / "schema.json").exists())
    report = {}
    print("| dataset | steps | upstream 2.1.2 kWh | ours (2.1 preset) kWh | rel. diff | KPIs compared | "
          "worst KPI rel. diff (which) | corrected default kWh | corrected vs 2.1.2 |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names:
        schema = UPSTREAM_DIR / name / "schema.json"
        try:
            ours = run_ours(schema, "citylearn-2.1")
        except Exception as error:  # noqa: BLE001 -- a dataset we cannot load is a row of the table
            print(f"| {name} | - | - | - | - | - | ours fails: {type(error).__name__}: {str(error)[:120]} | - | - |")
            report[name] = {"error": f"{type(error).__name__}: {error}"}
            continue
        if args.corrections_only:
            report[name] = {"corrections": corrections(schema)}
            continue
        up = upstream_result(args.upstream_python, schema, args.upstream_cache)
        rows = compare_kpis(ours["kpis"], up["kpis"])
        worst = max(rows, key=lambda r: r[4])
        fixes = {} if args.skip_corrections else corrections(schema)
        corrected = fixes.get("CORRECTED", math.nan)
        energy_rel = relative(ours["district_energy_kwh"], up["district_energy_kwh"])
        print(f"| {name} | {ours['steps']} | {up['district_energy_kwh']:,.2f} | {ours['district_energy_kwh']:,.2f} "
              f"| {energy_rel:.1e} | {len(rows)} | {worst[4]:.1e} ({worst[0]}, {worst[1]}) | {corrected:,.2f} | "
              f"{(corrected / up['district_energy_kwh'] - 1) * 100:+.3f} % |")
        report[name] = {"ours": ours, "upstream": up, "kpi_rows": rows, "energy_rel": energy_rel,
                        "corrections": fixes}
    if not args.skip_corrections:
        print_corrections(report)
    print_kpis(report)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1, default=str))
    if args.store:
        store_references({name: r["upstream"] for name, r in report.items() if "upstream" in r})


def store_references(records: dict[str, dict]) -> None:
    """Merge upstream 2.1.2 no-control records (by dataset name) into :data:`STORE`, without the machine-specific
    fields (wall time, peak memory); NaN and infinite KPI values are stored as the strings "nan", "inf", "-inf"
    (``float()`` reads them back), missing ones as null."""
    old = json.loads(STORE.read_text()) if STORE.is_file() else {}
    for name, record in records.items():
        kpis = [[k, n, v if v is None or math.isfinite(v) else str(v)] for k, n, v in record["kpis"]]
        old[name] = {"citylearn": "2.1.2", "actions": "zeros", "steps": record["steps"],
                     "district_energy_kwh": record["district_energy_kwh"],
                     "building_energy_kwh": record["building_energy_kwh"], "kpis": kpis}
    STORE.parent.mkdir(parents=True, exist_ok=True)
    lines = ",\n".join(f"{json.dumps(name)}: {json.dumps(old[name])}" for name in sorted(old))  # a dataset a line
    STORE.write_text("{\n" + lines + "\n}\n")


def print_corrections(report: dict) -> None:
    """Per dataset: the corrected default's no-control energy [kWh], its difference from upstream 2.1.2 (from
    :data:`STORE`) and the district energy change [%] that reverting each correction causes (fields with no
    effect on any dataset listed below the table)."""
    from citylearn_env.settings import Behaviour

    stored = json.loads(STORE.read_text()) if STORE.is_file() else {}
    print("\nEffect of each correction on no-control district energy: (CORRECTED - CORRECTED with the field at "
          "its 2.1 value) / that, in %; fields with no effect on any dataset are listed below the table.")
    measured = [f for f in Behaviour.field_names() if all(f in r["corrections"] for r in report.values()
                                                          if r.get("corrections"))]
    fields = [f for f in measured if any(r.get("corrections") and r["corrections"][f] != r["corrections"]["CORRECTED"]
                                         for r in report.values())]
    print("| dataset | CORRECTED kWh | vs upstream 2.1.2 | " + " | ".join(f"`{f}`" for f in fields)
          + " | each other field |")
    print("|---|---|---|" + "---|" * len(fields) + "---|")
    for name, r in report.items():
        fixes = r.get("corrections")
        if not fixes:
            continue
        upstream = stored.get(name, {}).get("district_energy_kwh")
        versus = f"{(fixes['CORRECTED'] / upstream - 1) * 100:+.3f} %" if upstream else "(upstream not stored)"
        cells = [f"{(fixes['CORRECTED'] / fixes[f] - 1) * 100:+.3f} %" for f in fields]
        print(f"| {name} | {fixes['CORRECTED']:,.2f} | {versus} | " + " | ".join(cells) + " | 0 |")
    print("no effect on any dataset: " + ", ".join(f for f in measured if f not in fields))


def print_kpis(report: dict) -> None:
    """Every district KPI, upstream vs ours (2.1 preset), per dataset."""
    print("\nDistrict KPIs, upstream 2.1.2 / ours (2.1 preset):")
    for name, r in report.items():
        if "kpi_rows" not in r:
            continue
        cells = [f"{k} {u:.6g}/{o:.6g}" if o is not None and u is not None else f"{k} {u}/{o}"
                 for k, n, o, u, _ in r["kpi_rows"] if n == "District"]
        bad = [f"{k} ({n})" for k, n, _, _, rel in r["kpi_rows"] if rel > 1e-4]
        print(f"- {name}: {'; '.join(cells)}" + (f" -- over 1e-4: {', '.join(bad)}" if bad else ""))


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--child":
        _upstream_child(sys.argv[2], sys.argv[3])
    else:
        main()
