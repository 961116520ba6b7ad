"""``districtgen surrogate install``: put a retrained surrogate into a built district. The model's LSTM inputs
are checked against the building's, the files copied, the schema updated, the district re-validated and its
records rewritten, all in a copy that replaces the district only when everything succeeded.
"""

from __future__ import annotations

import copy
import datetime as dt
import json
import os
import shutil
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from citylearn_env.errors import LocatedError
from citylearn_env.outputs import check_slug
from pipeline.builder.manifest import (
    MANIFEST,
    TIMINGS,
    check_district,
    district_files,
    make_world_readable,
    output_hashes,
    read_manifest,
    sha256_file,
    split_metrics_timings,
    write_json_file,
    write_sidecar,
)
from pipeline.builder.report import SelectionSummary, district_report, write_report
from pipeline.builder.staging import (
    at_step,
    check_no_links,
    check_not_inside,
    clean_leftovers,
    copy_district,
    exit_on_signals,
    swap_in,
    write_new_file,
)
from pipeline.builder.validate import validate_district
from pipeline.errors import InputError
from pipeline.select import describe_selection
from surrogates.evaluate import replay_test_rmse
from surrogates.export import load_surrogate
from surrogates.ilv import read_ilv, table_digest
from surrogates.plausibility import replay_far_off
from surrogates.sources.csv import read_ilv_table


@dataclass(frozen=True)
class ModelFiles:
    """A trained surrogate as ``surrogate train`` writes it: ``<stem>.pth`` and ``<stem>.dynamics.json``,
    optionally ``<stem>.metrics.json`` and ``<stem>.png``, all in one folder."""

    pth: Path
    dynamics: Path
    metrics: Path | None
    plot: Path | None


def find_model_files(model: str | os.PathLike, building: str) -> ModelFiles:
    """The files of a trained model from its ``.pth`` or its folder (one ``.pth``, or ``<building>.pth``)."""
    model = Path(model)
    if model.is_dir():
        candidates = sorted(model.glob("*.pth"))
        named = [p for p in candidates if p.stem == building]
        if len(named) == 1 or len(candidates) == 1:
            model = (named or candidates)[0]
        else:
            raise InputError(f"expected one .pth (or {building}.pth) in the folder, found "
                             f"{len(candidates)}", file=model)
    if model.suffix != ".pth" or not model.is_file():
        raise InputError("not a model file (the .pth written by 'surrogate train') or its folder", file=model)
    sibling = {s: model.with_name(f"{model.stem}{s}") for s in (".dynamics.json", ".metrics.json", ".png")}
    if not sibling[".dynamics.json"].is_file():
        raise InputError("no dynamics block beside the model (written by 'surrogate train')",
                         file=sibling[".dynamics.json"])
    return ModelFiles(model, sibling[".dynamics.json"],
                      sibling[".metrics.json"] if sibling[".metrics.json"].is_file() else None,
                      sibling[".png"] if sibling[".png"].is_file() else None)


def check_model_fits(block: Mapping[str, Any], current: Mapping[str, Any] | None, *, building: str,
                     model: Path) -> None:
    """Refuse (one line) a model whose LSTM inputs (names, order, count) are not the building's: ``block`` is
    the new model's dynamics block, ``current`` the schema's dynamics entry of the building (None: none)."""
    if not current:
        raise InputError(f"{building} has no LSTM dynamics entry in the schema: nothing to replace (build the "
                         "district with a surrogate source)", file=model, column="dynamics")
    new, old = block.get("attributes", {}), current.get("attributes", {})
    if list(new.get("input_observation_names", [])) != list(old.get("input_observation_names", [])):
        raise InputError(f"the model's LSTM inputs {new.get('input_observation_names')} are not {building}'s "
                         f"{old.get('input_observation_names')}", file=model, column="input_observation_names")
    if new.get("input_size") != old.get("input_size"):
        raise InputError(f"the model's input size {new.get('input_size')} is not {building}'s "
                         f"{old.get('input_size')}", file=model, column="input_size")


def check_training_table(model: ModelFiles, recorded: Path, building: str) -> None:
    """Refuse (one line) a model not trained on the house's own table: its ``.metrics.json`` must name the same
    ``table_sha256`` (the ILV table's content) as the building's current surrogate record ``recorded``."""
    def table_of(path: Path | None) -> str | None:
        try:
            return json.loads(path.read_text()).get("table_sha256") if path is not None else None
        except (OSError, ValueError, AttributeError):
            return None

    house, trained = table_of(recorded), table_of(model.metrics)
    if house is None:
        raise InputError(f"the district records no training table for {building} ({recorded.name} without "
                         "table_sha256): cannot check the model against it (--force to install anyway)",
                         file=recorded, column="table_sha256")
    if trained is None:
        raise InputError(f"no training record beside the model ({model.pth.stem}.metrics.json with table_sha256): "
                         f"cannot tell which table it was trained on (--force to install anyway)",
                         file=model.pth, column="table_sha256")
    if trained != house:
        raise InputError(f"the model was trained on ILV table {trained[:12]}, {building}'s surrogate on "
                         f"{house[:12]}: not this house's training table (--force to install anyway)",
                         file=model.metrics, column="table_sha256")


def place_model(folder: Path, building: str, files: ModelFiles, schema: dict, block: dict) -> dict[str, Any]:
    """Copy a checked model (its parsed dynamics ``block``) into a district folder as ``<building>.pth`` and
    ``surrogates/<building>.*`` (metrics without their seconds), point the schema's dynamics entry at it and
    rewrite ``schema.json``; returns the seconds taken out of the metrics (for ``timings.json``)."""
    block = copy.deepcopy(block)
    block["attributes"]["filename"] = f"{building}.pth"
    (folder / "surrogates").mkdir(exist_ok=True)
    replace_file(folder / f"{building}.pth", files.pth.read_bytes())
    write_json_file(folder / "surrogates" / f"{building}.dynamics.json", block)
    seconds: dict[str, Any] = {}
    if files.metrics is not None:
        metrics, seconds = split_metrics_timings(json.loads(files.metrics.read_text()))
        source = Path(str(metrics.get("source", ""))).name  # the training table's name, not where it was
        write_json_file(folder / "surrogates" / f"{building}.metrics.json",
                        {**metrics, "building": building, "source": source})
    if files.plot is not None:
        replace_file(folder / "surrogates" / f"{building}.png", files.plot.read_bytes())
    drop_foreign_table(folder, building, files)
    schema["buildings"][building]["dynamics"] = block
    write_json_file(folder / "schema.json", schema)
    return seconds


def drop_foreign_table(folder: Path, building: str, files: ModelFiles) -> None:
    """Remove the district's ``surrogates/<building>.ilv.parquet`` when the installed model was not trained on
    it (its metrics record another ``table_sha256``, or none): the file is the table the building's CURRENT
    model was trained on, or absent."""
    table = folder / "surrogates" / f"{building}.ilv.parquet"
    if not table.is_file():
        return
    recorded = json.loads(files.metrics.read_text()).get("table_sha256") if files.metrics is not None else None
    if recorded is None or recorded != table_digest(read_ilv(table)):
        table.unlink()


def replace_file(path: Path, data: bytes) -> None:
    """Put ``data`` at ``path`` as a new regular file: what was there (a file, a planted link) is removed, never
    written through (:func:`pipeline.builder.staging.write_new_file`)."""
    path.unlink(missing_ok=True)
    write_new_file(path, data)


def revalidate(folder: Path, name: str, schema: dict, manifest: Mapping[str, Any]) -> None:
    """Run the district validation (no control + the cost RBC + the oracle) and write ``report/`` anew from what
    the district holds, as its build does (:func:`pipeline.builder.report.write_report`): the selection from
    the ``manifest`` (:func:`recorded_selection`)."""
    validation = validate_district(folder / "schema.json")
    shutil.rmtree(folder / "report", ignore_errors=True)
    write_report(folder / "report", district_report(folder, name, schema, validation,
                                                    recorded_selection(folder, manifest)))


def recorded_selection(folder: Path, manifest: Mapping[str, Any]) -> SelectionSummary | None:
    """The district's k-means selection as its manifest records it (``selection``); for a district built
    before the manifest held it, the k of ``selection.csv`` without the validity indices; None: the buildings
    were listed."""
    if isinstance(manifest.get("selection"), Mapping):
        return SelectionSummary.from_json(manifest["selection"])
    table = folder / "selection.csv"
    if not table.is_file():
        return None
    try:
        chosen = pd.read_csv(table)
        return SelectionSummary(int(chosen["k"].iloc[0]), heading=describe_selection(chosen))
    except (OSError, ValueError, KeyError, IndexError) as error:
        raise InputError(f"cannot read the selection's k: {error}", file=table, column="k") from None


def install_surrogate(district: str | os.PathLike, building: str, model: str | os.PathLike, *,
                      force: bool = False) -> Path:
    """Put a retrained surrogate (``surrogate train`` output) into a built district for ``building``.

    Checks the model's LSTM inputs against the schema's dynamics entry, copies the files, updates
    ``schema.json``, re-runs the validation (report included) and rewrites ``manifest.json`` (inputs and
    configuration as built; surrogate_cache of the building: the installed model's sha256) and ``timings.json``
    (the training seconds), all in a copy of the district that replaces it only when everything succeeded.
    Errors are one :class:`InputError` naming the district, the building or the model file. Refused before
    anything is touched: a district whose artifacts no longer match its manifest (tampered or damaged), a model
    not trained on the building's own ILV table (:func:`check_training_table`) -- ``force`` installs anyway --
    and a district that holds the current directory (the swap would pull it away). Returns the district folder
    (resolved).
    """
    folder = Path(district).resolve()
    check_slug(building, column="building", file=folder / "schema.json")  # it names files: never a path, --force or not
    check_not_inside(folder)
    clean_leftovers(folder.parent, folder.name)  # a killed earlier install or build: old or new, never neither
    manifest = read_manifest(folder)
    overridden = check_verified(folder, force)
    try:
        schema = json.loads((folder / "schema.json").read_text())
    except (OSError, ValueError) as error:
        raise InputError(f"cannot read the schema: {error}", file=folder / "schema.json") from None
    if building not in schema.get("buildings", {}):
        raise InputError(f"no building {building!r} in the district (it has "
                         f"{', '.join(schema.get('buildings', {}))})", file=folder / "schema.json",
                         column="buildings")
    files = find_model_files(model, building)
    block = json.loads(files.dynamics.read_text())
    load_surrogate(files.pth, block)  # the weights match their block (else one InputError)
    check_model_fits(block, schema["buildings"][building].get("dynamics"), building=building, model=files.pth)
    if not force:
        check_training_table(files, folder / "surrogates" / f"{building}.metrics.json", building)
    replayed = check_model_behaviour(files, block, folder / "surrogates" / f"{building}.ilv.parquet", force=force)
    for line in overridden:
        print(f"districtgen: --force overrides: {line}", file=sys.stderr)
    work = folder.with_name(f".{folder.name}.install-{os.getpid()}")
    shutil.rmtree(work, ignore_errors=True)
    with exit_on_signals():  # SIGTERM / SIGHUP: the working copy is removed as on Ctrl-C
        at_step("copy")
        copy_district(folder, work)
        return install_into(folder, work, building, files, schema, block, manifest, replayed)


def install_into(folder: Path, work: Path, building: str, files: ModelFiles, schema: dict, block: dict,
                 manifest: dict, replayed: Mapping[str, Any] | None = None) -> Path:
    """Place the model into the working copy ``work`` of ``folder``, revalidate, rewrite the records and swap
    it in; ``work`` is removed whatever happens. The manifest lists what it listed (minus what the install
    removed) and what the install wrote, never a file nobody recorded (an unknown file stays unknown)."""
    unknown = set(district_files(folder)) - set(manifest.get("outputs") or {})
    try:
        at_step("place model")
        seconds = place_model(work, building, files, schema, block)
        if replayed is not None:
            record_replay(work / "surrogates" / f"{building}.metrics.json", replayed)
        at_step("revalidate")
        revalidate(work, manifest.get("district") or folder.name, schema, manifest)
        manifest["outputs"] = {name: entry for name, entry in output_hashes(work).items() if name not in unknown}
        manifest.setdefault("surrogate_cache", {})[building] = {"key": None, "installed": files.pth.name,
                                                              "sha256": sha256_file(files.pth)}
        at_step("records")
        write_json_file(work / MANIFEST, manifest)
        write_install_timings(work, building, files.pth, seconds)
        write_sidecar(work)
        make_world_readable(work)
        check_no_links(work)
        swap_in(work, folder)
    except (LocatedError, OSError) as error:  # name the district the user gave, not the deleted working copy
        raise in_district(error, work, folder) from None
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return folder


def in_district(error: LocatedError | OSError, work: Path, folder: Path) -> LocatedError | OSError:
    """``error`` (raised inside the working copy ``work``) with every mention of ``work`` replaced by the
    district ``folder`` it copies: the message names the file the user gave, not a copy deleted on exit."""
    def mapped(text: object) -> str:
        return str(text).replace(str(work), str(folder)).replace(work.name, folder.name)

    if isinstance(error, LocatedError):
        located = type(error)(mapped(error))
        located.file = None if error.file is None else mapped(error.file)
        located.column, located.row = error.column, error.row
        return located
    if error.filename is None:
        return error
    return type(error)(error.errno, error.strerror, mapped(error.filename))


def write_install_timings(folder: Path, building: str, pth: Path, seconds: Mapping[str, Any]) -> Path:
    """Record an installed model in ``timings.json``: its training seconds, where it came from, when."""
    try:
        record = json.loads((folder / TIMINGS).read_text())
    except (OSError, ValueError):
        record = {}
    record.setdefault("surrogates", {})[building] = {**seconds, "installed_from": str(pth.resolve()),
                                                     "installed_utc": dt.datetime.now(dt.UTC)
                                                     .isoformat(timespec="seconds")}
    return write_json_file(folder / TIMINGS, record)


def check_verified(folder: Path, force: bool) -> list[str]:
    """Refuse (one line) a district that fails ``verify``'s record checks: its artifacts, inputs, records
    (``manifest.json``, ``timings.json`` against ``manifest.sha256``) and the manifest's own fields
    (:func:`pipeline.builder.manifest.check_district`). With ``force``: the problems it overrides."""
    problems = check_district(folder).problems
    if problems and not force:
        raise InputError(f"the district fails verify ({problems[0]}; {len(problems)} problem(s) in all, see "
                         "'districtgen verify'): not installing into it (--force to install anyway)", file=folder)
    return problems


def check_model_behaviour(files: ModelFiles, block: dict, table_path: Path, *, force: bool) -> dict | None:
    """Replay the model closed loop on the held-out test runs its metrics record, on the house's own ILV table
    (:func:`surrogates.evaluate.replay_test_rmse`); refuse (one line) a model whose error is far above the
    RMSE it claims (:func:`surrogates.plausibility.replay_far_off`) unless ``force``. Returns the replay's
    record (None: nothing to replay, a model without metrics or a district without the table, installed only
    with ``force``)."""
    try:
        metrics = json.loads(files.metrics.read_text()) if files.metrics is not None else None
        claimed = float(metrics["test"]["closed_loop_rmse_c"])
        test = metrics["training"]["splits"]["test"]
    except (OSError, ValueError, KeyError, TypeError):
        return None  # check_training_table has already refused it unless forced
    if not table_path.is_file():
        return None
    rmse, hours = replay_test_rmse(files.pth, block, read_ilv_table(table_path), test)
    if replay_far_off(rmse, claimed) and not force:
        raise InputError(f"the model replayed on the house's held-out runs is off by {rmse:.3g} degC (closed-loop "
                         f"RMSE over {hours} h); its metrics claim {claimed:.3g} degC: not installed (--force to "
                         "install anyway)", file=files.pth, column="test.closed_loop_rmse_c")
    return {"closed_loop_rmse_c": round(rmse, 4), "hours": hours, "claimed_closed_loop_rmse_c": claimed}


def record_replay(metrics_path: Path, replayed: Mapping[str, Any]) -> None:
    """Add the install's replay (recomputed, not copied) to an installed model's metrics as ``install_replay``."""
    metrics = json.loads(metrics_path.read_text())
    metrics["install_replay"] = dict(replayed)
    replace_file(metrics_path, (json.dumps(metrics, indent=2) + "\n").encode())
