"""``manifest.json`` / ``timings.json``, ``districtgen verify`` and ``districtgen surrogate install`` on real
builds of the synthetic fixture district (issue 15, part 5)."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pandas as pd
import pytest

from pipeline.builder.driver import build_district_local
from pipeline.builder.manifest import (
    check_district,
    verify_district,
    write_manifest,
    write_sidecar,
    write_timings,
)
from pipeline.cli import main
from pipeline.config import read_build_config

ROOT = Path(__file__).resolve().parents[3]
FIXTURE = ROOT / "tests" / "fixtures" / "synthetic_district"
INPUTS = {"weather": "weather/USA_FL_Tampa.Intl.AP.722110_TMY3.epw", "tariff": "../../../raw/tariffs/"
          "austin_energy_tou_2018.toml", "fuel_mix": "fuel_mix/IntGenbyFuel2018_synthetic.xlsx"}


def district_config(folder: Path, *, source: str = "none") -> Path:
    """The fixture district (1-3 June 2018) in ``folder``, with copies of its weather, tariff and fuel mix and
    its ILV tables cut to 1-21 June under ``folder/inputs`` (relative paths, as a user writes them)."""
    inputs = folder / "inputs"
    (inputs / "ilv").mkdir(parents=True, exist_ok=True)
    for relative in INPUTS.values():
        shutil.copyfile(FIXTURE / relative, inputs / Path(relative).name)
    for path in sorted((FIXTURE / "ilv").glob("*.parquet")):
        table = pd.read_parquet(path)
        stamp = pd.to_datetime(table["timestamp"])
        table[(stamp >= "2018-06-01") & (stamp < "2018-06-22")].reset_index(drop=True).to_parquet(
            inputs / "ilv" / path.name, index=False)
    text = FIXTURE.joinpath("district.toml").read_text().replace("end = 2018-06-30", "end = 2018-06-03")
    for key, relative in INPUTS.items():
        text = text.replace(f'{key} = "{relative}"', f'{key} = "inputs/{Path(relative).name}"')
    text = text.replace('eulp = "eulp/', f'eulp = "{FIXTURE}/eulp/').replace('ilv = "ilv"', 'ilv = "inputs/ilv"')
    text = text.replace('source = "csv"', f'source = "{source}"').replace("epochs = 40", "epochs = 1")
    path = folder / "district.toml"
    path.write_text(text)
    return path


def verify_lines(folder: Path, capsys) -> tuple[int, list[str]]:
    """``districtgen verify FOLDER``: exit status and the printed lines."""
    status = main(["verify", str(folder)])
    out = capsys.readouterr()
    return status, (out.out + out.err).strip().splitlines()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """One short build without surrogates (relative input paths); tests work on copies of it."""
    tmp = tmp_path_factory.mktemp("manifest")
    return build_district_local(read_build_config(district_config(tmp)), tmp / "out")


@pytest.fixture()
def district(built, tmp_path):
    """A copy of the build beside it (so the inputs' folder recorded in timings.json still holds)."""
    copy = built.parent / f"copy-{tmp_path.name}"
    shutil.copytree(built, copy)
    yield copy
    shutil.rmtree(copy, ignore_errors=True)


def test_intact_build_verifies_with_exit_0(district, capsys):
    assert check_district(district).problems == [] and check_district(district).warnings == []
    status, lines = verify_lines(district, capsys)
    assert status == 0 and "every artifact and input matches the manifest" in lines[-2]
    manifest = json.loads((district / "manifest.json").read_text())
    assert manifest["inputs"]["weather"]["path"] == "inputs/USA_FL_Tampa.Intl.AP.722110_TMY3.epw"
    assert {"eulp_metadata", "eulp_timeseries/900001", "eulp_timeseries/900002"} <= set(manifest["inputs"])
    for name in ("Building_1.csv", "Building_2.csv", "schema.json", "report/summary.md", "buildings.json"):
        data = (district / name).read_bytes()
        assert manifest["outputs"][name] == {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}


def test_changed_building_timeseries_is_one_line_and_exit_2(district, capsys):
    path = district / "Building_1.csv"
    lines = path.read_text().splitlines()
    lines[5] = lines[5].replace(",", ",1", 1)     # one value of one row changed
    path.write_text("\n".join(lines) + "\n")
    assert verify_district(district) == ["Building_1.csv: sha256 differs from the manifest"]
    status, out = verify_lines(district, capsys)
    assert status == 2 and any(line.endswith("Building_1.csv: sha256 differs from the manifest") for line in out)


def test_deleted_artifact_is_reported(district, capsys):
    (district / "report" / "kpis_cost_rbc.csv").unlink()
    assert verify_district(district) == ["report/kpis_cost_rbc.csv: missing"]
    assert verify_lines(district, capsys)[0] == 2


def test_unknown_file_is_a_warning_only(district, capsys):
    (district / "notes.txt").write_text("mine\n")
    result = check_district(district)
    assert result.problems == [] and result.warnings == ["notes.txt: not in the manifest (an unknown file)"]
    status, lines = verify_lines(district, capsys)
    assert status == 0 and any("warning" in line and "notes.txt" in line for line in lines)


def test_changed_input_file_is_reported(built, district, capsys):
    tariff = built.parent.parent / "inputs" / "austin_energy_tou_2018.toml"
    original = tariff.read_bytes()
    try:
        tariff.write_bytes(original + b"\n# edited\n")
        problems = verify_district(district)
        assert len(problems) == 1 and "austin_energy_tou_2018.toml (input tariff): sha256 differs" in problems[0]
        assert verify_lines(district, capsys)[0] == 2
    finally:
        tariff.write_bytes(original)


def test_changed_ilv_table_is_reported(tmp_path):
    """A csv-surrogate configuration lists its ILV tables among the inputs; a changed table is a problem."""
    config = read_build_config(district_config(tmp_path, source="csv"))
    out = tmp_path / "district"
    out.mkdir()
    (out / "schema.json").write_text("{}\n")
    write_manifest(out, config)
    write_timings(out, config, {"ingest": 1.0})
    assert verify_district(out) == []
    table_path = tmp_path / "inputs" / "ilv" / "900002.parquet"
    table = pd.read_parquet(table_path)
    table.loc[10, "indoor_dry_bulb_temperature"] += 0.5
    table.to_parquet(table_path, index=False)
    problems = verify_district(out)
    assert len(problems) == 1 and "900002.parquet (input ilv/900002): sha256 differs" in problems[0]


@pytest.mark.parametrize("record", ["manifest.json", "timings.json"])
def test_install_refuses_a_district_whose_records_fail_verify(district, tmp_path, record):
    """An edited manifest.json (its weather.csv entry rewritten to hide an edited row) or timings.json fails
    verify: install refuses before anything is touched, one line naming the record; --force says what it
    overrides."""
    from pipeline.builder.install import check_verified
    from pipeline.errors import InputError

    if record == "manifest.json":
        weather = district / "weather.csv"
        weather.write_bytes(weather.read_bytes().replace(b"\n", b"\n45.0,", 1))
        manifest = json.loads((district / record).read_text())
        manifest["outputs"]["weather.csv"]["sha256"] = hashlib.sha256(weather.read_bytes()).hexdigest()
        manifest["outputs"]["weather.csv"]["bytes"] = weather.stat().st_size
        (district / record).write_text(json.dumps(manifest))
    else:
        timings = json.loads((district / record).read_text())
        timings["config_folder"] = str(tmp_path)
        (district / record).write_text(json.dumps(timings))
    before = {p: p.read_bytes() for p in district.rglob("*") if p.is_file()}
    with pytest.raises(InputError, match=rf"fails verify \({record}: sha256 differs from manifest.sha256.*--force"):
        check_verified(district, force=False)
    assert any(record in line for line in check_verified(district, force=True))
    assert main(["surrogate", "install", str(district), "Building_1", str(tmp_path / "m.pth")]) == 2
    assert {p: p.read_bytes() for p in district.rglob("*") if p.is_file()} == before


def test_a_district_moved_away_from_its_inputs_warns(district, tmp_path):
    moved = tmp_path / "moved"
    shutil.copytree(district, moved)
    (moved / "timings.json").unlink()
    result = check_district(moved)
    assert result.problems == ["timings.json: missing (listed in manifest.sha256)"]
    assert any("input weather" in w and "not checked" in w for w in result.warnings)


# ---------------------------------------------------------------------------------------------- install
def tiny_model(table: Path, out: Path, **settings) -> Path:
    """Train a tiny LSTM with ``surrogates.cli.train`` (a few one-step updates, one closed-loop epoch)."""
    from surrogates.cli import train
    from surrogates.config import TrainConfig

    config = TrainConfig(hidden_size=8, num_layers=1, epochs=1, pretrain_steps=30, batch_size=64,
                         pretrain_batch_size=64, progress=False, **settings)
    train(table, out, "retrained", config)
    return out / "retrained.pth"


@pytest.mark.slow  # one build with surrogates and two tiny trainings: about a minute on 2 cores
def test_install_a_retrained_surrogate_then_verify(tmp_path, capsys):
    path = district_config(tmp_path, source="csv")
    config = read_build_config(path).model_copy(update={"cache_dir": tmp_path / "cache"})
    district = build_district_local(config, tmp_path / "out")
    table = district / "surrogates" / "Building_1.ilv.parquet"   # kept with the district: no cache, no inputs
    model = tiny_model(table, tmp_path / "model")

    assert main(["surrogate", "install", str(district), "Building_1", str(model.parent)]) == 0
    assert "verify passes" in capsys.readouterr().out
    assert (district / "Building_1.pth").read_bytes() == model.read_bytes()
    block = json.loads((district / "schema.json").read_text())["buildings"]["Building_1"]["dynamics"]
    assert block["attributes"]["hidden_size"] == 8 and block["attributes"]["filename"] == "Building_1.pth"
    assert block["attributes"]["num_layers"] == 1
    assert "train_seconds" not in json.loads((district / "surrogates/Building_1.metrics.json").read_text())[
        "training"]
    assert json.loads((district / "timings.json").read_text())["surrogates"]["Building_1"]["train_seconds"] >= 0
    assert check_district(district).problems == [] and check_district(district).warnings == []
    assert verify_lines(district, capsys)[0] == 0
    assert "## Buildings" in (district / "report" / "summary.md").read_text()   # the build's section is kept

    before = (district / "manifest.json").read_bytes()
    assert main(["surrogate", "install", str(district), "Building_9", str(model)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no building 'Building_9'" in err[0]
    narrow = tiny_model(table, tmp_path / "narrow", inputs=("outdoor_dry_bulb_temperature", "cooling_demand",
                                                            "heating_demand", "indoor_dry_bulb_temperature"))
    assert main(["surrogate", "install", str(district), "Building_2", str(narrow)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "LSTM inputs" in err[0] and "retrained.pth" in err[0]
    assert (district / "manifest.json").read_bytes() == before   # a refused model changes nothing

    # trained on 900001's table: not Building_2's (900002) -- refused, then installed with --force
    assert main(["surrogate", "install", str(district), "Building_2", str(model)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not this house's training table" in err[0] and "--force" in err[0]
    assert (district / "manifest.json").read_bytes() == before
    # a link planted at the file install replaces: removed, never written through
    outside = tmp_path / "precious.pth"
    outside.write_bytes(b"precious")
    (district / "Building_2.pth").unlink()
    (district / "Building_2.pth").symlink_to(outside)
    assert main(["surrogate", "install", str(district), "Building_2", str(model), "--force"]) == 0
    capsys.readouterr()
    assert outside.read_bytes() == b"precious" and not (district / "Building_2.pth").is_symlink()
    assert (district / "Building_2.pth").read_bytes() == model.read_bytes()
    # the district keeps the table each CURRENT model was trained on: Building_1's stays (it is the one),
    # Building_2's goes (its model now comes from Building_1's table)
    assert table.is_file() and not (district / "surrogates" / "Building_2.ilv.parquet").exists()
    assert verify_lines(district, capsys)[0] == 0
    summary = (district / "report" / "summary.md").read_text()
    digest = json.loads((district / "surrogates/Building_1.metrics.json").read_text())["table_sha256"]
    assert f"Building_1.ilv.parquet `{digest[:12]}`" in summary   # which table each model was trained and scored on

    # the replay is recomputed, not copied: the installed metrics hold it beside the claim
    replay = json.loads((district / "surrogates/Building_1.metrics.json").read_text())["install_replay"]
    assert replay["hours"] > 0 and replay["closed_loop_rmse_c"] <= 1.5 * replay["claimed_closed_loop_rmse_c"] + 0.1
    # an unknown file in the district stays unknown: never added to the manifest by an install
    (district / "notes.txt").write_text("mine\n")
    assert main(["surrogate", "install", str(district), "Building_1", str(model)]) == 0
    capsys.readouterr()
    assert "notes.txt" not in json.loads((district / "manifest.json").read_text())["outputs"]
    assert check_district(district).warnings == ["notes.txt: not in the manifest (an unknown file)"]
    # a model whose predictions are biased by tens of degC, its copied metrics still claiming a good fit: its
    # replay on the house's held-out runs refuses it, and nothing changes
    biased = biased_model(model, tmp_path / "biased")
    before = (district / "manifest.json").read_bytes()
    assert main(["surrogate", "install", str(district), "Building_1", str(biased)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "held-out runs is off by" in err[0] and "its metrics claim" in err[0]
    assert (district / "manifest.json").read_bytes() == before


def biased_model(model: Path, out: Path) -> Path:
    """A copy of ``model`` (with its records) whose output layer is shifted by +5 (normalised units: tens of
    degC), its metrics copied unchanged."""
    import torch

    out.mkdir()
    for path in model.parent.glob(f"{model.stem}.*"):
        shutil.copy(path, out / path.name)
    checkpoint = torch.load(model, weights_only=False)
    checkpoint["model_state_dict"]["l_linear.bias"] += 5.0
    torch.save(checkpoint, out / model.name)
    return out / model.name


def test_training_table_check_names_both_tables(tmp_path):
    """The model's record must name the house's table content (table_sha256); else one line, --force hint."""
    from pipeline.builder.install import ModelFiles, check_training_table
    from pipeline.errors import InputError

    def record(name: str, **fields) -> Path:
        path = tmp_path / name
        path.write_text(json.dumps({"building": "B", **fields}))
        return path

    house = record("house.metrics.json", table_sha256="a" * 64)
    model = ModelFiles(tmp_path / "m.pth", tmp_path / "m.dynamics.json", record("m.metrics.json",
                                                                                table_sha256="a" * 64), None)
    check_training_table(model, house, "Building_1")   # the same table: accepted
    other = ModelFiles(model.pth, model.dynamics, record("o.metrics.json", table_sha256="b" * 64), None)
    with pytest.raises(InputError, match=r"trained on ILV table bbbbbbbbbbbb, Building_1's surrogate on "
                                         r"aaaaaaaaaaaa: not this house's training table \(--force"):
        check_training_table(other, house, "Building_1")
    with pytest.raises(InputError, match="no training record beside the model"):
        check_training_table(ModelFiles(model.pth, model.dynamics, None, None), house, "Building_1")
    with pytest.raises(InputError, match="records no training table for Building_1"):
        check_training_table(model, record("old.metrics.json"), "Building_1")


def test_install_refuses_a_folder_that_is_not_a_district(tmp_path):
    from pipeline.builder.install import install_surrogate
    from pipeline.errors import InputError

    with pytest.raises(InputError, match="no manifest.json"):
        install_surrogate(tmp_path, "Building_1", tmp_path / "x.pth")


def test_install_refuses_a_tampered_district_before_touching_it(district, tmp_path):
    from pipeline.builder.install import install_surrogate
    from pipeline.errors import InputError

    csv = district / "Building_1.csv"
    csv.write_bytes(csv.read_bytes().replace(b"\n", b"\n0", 1))   # one changed cell
    before = {p: p.read_bytes() for p in district.rglob("*") if p.is_file()}
    with pytest.raises(InputError, match=r"fails verify \(.*Building_1.csv.*--force"):
        install_surrogate(district, "Building_1", tmp_path / "model.pth")
    assert {p: p.read_bytes() for p in district.rglob("*") if p.is_file()} == before
    # --force passes the check; this district has no surrogates, so the model check refuses next
    with pytest.raises(InputError, match="no .pth|not a model file"):
        install_surrogate(district, "Building_1", tmp_path / "model.pth", force=True)


@pytest.mark.parametrize("where", [".", "report"])
def test_install_from_inside_the_district_is_one_line(district, monkeypatch, capsys, where):
    monkeypatch.chdir(district / where)
    target = "." if where == "." else ".."
    assert main(["surrogate", "install", target, "Building_1", "model.pth"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "current directory is inside the district" in err[0]
    assert not any(p.name.startswith(f".{district.name}.install-") for p in district.parent.iterdir())


@pytest.mark.parametrize("name", ["../../etc/passwd", "/etc/passwd", "report/../../x"])
def test_verify_never_reads_outside_the_district(district, name):
    manifest = json.loads((district / "manifest.json").read_text())
    manifest["outputs"][name] = {"sha256": "0" * 64, "bytes": 1}
    (district / "manifest.json").write_text(json.dumps(manifest))
    write_sidecar(district)  # the editor rewrote the records consistently
    problems = check_district(district).problems
    assert problems == [f"{name}: names a file outside the district (not read)"]


def test_verify_refuses_a_link_out_of_the_district(district, tmp_path):
    (tmp_path / "secret").write_text("x")
    (district / "link.txt").symlink_to(tmp_path / "secret")
    manifest = json.loads((district / "manifest.json").read_text())
    manifest["outputs"]["link.txt"] = {"sha256": "0" * 64, "bytes": 1}
    (district / "manifest.json").write_text(json.dumps(manifest))
    write_sidecar(district)
    assert check_district(district).problems == ["link.txt: names a file outside the district (not read)"]


# ------------------------------------------------------------------ the records and the pinnable digest (issue 30.4)
def test_sidecar_holds_the_sha256_of_both_records(district):
    lines = (district / "manifest.sha256").read_text().splitlines()
    expected = [f"{hashlib.sha256((district / n).read_bytes()).hexdigest()}  {n}" for n in ("manifest.json",
                                                                                             "timings.json")]
    assert lines == expected  # sha256sum format: `sha256sum -c manifest.sha256` checks it
    assert "manifest.sha256" not in json.loads((district / "manifest.json").read_text())["outputs"]


def test_edited_timings_is_a_problem(district, tmp_path, capsys):
    """timings.json says where the inputs are checked: moved to an empty folder they would all be warnings."""
    record = json.loads((district / "timings.json").read_text())
    record["config_folder"] = str(tmp_path / "nowhere")
    (district / "timings.json").write_text(json.dumps(record))
    result = check_district(district)
    assert result.problems == ["timings.json: sha256 differs from manifest.sha256 (edited after the build)"]
    assert verify_lines(district, capsys)[0] == 2


def test_missing_sidecar_is_a_problem(district):
    (district / "manifest.sha256").unlink()
    assert verify_district(district) == ["manifest.sha256: missing or without a line for manifest.json (the "
                                         "records cannot be checked)"]


def test_manifest_seed_edited_is_caught_by_sidecar_fields_and_pin(district, capsys):
    """An edit of the manifest's seed is caught three ways: the sidecar, the configuration it records and,
    when the editor rewrote all of them consistently, only the pinned digest."""
    pinned = hashlib.sha256((district / "manifest.json").read_bytes()).hexdigest()
    manifest = json.loads((district / "manifest.json").read_text())
    manifest["seeds"]["build"] += 1
    (district / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    assert verify_district(district) == [
        "manifest.json: sha256 differs from manifest.sha256 (edited after the build)",
        f"manifest.json: seeds {manifest['seeds']} are not the configuration's "
        f"{{'build': {manifest['seeds']['build'] - 1}, 'surrogate': {manifest['seeds']['surrogate']}}}"]
    manifest["config"]["seed"] = manifest["seeds"]["build"]  # a consistent rewrite of every record
    (district / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    write_sidecar(district)
    assert verify_district(district) == []
    problems = check_district(district, expect=pinned).problems
    assert len(problems) == 1 and problems[0].startswith("manifest.json: manifest digest ")
    assert f"is not the expected {pinned}" in problems[0]
    assert main(["verify", str(district), "--expect", pinned]) == 2
    capsys.readouterr()


def test_verify_expect_accepts_the_digest_or_a_sidecar_copy(district, tmp_path, capsys):
    digest = hashlib.sha256((district / "manifest.json").read_bytes()).hexdigest()
    status, lines = verify_lines(district, capsys)
    assert status == 0 and lines[-1] == f"manifest digest {digest}"
    assert main(["verify", str(district), "--expect", digest.upper()]) == 0
    pin = tmp_path / "pinned.sha256"
    shutil.copyfile(district / "manifest.sha256", pin)
    assert main(["verify", str(district), "--expect", str(pin)]) == 0
    capsys.readouterr()
    assert main(["verify", str(district), "--expect", "abc"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--expect" in err[0] and "64 hex digits" in err[0]


INSTALLER = """
import os, signal, sys
from pipeline.builder import staging
from pipeline.builder.install import install_surrogate

label = sys.argv[3]
staging.STEP_HOOK = lambda step: os.kill(os.getpid(), signal.SIGKILL) if step == label else None
install_surrogate(sys.argv[1], "Building_1", sys.argv[2])
"""


def tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow  # one build with surrogates, one tiny training and six killed installs: about two minutes
def test_an_install_killed_at_any_step_leaves_the_old_or_the_new_district(tmp_path):
    """SIGKILL of a real ``surrogate install`` before each of its steps (the working copy, each write into it,
    the swap): the district verifies as the whole old one or the whole new one, and the next writer's cleaning
    leaves nothing hidden beside it."""
    import subprocess
    import sys

    from pipeline.builder.staging import clean_leftovers

    config = read_build_config(district_config(tmp_path, source="csv")).model_copy(
        update={"cache_dir": tmp_path / "cache"})
    built = build_district_local(config, tmp_path / "out")
    model = tiny_model(tmp_path / "inputs" / "ilv" / "900001.parquet", tmp_path / "model")
    old = tree(built)
    for label in ("copy", "place model", "revalidate", "records", "exchange", "delete old"):
        root = tmp_path / label.replace(" ", "_")
        district = root / built.name
        shutil.copytree(built, district)
        done = subprocess.run([sys.executable, "-c", INSTALLER, str(district), str(model), label], cwd=ROOT,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == -9, (label, done.stderr[-2000:])
        now = tree(district)
        if label == "delete old":   # killed after the exchange: the new district is in place
            assert now["Building_1.pth"] == model.read_bytes() and now != old, label
        else:
            assert now == old, label
        assert verify_district(district) == [], label
        clean_leftovers(root, built.name)
        assert [p.name for p in root.iterdir()] == [built.name], label


@pytest.mark.parametrize("name", ["Building_1.csv", "weather.csv", "pricing.csv", "carbon_intensity.csv",
                                  "schema.json", "buildings.json", "report/summary.md", "report/district_net.png",
                                  "manifest.json", "timings.json", "manifest.sha256"])
def test_every_file_class_of_a_district_is_covered_by_verify(district, name):
    """One byte of any file of the district changed: verify reports a problem naming that file."""
    path = district / name
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))
    problems = verify_district(district)
    assert problems and any(p.startswith(f"{name}:") or p.startswith("manifest.sha256:") for p in problems), problems
    if name != "manifest.sha256":
        assert any(p.startswith(f"{name}:") for p in problems), problems


@pytest.mark.parametrize("damage", [
    lambda text: text[: len(text) // 2],                                  # cut: no longer JSON
    lambda text: text.replace('"outputs"', '"output"', 1),                # JSON, without the outputs table
    lambda text: text.replace('"path"', '"pat"'),                         # JSON, an input without its path
])
def test_a_manifest_changed_into_another_shape_is_a_problem_not_a_crash(district, damage):
    path = district / "manifest.json"
    path.write_text(damage(path.read_text()))
    problems = verify_district(district)
    assert "manifest.json: not a districtgen manifest (changed after the build)" in problems
    assert any(p.startswith("manifest.sha256:") or p.startswith("manifest.json:") for p in problems)


def crafted_inputs(district: Path, inputs: dict) -> None:
    """Rewrite a district's manifest inputs (and its records' sidecar, as a crafted district would)."""
    manifest = json.loads((district / "manifest.json").read_text())
    manifest["inputs"] = inputs
    (district / "manifest.json").write_text(json.dumps(manifest))
    write_sidecar(district)


@pytest.mark.parametrize("path", ["/proc/self/pagemap", "../../../../../../../../proc/self/pagemap",
                                  "../../../../../../../../etc/shadow", "/etc/passwd", "../../../../../../dev/zero"])
def test_verify_never_opens_a_system_file_a_crafted_manifest_names(district, path):
    """A crafted manifest naming a pseudo file (a read that never ends), a device or a system file (a content
    oracle) gets one problem line per input; nothing is opened (the call returns: /proc/self/pagemap or
    /dev/zero read whole would not)."""
    crafted_inputs(district, {"weather": {"path": path, "sha256": "0" * 64, "bytes": 1}})
    problems = verify_district(district)
    assert len(problems) == 1 and "(input weather)" in problems[0] and "not read" in problems[0]


def test_verify_does_not_hash_an_input_of_another_size(district, tmp_path):
    """An input whose size is not the recorded one differs without being read (the read is bounded by what the
    build read)."""
    big = tmp_path / "inputs_big.bin"
    big.write_bytes(b"x" * 4096)
    config_folder = json.loads((district / "timings.json").read_text())["config_folder"]
    relative = os.path.relpath(big, config_folder)
    crafted_inputs(district, {"weather": {"path": relative, "sha256": "0" * 64, "bytes": 10}})
    problems = verify_district(district)
    assert len(problems) == 1 and "4096 bytes against the recorded 10; not read" in problems[0]


@pytest.mark.parametrize("building", ["../../victim", "/etc/victim", "..", "a/b"])
def test_install_refuses_a_building_name_that_is_a_path_even_with_force(district, tmp_path, building):
    """A crafted schema naming a building ``../../victim`` cannot make install (``--force`` included) write
    outside the district: the name is refused in one line before anything is read or copied."""
    from pipeline.builder.install import install_surrogate
    from pipeline.errors import InputError

    victim = tmp_path / "victim.pth"
    victim.write_bytes(b"precious")
    before = {p: p.read_bytes() for p in district.rglob("*") if p.is_file()}
    with pytest.raises(InputError, match="is not a safe name"):
        install_surrogate(district, building, tmp_path / "model.pth", force=True)
    assert victim.read_bytes() == b"precious"
    assert {p: p.read_bytes() for p in district.rglob("*") if p.is_file()} == before
