"""What a built district is made of, and checks that it still is: ``manifest.json``, ``timings.json``,
and ``verify``.

A district folder holds two record files:

* ``manifest.json`` -- a pure function of the configuration and the inputs: the configuration (paths
  relative to the configuration file's folder, no cache location), the sha256 and size of every input file
  the build read (weather, tariff, fuel mix, stock / characteristics file, EULP files, ILV tables of
  ``surrogate.source = "csv"``, the FMU) and of every artifact (building timeseries, weather, pricing,
  carbon, schema, surrogates and their training tables, report, selection, ...), package versions, seeds and
  each building's surrogate cache key (and, for a judged house, its judgement cache key) and, for a k-means
  selection, its k and validity indices (``selection``: what the report shows, kept for ``surrogate install``'s
  rewrite of it). Two builds of the same configuration write the same bytes.
* ``timings.json`` -- what only this run knows: seconds per stage, the surrogates' training seconds (taken
  out of their ``.metrics.json``), surrogate and judgement cache hits, where the configuration file and the
  cache were. It differs between two builds, so the manifest does not hash it.

A third record, ``manifest.sha256``, holds the sha256 of both in ``sha256sum`` format (``sha256sum -c
manifest.sha256`` checks them too). The first line is the *manifest digest*: the district's whole identity
(every artifact and input hash, the configuration, seeds and versions) in one value that two builds of the same
configuration share; the build and ``verify`` print it, and ``verify --expect DIGEST`` pins it (for CI).

Every file of a district is mode 0644 and every folder 0755 whatever the umask
(:func:`make_world_readable`). Paths in the records are POSIX, relative (``Building_1.csv``,
``surrogates/Building_1.metrics.json``).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import platform
import re
import resource
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import metadata as importlib_metadata
from pathlib import Path
from stat import S_ISREG
from typing import Any

from citylearn_env.dataset import write_atomically
from pipeline.builder.cache import cache_root
from pipeline.config import BuildConfig
from pipeline.errors import InputError
from pipeline.ingest.eulp import locate_building
from surrogates.precision import Choice, capability

MANIFEST = "manifest.json"
TIMINGS = "timings.json"
#: sha256sum-format digests of the two records above (the manifest's first: the pinnable manifest digest)
SIDECAR = "manifest.sha256"
#: record files: not listed among the outputs (the manifest cannot hash itself; the timings differ per run)
RECORDS = (MANIFEST, TIMINGS, SIDECAR)
#: what a surrogate's metrics report holds that depends on the machine and the moment, not on the inputs: the
#: training seconds and the measured reason for its precision (moved into timings.json, never hashed)
TRAINING_SECONDS = ("train_seconds", "train_cpu_seconds", "precision_reason", "bf16_speedup")
VERSIONED = ("districtgen", "numpy", "pandas", "torch", "gymnasium", "prefect", "pvlib", "matplotlib")
FILE_MODE, FOLDER_MODE = 0o644, 0o755


# ---------------------------------------------------------------------------------------------- hashing
def sha256_file(path: str | os.PathLike) -> str:
    """sha256 (hex) of a file's bytes, read in 1 MiB chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def file_entry(path: Path) -> dict[str, object]:
    """``{"sha256": hex, "bytes": size}`` of one file."""
    return {"sha256": sha256_file(path), "bytes": path.stat().st_size}


def district_files(folder: Path) -> list[str]:
    """Every file under ``folder`` except the two record files, as sorted POSIX relative paths."""
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                  if p.is_file() and p.relative_to(folder).as_posix() not in RECORDS)


def output_hashes(folder: Path) -> dict[str, dict[str, object]]:
    """:func:`file_entry` of every artifact of a district folder, by relative path (sorted)."""
    return {name: file_entry(folder / name) for name in district_files(folder)}


# ---------------------------------------------------------------------------------------------- inputs
def district_digest(folder: str | os.PathLike) -> str:
    """sha256 over the artifact hashes a district's manifest records (:func:`output_hashes`:
    every file's relative path, sha256 and size, except ``manifest.json`` and ``timings.json``).

    Two builds of the same configuration have the same digest whatever the runner or worker count."""
    return hashlib.sha256(json.dumps(output_hashes(Path(folder)), sort_keys=True).encode()).hexdigest()


def portable_path(path: str | os.PathLike, base: Path) -> str:
    """``path`` relative to ``base`` (POSIX; ``..`` where needed); a URL or another drive stays as it is."""
    text = str(path)
    if text.startswith(("http://", "https://")):
        return text
    try:
        return Path(os.path.relpath(Path(text).absolute(), base.absolute())).as_posix()
    except ValueError:
        return Path(text).as_posix()


def config_folder(config: BuildConfig) -> Path:
    """The folder relative paths of the configuration resolve against (the file's folder; cwd for a dict)."""
    source = Path(config.source)
    return source.parent.resolve() if source.name != "<dict>" else Path.cwd()


#: label -> (configuration section, key) of every field that names one input file
FILE_FIELDS: dict[str, tuple[str, str]] = {
    "weather": ("inputs", "weather"), "tariff": ("inputs", "tariff"), "fuel_mix": ("inputs", "fuel_mix"),
    "characteristics": ("inputs", "characteristics"), "selection_metadata": ("selection", "metadata"),
    "fmu": ("surrogate", "fmu")}
#: fields that name a folder or a URL (:func:`input_files` lists the files read from them one by one)
FOLDER_FIELDS: tuple[tuple[str, str], ...] = (("inputs", "ilv"), ("inputs", "eulp"))


def portable_config(config: BuildConfig) -> dict[str, Any]:
    """The configuration as plain JSON without where it was built: every path relative to the configuration
    file's folder, ``source`` its file name, ``cache_dir`` left out (it changes no artifact)."""
    base = config_folder(config)
    data = json.loads(config.model_dump_json(exclude={"cache_dir"}))
    data["source"] = Path(config.source).name
    for section, key in (*FILE_FIELDS.values(), *FOLDER_FIELDS):
        if data.get(section) and data[section].get(key) is not None:
            data[section][key] = portable_path(data[section][key], base)
    return data


def input_files(config: BuildConfig) -> dict[str, Path]:
    """Every local input file the build reads, by label: ``weather``, ``tariff``, ``fuel_mix``,
    ``characteristics``, ``selection_metadata``, ``fmu``, ``eulp_metadata`` and ``eulp_timeseries/<bldg_id>``
    (a local EULP folder), ``ilv/<bldg_id>`` (``surrogate.source = "csv"``)."""
    i = config.inputs
    files: dict[str, Path] = {}
    for label, (section, key) in FILE_FIELDS.items():
        holder = getattr(config, section)  # None for an absent optional section (selection)
        value = None if holder is None else getattr(holder, key)
        if value is not None and (label != "fmu" or config.surrogate.source == "fmu"):  # an unused FMU: no input
            files[label] = Path(value)
    ids = [int(b) for b in (i.buildings or [])]
    if i.eulp is not None and not i.eulp.startswith(("http://", "https://")):

        for bldg_id in ids:
            metadata_path, series_path = locate_building(i.eulp, bldg_id, upgrade=i.upgrade, state=i.state)
            files["eulp_metadata"] = Path(metadata_path)
            files[f"eulp_timeseries/{bldg_id}"] = Path(series_path)
    if config.surrogate.source == "csv" and i.ilv is not None:
        for bldg_id in ids:
            found = [i.ilv / f"{bldg_id}{s}" for s in (".parquet", ".csv") if (i.ilv / f"{bldg_id}{s}").exists()]
            if found:
                files[f"ilv/{bldg_id}"] = found[0]
    return files


def input_hashes(config: BuildConfig) -> dict[str, dict[str, object]]:
    """Label -> ``{"path": relative to the configuration's folder, "sha256", "bytes"}`` of every input."""
    base = config_folder(config)
    return {label: {"path": portable_path(path, base), **file_entry(path)}
            for label, path in input_files(config).items()}


# ---------------------------------------------------------------------------------------------- writing
def package_version(dist: str) -> str | None:
    """The installed version of distribution ``dist`` (None when not installed)."""
    try:
        return importlib_metadata.version(dist)
    except importlib_metadata.PackageNotFoundError:
        return None


def write_json_file(path: Path, data: Mapping[str, Any]) -> Path:
    """Write ``data`` as indented JSON (one trailing newline) atomically, mode 0644."""

    return write_atomically(path, lambda stream: stream.write(json.dumps(data, indent=2, default=str) + "\n"))


def manifest_document(out: Path, config: BuildConfig, surrogate_keys: Mapping[str, str | None] | None = None,
                      judge_keys: Mapping[str, str] | None = None,
                      selection: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The manifest of the district in ``out`` (see the module docstring); deterministic. ``surrogate_keys``:
    each building's surrogate cache key; ``judge_keys``: each judged house's judgement cache key; ``selection``:
    the k-means selection's k and validity indices (:class:`pipeline.builder.report.SelectionSummary`, for the
    report a ``surrogate install`` rewrites; None: the buildings were listed)."""
    return {"district": config.name, "config": portable_config(config), "inputs": input_hashes(config),
            "outputs": output_hashes(out), "versions": {d: package_version(d) for d in VERSIONED},
            "python": platform.python_version(),
            "seeds": {"build": config.seed, "surrogate": config.surrogate.seed},
            "surrogate_cache": {name: surrogate_cache_entry(key, (judge_keys or {}).get(name))
                                for name, key in (surrogate_keys or {}).items()},
            "run_record": TIMINGS, **({"selection": dict(selection)} if selection is not None else {})}


def surrogate_cache_entry(key: str | None, judge_key: str | None = None) -> dict[str, str | None]:
    """A building's ``surrogate_cache`` entry of the manifest: ``{"key": ...}`` and, for a judged house,
    ``"judge_key"``."""
    return {"key": key} if judge_key is None else {"key": key, "judge_key": judge_key}


def write_manifest(out: Path, config: BuildConfig, surrogate_keys: Mapping[str, str | None] | None = None,
                   judge_keys: Mapping[str, str] | None = None, selection: Mapping[str, Any] | None = None) -> Path:
    """Write ``out/manifest.json`` (:func:`manifest_document`) and the sidecar (:func:`write_sidecar`);
    returns the manifest's path."""
    path = write_json_file(out / MANIFEST, manifest_document(out, config, surrogate_keys, judge_keys, selection))
    write_sidecar(out)
    return path


def write_timings(out: Path, config: BuildConfig, seconds: Mapping[str, float],
                  surrogates: Mapping[str, Mapping[str, object]] | None = None,
                  precision: Choice | None = None) -> Path:
    """Write ``out/timings.json``: the CPU (:func:`surrogates.precision.capability`), ``seconds`` per build
    stage [s, wall clock], the precision the build resolved for its surrogates' updates, what was asked and why
    (``precision``: :func:`pipeline.builder.surrogates.resolve_precision`), per building the surrogate's training
    seconds, the precision its updates ran in and whether the cache had it, the configuration file's and the
    cache's locations, the build process's peak resident memory [MB] (``ru_maxrss``: with Dask, the driver's
    alone) and the UTC time it was written. Not reproducible, so the manifest does not hash it; the sidecar
    does."""

    record = {"finished_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"), "cpu": capability().describe(),
              "config_file": str(Path(config.source).resolve()) if Path(config.source).name != "<dict>" else None,
              "config_folder": str(config_folder(config)), "cache_root": str(cache_root(config.cache_dir)),
              "stages_s": {k: round(float(v), 3) for k, v in seconds.items()},
              "build_process_peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
              "precision": None if precision is None else precision.record(),
              "surrogates": {k: dict(v) for k, v in (surrogates or {}).items()}}
    path = write_json_file(out / TIMINGS, record)
    write_sidecar(out)
    return path


def split_metrics_timings(metrics: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """A surrogate metrics report without its seconds, and those seconds.

    Returns ``(metrics without training.train_seconds / train_cpu_seconds and the per-epoch
    training.history[*].seconds, {"train_seconds": s, "train_cpu_seconds": s, "epoch_seconds": [s, ...]})``.
    Pure: the argument is not changed.
    """
    clean = json.loads(json.dumps(metrics))
    training = clean.get("training") or {}
    timings: dict[str, Any] = {k: training.pop(k) for k in TRAINING_SECONDS if k in training}
    if "precision" in training:  # the mode that ran stays in the metrics too (it decides the weights)
        timings["precision"] = training["precision"]
    history = training.get("history") or []
    epochs = [epoch.pop("seconds") for epoch in history if isinstance(epoch, dict) and "seconds" in epoch]
    if epochs:
        timings["epoch_seconds"] = epochs
    return clean, timings


def split_surrogate_timings(files: Mapping[str, bytes]) -> tuple[dict[str, bytes], dict[str, Any]]:
    """A building's surrogate files (relative path -> bytes) with the seconds taken out of its
    ``*.metrics.json`` (:func:`split_metrics_timings`; written back as ``json.dumps(indent=2)`` + newline, the
    trainer's own format), and those seconds."""
    out, timings = dict(files), {}
    for name, data in files.items():
        if name.endswith(".metrics.json"):
            clean, timings = split_metrics_timings(json.loads(data))
            out[name] = (json.dumps(clean, indent=2) + "\n").encode()
    return out, timings


def write_sidecar(out: Path) -> Path:
    """Write ``out/manifest.sha256``: the sha256 of ``manifest.json`` and of ``timings.json`` (when present), one
    ``<hex>  <name>`` line each (``sha256sum`` format). Written after both records, by every writer of them."""
    lines = "".join(f"{sha256_file(out / name)}  {name}\n" for name in (MANIFEST, TIMINGS) if (out / name).is_file())
    return write_atomically(out / SIDECAR, lambda stream: stream.write(lines))


def manifest_digest(folder: str | os.PathLike) -> str:
    """The manifest digest: sha256 of ``manifest.json``'s bytes (see the module docstring)."""
    return sha256_file(Path(folder) / MANIFEST)


def make_world_readable(folder: Path) -> None:
    """Mode 0755 on ``folder`` and every folder under it, 0644 on every file (symlinks untouched), whatever
    the umask and the temporary-folder modes the build went through."""
    os.chmod(folder, FOLDER_MODE)
    for root, dirs, files in os.walk(folder):
        for name in dirs:
            if not os.path.islink(os.path.join(root, name)):
                os.chmod(os.path.join(root, name), FOLDER_MODE)
        for name in files:
            if not os.path.islink(os.path.join(root, name)):
                os.chmod(os.path.join(root, name), FILE_MODE)


# ---------------------------------------------------------------------------------------------- verify
@dataclass(frozen=True)
class Verification:
    """Problems (an artifact or an input differs from the manifest, an artifact is missing) and warnings (an
    unknown file, an input not at hand); each one line starting with the file it is about."""

    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def read_manifest(folder: Path) -> dict[str, Any]:
    """``folder/manifest.json``; a missing or malformed one is an :class:`InputError`."""
    try:
        manifest = json.loads((folder / MANIFEST).read_text())
    except FileNotFoundError:
        raise InputError("no manifest.json: not a districtgen build", file=folder) from None
    except (OSError, ValueError) as error:
        raise InputError(f"manifest.json is not a districtgen manifest ({error})", file=folder / MANIFEST) from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("outputs"), dict):
        raise InputError("manifest.json is not a districtgen manifest (no 'outputs' table)", file=folder / MANIFEST,
                         column="outputs")
    return manifest


def recorded_config_folder(folder: Path) -> Path | None:
    """Where the build's configuration file was (from ``timings.json``), or None when not recorded."""
    try:
        where = json.loads((folder / TIMINGS).read_text()).get("config_folder")
    except (OSError, ValueError, AttributeError):
        return None
    return Path(where) if where else None


def inside(folder: Path, name: str) -> bool:
    """Whether the relative POSIX path ``name`` stays inside ``folder`` (no absolute path, no ``..``, no
    symlink that leads out)."""
    if not isinstance(name, str) or not name or name.startswith("/") or ".." in name.split("/"):
        return False
    root = folder.resolve()
    return (root / name).resolve().is_relative_to(root)


def check_outputs(folder: Path, outputs: Mapping[str, Mapping[str, object]]) -> Verification:
    """Every listed artifact present with its sha256 (problems); files not listed (warnings). A listed name
    that leaves the district (absolute, ``..``, a symlink out) is a problem and is never read."""
    problems = []
    for name, entry in outputs.items():
        path = folder / name
        if not inside(folder, name):
            problems.append(f"{name}: names a file outside the district (not read)")
        elif not path.is_file():
            problems.append(f"{name}: missing")
        elif sha256_file(path) != entry["sha256"]:
            problems.append(f"{name}: sha256 differs from the manifest")
    warnings = [f"{name}: not in the manifest (an unknown file)" for name in district_files(folder)
                if name not in outputs]
    return Verification(problems, warnings)


#: top-level folders of the system that no districtgen input lives in: pseudo file systems (reading them can
#: hang or never end) and system configuration (hashing it against a crafted manifest would be a content oracle)
SYSTEM_FOLDERS = ("/proc", "/sys", "/dev", "/run", "/etc", "/boot", "/root", "/var")


def readable_input(path: Path, size: object) -> str | None:
    """Why verify must not open the input at ``path`` (a reason), or None when it may: a regular file outside the
    system folders (:data:`SYSTEM_FOLDERS`) whose size is the recorded ``size`` [bytes] (a file of another size
    differs without reading it, so a read is bounded by what the build read)."""
    resolved = path.resolve()
    if any(resolved == Path(root) or resolved.is_relative_to(root) for root in SYSTEM_FOLDERS):
        return "a system file, never an input (not read)"
    try:
        stat = os.stat(resolved)
    except OSError:
        return None  # not found: reported as not checked
    if not S_ISREG(stat.st_mode):
        return "not a regular file (not read)"
    if not isinstance(size, int) or stat.st_size != size:
        return (f"sha256 differs from the manifest (the district was built from other data: {stat.st_size} bytes "
                f"against the recorded {size}; not read)")
    return None


def check_inputs(inputs: Mapping[str, Mapping[str, object]], base: Path | None) -> Verification:
    """Each input re-hashed at ``base / path``: a different sha256 or size is a problem; an absolute recorded
    path (a build records them relative to its configuration's folder), a system file or anything but a regular
    file is a problem and is never opened (:func:`readable_input`); an input not found (or no ``base``) is a
    warning (not checked)."""
    problems, warnings = [], []
    for label, entry in inputs.items():
        recorded = Path(str(entry["path"]))
        if recorded.is_absolute() or str(entry["path"]).startswith(("http://", "https://")):
            if recorded.is_absolute():
                problems.append(f"{recorded} (input {label}): an absolute path, not one a build records (not read)")
            continue
        if base is None:
            warnings.append(f"{recorded} (input {label}): not checked, the configuration's folder is not "
                            f"recorded ({TIMINGS} missing)")
            continue
        path = base / recorded
        refused = readable_input(path, entry.get("bytes"))
        if refused is not None:
            problems.append(f"{path} (input {label}): {refused}")
        elif not path.is_file():
            warnings.append(f"{path} (input {label}): not found here, not checked")
        elif sha256_file(path) != entry["sha256"]:
            problems.append(f"{path} (input {label}): sha256 differs from the manifest (the district was "
                            "built from other data)")
    return Verification(problems, warnings)


def read_sidecar(folder: Path) -> tuple[dict[str, str], list[int]]:
    """``manifest.sha256`` as record name -> sha256 (hex), and the numbers (1-based) of its lines that are not
    ``<64 hex>  <name>`` (an empty file or a missing one: nothing listed)."""
    try:
        text = (folder / SIDECAR).read_text()
    except (OSError, UnicodeDecodeError):
        return {}, []
    lines = text.split("\n")
    lines = lines[:-1] if lines and lines[-1] == "" else lines
    found = [re.fullmatch(r"([0-9a-f]{64}) [ *]([^\s]+)", line) for line in lines]
    return {m.group(2): m.group(1) for m in found if m}, [i + 1 for i, m in enumerate(found) if m is None]


def check_records(folder: Path, expect: str | None = None) -> Verification:
    """The two records against ``manifest.sha256`` (a record that differs or is not listed is a problem: an
    edited ``timings.json`` would move where the inputs are checked), and the manifest digest against ``expect``
    (the pinned value of ``verify --expect``; None: not pinned)."""
    recorded, malformed = read_sidecar(folder)
    problems = [f"{SIDECAR}: line {n} is not '<sha256>  <record>' (edited after the build)" for n in malformed]
    if MANIFEST not in recorded:
        problems.append(f"{SIDECAR}: missing or without a line for {MANIFEST} (the records cannot be checked)")
    for name, digest in recorded.items():
        if name not in (MANIFEST, TIMINGS):
            problems.append(f"{SIDECAR}: names {name!r}, not a record of the district")
        elif not (folder / name).is_file():
            problems.append(f"{name}: missing (listed in {SIDECAR})")
        elif sha256_file(folder / name) != digest:
            problems.append(f"{name}: sha256 differs from {SIDECAR} (edited after the build)")
    if (folder / TIMINGS).is_file() and TIMINGS not in recorded and MANIFEST in recorded:
        problems.append(f"{TIMINGS}: not listed in {SIDECAR} (added after the build)")
    digest = manifest_digest(folder) if expect is not None else None
    if digest is not None and digest != expect.lower():
        problems.append(f"{MANIFEST}: manifest digest {digest} is not the expected {expect} "
                        "(another build, configuration, input or package version)")
    return Verification(problems, [])


def check_manifest_fields(manifest: Mapping[str, Any]) -> Verification:
    """The manifest's own fields agree with its configuration: the district name and both seeds."""
    config = manifest.get("config") if isinstance(manifest.get("config"), dict) else {}
    problems = []
    if config and manifest.get("district") != config.get("name"):
        problems.append(f"{MANIFEST}: district {manifest.get('district')!r} is not the configuration's name "
                        f"{config.get('name')!r}")
    surrogate = config.get("surrogate") if isinstance(config.get("surrogate"), dict) else {}
    wanted = {"build": config.get("seed"), "surrogate": surrogate.get("seed")}
    if config and manifest.get("seeds") != wanted:
        problems.append(f"{MANIFEST}: seeds {manifest.get('seeds')} are not the configuration's {wanted}")
    return Verification(problems, [])


def check_district(folder: str | Path, config_folder: Path | None = None, expect: str | None = None
                   ) -> Verification:
    """Re-hash every file of a district against its records: the artifacts and inputs against the manifest
    (:func:`check_outputs`, :func:`check_inputs`), the manifest's fields against its configuration, both
    records against ``manifest.sha256`` and the manifest digest against ``expect`` (:func:`check_records`).

    ``config_folder``: where the inputs' relative paths resolve (default: the folder recorded in
    ``timings.json``). Raises :class:`InputError` for a folder that is not a districtgen build (no readable
    manifest.json and no ``manifest.sha256``); a build's manifest changed into something that does not parse
    is a problem (with what ``manifest.sha256`` says of it), as nothing else can be checked against it.
    """
    folder = Path(folder)
    try:
        manifest = read_manifest(folder)
    except InputError:
        if not (folder / SIDECAR).is_file():
            raise  # nothing records a manifest: not a districtgen build
        return _changed_manifest(check_records(folder, expect))
    records = check_records(folder, expect)
    try:
        parts = (records, check_manifest_fields(manifest), check_outputs(folder, manifest["outputs"]),
                 check_inputs(manifest.get("inputs") or {}, config_folder or recorded_config_folder(folder)))
    except (KeyError, TypeError, AttributeError):  # parses, but changed into another shape
        return _changed_manifest(records)
    return Verification([p for part in parts for p in part.problems], [w for part in parts for w in part.warnings])


def _changed_manifest(records: Verification) -> Verification:
    """What a build whose manifest.json no longer reads as one can report: its records' check and that."""
    return Verification([*records.problems, f"{MANIFEST}: not a districtgen manifest (changed after the build)"],
                        records.warnings)


def verify_district(folder: str | Path) -> list[str]:
    """The problems of :func:`check_district` (empty: every artifact and input matches the manifest)."""
    return check_district(folder).problems
