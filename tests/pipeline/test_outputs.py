"""Every command that writes outside a build opens its outputs without following links and never writes into a
built district (issue 50, items 1, 3 and 9): the rule of :mod:`citylearn_env.outputs`, then each command through
the real CLI (``paper``, ``optimal``, ``select``, the ingest commands, ``surrogate train|evaluate``, ``run``) with
links planted at its output names, a district as its output, names that would leave the folder and numeric
options out of range; and install's errors naming the district, not its deleted working copy."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from citylearn_env import load_schema
from citylearn_env.errors import InputError, SchemaError
from citylearn_env.example import write_example_district
from citylearn_env.outputs import check_not_district, check_slug, open_output, output_folder, write_output
from pipeline.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAPER_IDS = ["x-b1_b2-x-x"]


@pytest.fixture(scope="module")
def schema(tmp_path_factory) -> Path:
    return write_example_district(tmp_path_factory.mktemp("outputs"), n_buildings=2, hours=72, seed=1)


@pytest.fixture(scope="module")
def paper_schema(tmp_path_factory) -> Path:
    """The smallest district the paper's tests run (a test period needs a month)."""
    return write_example_district(tmp_path_factory.mktemp("paper"), n_buildings=3, hours=720, seed=11)


@pytest.fixture
def victim(tmp_path) -> Path:
    """A file outside every output folder that a planted link points at."""
    path = tmp_path / "victim.txt"
    path.write_text("precious\n")
    return path


def fake_district(folder: Path) -> Path:
    """A folder that looks like a built district (the two record files) with one data file."""
    folder.mkdir(parents=True)
    for name, text in (("manifest.json", "{}"), ("manifest.sha256", "0" * 64), ("Building_1.csv", "a,b\n1,2\n")):
        (folder / name).write_text(text)
    return folder


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def one_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


# --------------------------------------------------------------------------------------------- the rule
def test_a_link_at_the_name_is_refused_and_one_planted_meanwhile_is_replaced(tmp_path, victim):
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").symlink_to(victim)
    with pytest.raises(InputError, match=r"a\.csv.*symbolic link"):
        write_output(out, "a.csv", "written\n")
    assert victim.read_text() == "precious\n"
    # a link planted while the file is being written: the new file replaces it, nothing goes through it
    with open_output(out, "b.csv") as stream:
        (out / "b.csv").symlink_to(victim)
        stream.write("mine\n")
    assert not (out / "b.csv").is_symlink() and (out / "b.csv").read_text() == "mine\n"
    assert victim.read_text() == "precious\n"


def test_an_existing_file_is_replaced_not_written_through_its_hard_link(tmp_path, victim):
    out = tmp_path / "out"
    out.mkdir()
    os.link(victim, out / "shared.md")      # a hard link: writing into the file would change the victim
    write_output(out, "shared.md", "new\n")
    assert (out / "shared.md").read_text() == "new\n" and victim.read_text() == "precious\n"
    assert oct((out / "shared.md").stat().st_mode & 0o777) == oct(0o644)


def test_a_failed_write_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), open_output(tmp_path, "x.csv") as stream:
        stream.write("half")
        raise RuntimeError("the writer failed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["../../x", "a/b", "..", ".hidden", "", "x" * 200, "Building_1\x00"])
def test_names_that_become_paths_are_slugs(name):
    with pytest.raises(InputError, match="not a safe name"):
        check_slug(name, column="building")
    assert check_slug("Building_1.v2-a", column="building") == "Building_1.v2-a"


def test_no_output_inside_a_built_district_even_through_a_link(tmp_path):
    district = fake_district(tmp_path / "district")
    (tmp_path / "alias").symlink_to(district)
    for path in (district, district / "Building_1.csv", district / "report" / "x.md", tmp_path / "alias" / "y"):
        with pytest.raises(InputError, match="built district"):
            check_not_district(path)
    check_not_district(tmp_path / "elsewhere" / "y.csv")      # beside it is fine
    with pytest.raises(InputError, match="symbolic link"):
        output_folder(tmp_path / "alias", column="--output")


# ------------------------------------------------------------------------------------------------ paper
PAPER_NAMES = ["runs.csv", "results.csv", "results.md", "regret.csv", "regret.md", "multiplier_sweep.md",
               "cost_emissions.png", "actions_soc.png", "daily_peak.png", "soc_trajectories.png",
               "tasks/x-b1_b2-x-x-m3-s0.json", "tasks", "."]


def paper(schema: Path, out: Path, *extra: str) -> list[str]:
    return ["paper", str(schema), "-o", str(out), "--only", *PAPER_IDS, "--sac-episodes", "1", "--workers", "1",
            "--controllers", "rbc", *extra]


@pytest.mark.parametrize("name", PAPER_NAMES)
def test_paper_refuses_a_link_planted_at_any_output_name(paper_schema, tmp_path, victim, capsys, name):
    out = tmp_path / "run"
    link = out / name if name != "." else out
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(victim if name not in (".", "tasks") else victim.parent)
    assert main(paper(paper_schema, out)) == 2
    line = one_error(capsys)
    assert str(link) in line and "symbolic link" in line
    assert victim.read_text() == "precious\n" and sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["run", "victim.txt"])


def test_paper_writes_regular_files_and_never_into_a_district(paper_schema, tmp_path, victim, capsys):
    out = tmp_path / "run"
    out.mkdir()
    os.link(victim, out / "results.md")      # a hard link at an output name: the run replaces it
    page = tmp_path / "page.md"
    assert main(paper(paper_schema, out, "--docs", str(page))) == 0
    capsys.readouterr()
    assert victim.read_text() == "precious\n" and "x-b1_b2-x-x" in (out / "results.md").read_text()
    assert all(not p.is_symlink() for p in out.rglob("*")) and (out / "tasks" / "x-b1_b2-x-x-m3-s0.json").is_file()
    assert not [p for p in out.rglob("*.tmp")] and "x-b1_b2-x-x" in page.read_text()
    district = fake_district(tmp_path / "district")
    before = snapshot(district)
    for argv in (paper(paper_schema, district), paper(paper_schema, district / "report"),
                 paper(paper_schema, out, "--docs", str(district / "README.md"))):
        assert main(argv) == 2
        assert "built district" in one_error(capsys)
    assert snapshot(district) == before and not (district / "report").exists()
    (tmp_path / "docs_link.md").symlink_to(victim)
    assert main(paper(paper_schema, out, "--docs", str(tmp_path / "docs_link.md"))) == 2
    assert "docs_link.md" in one_error(capsys) and victim.read_text() == "precious\n"


@pytest.mark.parametrize(("argv", "says"), [
    (["--sac-episodes", "-1"], "--sac-episodes must be a number >= 1, got -1"),
    (["--sac-episodes", "0"], "--sac-episodes must be a number >= 1, got 0"),
    (["--seeds", "0"], "--seeds must be a number >= 1"),
    (["--workers", "0"], "--workers must be a number >= 1"),
    (["--seed", "-3"], "--seed must be a number >= 0"),
    (["--sac-threads", "0"], "--sac-threads must be a number >= 1"),
    (["--multiplier", "-1"], "--multiplier must be a number >= 0"),
    (["--multiplier", "nan"], "--multiplier must be a number >= 0, got nan"),
    (["--sweep", "1", "inf"], "--sweep must be a number >= 0, got inf"),
])
def test_paper_numeric_options_out_of_range_are_one_line(paper_schema, tmp_path, capsys, argv, says):
    out = tmp_path / "run"
    base = paper(paper_schema, out)
    base[base.index("--sac-episodes"):base.index("--sac-episodes") + 2] = []   # the case sets its own
    assert main([*base, *argv]) == 2
    assert says in one_error(capsys)
    assert not out.exists()


# ---------------------------------------------------------------------------------------------- optimal
def test_optimal_never_writes_through_a_link_nor_into_a_district(schema, tmp_path, victim, capsys):
    pytest.importorskip("highspy")
    link = tmp_path / "schedule.csv"
    link.symlink_to(victim)
    assert main(["optimal", str(schema), "--no-check", "-o", str(link)]) == 2
    line = one_error(capsys)
    assert str(link) in line and "symbolic link" in line and victim.read_text() == "precious\n"
    district = fake_district(tmp_path / "district")
    before = snapshot(district)
    for target in (district / "Building_1.csv", district / "new.csv"):
        assert main(["optimal", str(schema), "--no-check", "-o", str(target)]) == 2
        assert "built district" in one_error(capsys)
    assert snapshot(district) == before
    # a regular file there is replaced by a new one (its other hard link keeps the old bytes)
    os.link(victim, tmp_path / "old.csv")
    assert main(["optimal", str(schema), "--no-check", "-o", str(tmp_path / "old.csv")]) == 0
    capsys.readouterr()
    assert victim.read_text() == "precious\n" and (tmp_path / "old.csv").read_text().startswith("time_step,")


@pytest.mark.parametrize(("argv", "says"), [
    (["--mpc", "--horizon", "0"], "--horizon N needs N >= 1 steps, got 0"),
    (["--mpc", "--horizon", "-5"], "--horizon N needs N >= 1 steps, got -5"),
    (["--mpc", "--train", "0", "10"], "--forecast perfect ignores it"),
    (["--mpc", "--forecast", "persistence", "--train", "0", "10"], "--forecast persistence ignores it"),
])
def test_optimal_options_that_mean_nothing_are_one_line(schema, capsys, argv, says):
    pytest.importorskip("highspy")
    assert main(["optimal", str(schema), *argv]) == 2
    assert says in one_error(capsys)


# -------------------------------------------------------------------------- select, ingest, surrogates, run
def test_select_refuses_links_districts_and_bad_numbers(tmp_path, victim, capsys):
    metadata = tmp_path / "meta.csv"
    metadata.write_text("bldg_id,in.vintage\n1,1980s\n2,1990s\n3,2000s\n")
    link = tmp_path / "ids.csv"
    link.symlink_to(victim)
    district = fake_district(tmp_path / "district")
    for argv, says in ((["-o", str(link)], "symbolic link"), (["-o", str(district / "ids.csv")], "built district"),
                       (["-o", str(tmp_path / "a.csv"), "--seed", "-1"], "--seed must be >= 0"),
                       (["-o", str(tmp_path / "a.csv"), "--max-clusters", "0"], "--max-clusters must be >= 1")):
        assert main(["select", str(metadata), "--houses", "3", *argv]) == 2
        assert says in one_error(capsys)
    assert victim.read_text() == "precious\n" and not (district / "ids.csv").exists()
    assert main(["select", str(metadata), "--houses", "3", "-o", str(tmp_path / "a.csv")]) == 0
    assert (tmp_path / "a.csv").read_text().startswith("bldg_id,cluster,k")


def test_ingest_commands_never_write_into_a_district_or_through_a_link(tmp_path, victim, capsys):
    tariff = ROOT / "raw" / "tariffs" / "austin_energy_tou_2018.toml"
    district = fake_district(tmp_path / "district")
    before = snapshot(district)
    link = tmp_path / "pricing.csv"
    link.symlink_to(victim)
    for target, says in ((district / "pricing.csv", "built district"), (link, "symbolic link")):
        assert main(["tariff", str(tariff), "--start", "2018-06-01", "--end", "2018-06-02", "-o", str(target)]) == 2
        assert says in one_error(capsys)
    assert snapshot(district) == before and victim.read_text() == "precious\n"


def test_surrogate_train_refuses_names_that_leave_the_folder_and_planted_links(tmp_path, victim, capsys):
    table = tmp_path / "house.ilv.csv"
    table.write_text("not read: the outputs are checked first\n")
    out = tmp_path / "models"
    assert main(["surrogate", "train", str(table), "-o", str(out), "--name", "../../x"]) == 2
    assert "'../../x' is not a safe name" in one_error(capsys)
    out.mkdir()
    (out / "house.metrics.json").symlink_to(victim)
    assert main(["surrogate", "train", str(table), "-o", str(out)]) == 2
    assert "house.metrics.json" in one_error(capsys) and victim.read_text() == "precious\n"
    district = fake_district(tmp_path / "district")
    assert main(["surrogate", "train", str(table), "-o", str(district / "models")]) == 2
    assert "built district" in one_error(capsys) and not (district / "models").exists()
    # evaluate's plot (default: beside the model) is never written into a district
    assert main(["surrogate", "evaluate", str(district / "Building_1.pth"), str(table)]) == 2
    assert "built district" in one_error(capsys)


def test_run_refuses_a_negative_seed(capsys):
    assert main(["run", "--seed", "-1"]) == 2
    assert "--seed must be >= 0, got -1" in one_error(capsys)


# --------------------------------------------------------------------------------------------- install
def test_install_errors_name_the_district_not_its_working_copy(schema, tmp_path):
    from pipeline.builder.install import in_district

    folder = tmp_path / "mine"
    work = tmp_path / f".mine.install-{os.getpid()}"
    work.mkdir()
    for path in schema.parent.iterdir():
        (work / path.name).write_bytes(path.read_bytes())
    spec = json.loads((work / "schema.json").read_text())
    building = next(iter(spec["buildings"]))
    csv = work / spec["buildings"][building]["energy_simulation"]
    lines = csv.read_text().splitlines()
    lines[3] = ",".join("nan" for _ in lines[3].split(","))
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(SchemaError) as raised:
        load_schema(work / "schema.json")
    assert work.name in str(raised.value)      # the real error names the copy ...
    mapped = in_district(raised.value, work, folder)
    assert isinstance(mapped, SchemaError) and work.name not in str(mapped)
    assert str(folder / csv.name) in str(mapped) and mapped.column == raised.value.column
    missing = in_district(FileNotFoundError(2, "No such file or directory", str(work / "report" / "x.png")),
                          work, folder)
    assert isinstance(missing, FileNotFoundError) and missing.filename == str(folder / "report" / "x.png")


@pytest.mark.slow  # one build with surrogates and one tiny training: about a minute on 2 cores
def test_a_failed_install_names_the_district_file(tmp_path, capsys):
    from pipeline.builder.driver import build_district_local
    from pipeline.config import read_build_config
    from tests.pipeline.builder.test_manifest import district_config, tiny_model

    path = district_config(tmp_path, source="csv")
    config = read_build_config(path).model_copy(update={"cache_dir": tmp_path / "cache"})
    district = build_district_local(config, tmp_path / "out")
    model = tiny_model(district / "surrogates" / "Building_1.ilv.parquet", tmp_path / "model")
    csv = district / "Building_2.csv"
    lines = csv.read_text().splitlines()
    lines[5] = ",".join("nan" for _ in lines[5].split(","))   # verify fails; --force installs, revalidation fails
    csv.write_text("\n".join(lines) + "\n")
    before = snapshot(district)
    assert main(["surrogate", "install", str(district), "Building_1", str(model), "--force"]) == 2
    overrides, line = capsys.readouterr().err.strip().splitlines()
    assert "--force overrides: Building_2.csv" in overrides
    assert str(csv) in line and "row 4" in line and ".install-" not in line, line    # not the deleted copy
    assert snapshot(district) == before and sorted(p.name for p in district.parent.iterdir()) == [district.name]
