"""Issue 16 hardening of the pipeline and the CLI: safe names, a build that only touches what it made, one
line with exit status 2 for every bad input, no code from caches, no server or file left behind."""

from __future__ import annotations

import json
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import time
import zipfile
from pathlib import Path

import pytest

from citylearn_env import SchemaError
from citylearn_env.dynamics import read_pth_state_dict
from citylearn_env.example import write_example_district
from pipeline.builder.cache import FileCache, sha256_bytes
from pipeline.builder.staging import staging
from pipeline.cli import main
from pipeline.config import parse_build_config
from pipeline.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
VALID = {"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
         "inputs": {"eulp": "e", "buildings": [1], "weather": "w", "tariff": "t", "fuel_mix": "f"}}


def _config(**update):
    return parse_build_config({**VALID, **update}, file="district.toml")


def _cli(argv: list[str], capsys) -> tuple[int, str]:
    status = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return status, err[0]


# ------------------------------------------------------------------------------ finding 1: the cache
def _evil_pth(marker: Path) -> bytes:
    """A zip 'checkpoint' whose pickle would run ``touch marker`` if anything unpickled it."""

    class Payload:
        def __reduce__(self):
            return os.system, (f"touch {marker}",)

    import io

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("Building_1/data.pkl", pickle.dumps(Payload(), protocol=2))
    return buffer.getvalue()


def test_poisoned_cache_entry_is_never_executed(tmp_path):
    """An attacker who rewrites both a cached .pth and its entry.json (so the sha256 matches) gets bytes
    returned as bytes; the weights reader refuses the pickle's global before running anything."""
    marker = tmp_path / "ran"
    cache = FileCache(tmp_path / "cache" / "surrogates")
    key = "a" * 64
    folder = cache.put(key, {"Building_1.pth": b"honest weights"})
    evil = _evil_pth(marker)
    (folder / "Building_1.pth").write_bytes(evil)
    assert cache.get(key) is None                                     # tampered alone: detected, a miss
    listing = json.loads((folder / "entry.json").read_text())
    listing["files"]["Building_1.pth"] = {"sha256": sha256_bytes(evil), "bytes": len(evil)}
    (folder / "entry.json").write_text(json.dumps(listing))
    files = cache.get(key)                                            # entry.json rewritten too: data only
    assert files == {"Building_1.pth": evil} and not marker.exists()
    (tmp_path / "Building_1.pth").write_bytes(files["Building_1.pth"])
    with pytest.raises(SchemaError, match=r"Building_1.pth: refusing to load: global 'posix.system'"):
        read_pth_state_dict(tmp_path / "Building_1.pth")
    assert not marker.exists()


def test_the_cache_and_the_flows_never_unpickle():
    """Source check: the cache and the flow modules import no pickle/cloudpickle/torch.load."""
    for module in ("pipeline/builder/cache.py", "pipeline/flows.py"):
        text = (ROOT / module).read_text()
        code = [line for line in text.splitlines() if not line.lstrip().startswith(("#", '"', "'"))]
        for word in ("import pickle", "cloudpickle", "torch.load", "persist_result=True"):
            assert not any(word in line for line in code), (module, word)


# ------------------------------------------------------------------------------ finding 2: names, staging
@pytest.mark.parametrize("name", [".", "..", ".hidden", "a/b", "../up", "", "x" * 65, "a\nb", "/abs"])
def test_unsafe_district_names_are_refused(name):
    with pytest.raises(InputError) as error:
        _config(name=name)
    assert "district.toml, column/key 'name'" in str(error.value) and "\n" not in str(error.value)


def test_staging_refuses_an_unsafe_name_even_without_validation(tmp_path):
    config = _config().model_copy(update={"name": "."})     # model_copy does not validate
    with pytest.raises(InputError, match="'name': not a safe district name"):
        staging(config, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_folder_that_is_not_a_build_is_never_replaced(tmp_path):
    user = tmp_path / "x"
    user.mkdir()
    (user / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match=r"x, column/key 'name': exists and is not a districtgen build"):
        with staging(_config(), tmp_path):
            pass
    assert (user / "thesis.tex").read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"]


def test_a_build_replaces_its_own_previous_build_and_leaves_nothing_hidden(tmp_path):
    config = _config()
    for round_ in (1, 2):
        with staging(config, tmp_path) as out:
            (out / "manifest.json").write_text(json.dumps({"district": "x", "round": round_}))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"]
    assert json.loads((tmp_path / "x" / "manifest.json").read_text())["round"] == 2


def test_a_failed_build_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError):
        with staging(_config(), tmp_path):
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def _dead_pid() -> int:
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def test_staging_of_a_killed_build_is_cleaned_on_the_next_run(tmp_path):
    pid = _dead_pid()
    stale = tmp_path / f".x.building-{pid}"
    (stale / "surrogates").mkdir(parents=True)
    (tmp_path / f".x.building-{pid}.districtgen").write_text(json.dumps({"pid": pid, "district": "x"}))
    old = tmp_path / f".x.old-{pid}"                 # a killed two-rename swap's old version: put back, replaced
    old.mkdir()
    (old / "manifest.json").write_text(json.dumps({"district": "x"}))
    unmarked = tmp_path / ".x.building-1"           # not marked by a build: not ours, kept
    unmarked.mkdir()
    live = tmp_path / f".x.building-{os.getppid()}"  # marked but its process is alive: a concurrent build, kept
    live.mkdir()
    (tmp_path / f".x.building-{os.getppid()}.districtgen").write_text(json.dumps({"pid": os.getppid()}))
    with staging(_config(), tmp_path) as out:
        (out / "manifest.json").write_text(json.dumps({"district": "x"}))
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([".x.building-1", f".x.building-{os.getppid()}",
                           f".x.building-{os.getppid()}.districtgen", "x"])


# ------------------------------------------------------------------------------ finding 5: one line, exit 2
@pytest.mark.parametrize("text, says", [
    ("", "not valid JSON"), ('{"buildings": {', "not valid JSON"), ("[]", "a schema must be a JSON object"),
])
def test_run_on_a_broken_schema_is_one_line(tmp_path, capsys, text, says):
    schema = tmp_path / "schema.json"
    schema.write_text(text)
    status, line = _cli(["run", "--schema", str(schema)], capsys)
    assert status == 2 and str(schema) in line and says in line


def test_run_on_a_missing_schema_or_a_folder_is_one_line(tmp_path, capsys):
    status, line = _cli(["run", "--schema", str(tmp_path / "nope.json")], capsys)
    assert status == 2 and "nope.json: schema file not found" in line
    status, line = _cli(["run", "--schema", str(tmp_path)], capsys)
    assert status == 2 and f"{tmp_path}: cannot read the schema file" in line


def test_run_on_a_schema_with_an_inf_cell_is_one_line(tmp_path, capsys):
    schema = write_example_district(tmp_path, n_buildings=1, hours=48)
    lines = (tmp_path / "carbon_intensity.csv").read_text().splitlines()
    lines[5] = "inf"                      # lines[0] is the header: file line 6, data row 4
    (tmp_path / "carbon_intensity.csv").write_text("\n".join(lines) + "\n")
    status, line = _cli(["run", "--schema", str(schema)], capsys)
    assert status == 2 and "carbon_intensity.csv, column/key 'carbon_intensity', row 4 (file line 6)" in line


def test_build_config_errors_are_one_line(tmp_path, capsys):
    status, line = _cli(["build", str(tmp_path)], capsys)                        # a folder
    assert status == 2 and f"{tmp_path}: cannot read the configuration" in line
    config = tmp_path / "district.toml"
    config.write_text(
        'name = "x"\ntimezone = "Mars/Olympus_Mons"\n[period]\nstart = 2018-06-01\nend = 2018-06-02\n'
        '[inputs]\neulp = "e"\nbuildings = [1]\nweather = "w"\ntariff = "t"\nfuel_mix = "f"\n')
    status, line = _cli(["build", str(config)], capsys)
    assert status == 2 and "column/key 'timezone'" in line and "unknown time zone 'Mars/Olympus_Mons'" in line
    config.write_text(config.read_text().replace("Mars/Olympus_Mons", "America/Chicago")
                      + "[sizing]\ndhw_tank_fraction = inf\n")
    status, line = _cli(["build", str(config)], capsys)
    assert status == 2 and "column/key 'sizing.dhw_tank_fraction'" in line


def test_build_into_an_output_folder_that_is_a_file_or_cannot_be_made(tmp_path, capsys):
    config = tmp_path / "district.toml"
    config.write_text('name = "x"\n[period]\nstart = 2018-06-01\nend = 2018-06-02\n'
                      '[inputs]\neulp = "e"\nbuildings = [1]\nweather = "w"\ntariff = "t"\nfuel_mix = "f"\n')
    (tmp_path / "afile").write_text("")
    status, line = _cli(["build", str(config), "-o", str(tmp_path / "afile"), "--no-prefect"], capsys)
    assert status == 2 and "afile, column/key 'output_root': the output folder is a file" in line
    status, line = _cli(["build", str(config), "-o", str(tmp_path / "afile" / "sub"), "--no-prefect"], capsys)
    assert status == 2 and "column/key 'output_root'" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "district.toml"]


def test_verify_on_a_file_or_a_bad_manifest_is_one_line(tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    status, line = _cli(["verify", str(tmp_path / "afile")], capsys)
    assert status == 2 and "afile, column/key 'folder': not a folder" in line
    (tmp_path / "manifest.json").write_text("[]")
    status, line = _cli(["verify", str(tmp_path)], capsys)
    assert status == 2 and "manifest.json is not a districtgen manifest" in line


# ------------------------------------------------------------------------------ finding 7: nothing left behind
def test_run_without_a_schema_writes_nothing_in_the_current_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--policy", "zero"]) == 0
    assert "example district" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("how", [signal.SIGTERM, signal.SIGKILL])
def test_no_prefect_server_outlives_a_killed_build(tmp_path, how):
    """A process inside prefect_api() (as `districtgen build` runs) is killed: its server goes too."""
    script = textwrap.dedent("""
        import faulthandler, os, signal, sys, time
        from pathlib import Path
        from pipeline.flows import prefect_api
        faulthandler.register(signal.SIGUSR1, all_threads=True)  # the test asks where a hung build waits
        with prefect_api():
            for entry in Path("/proc").iterdir():   # the temporary server: the child running its script
                try:
                    if (entry.name.isdigit() and int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
                            == os.getpid() and b"temporary prefect api server" in (entry / "cmdline").read_bytes()):
                        print(entry.name, flush=True)
                except OSError:
                    continue
            time.sleep(600)
    """)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PREFECT_HOME": str(tmp_path / "prefect")}
    env.pop("PREFECT_API_URL", None)
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env)
    try:
        server = int(child.stdout.readline())
        os.kill(server, 0)                                   # the server runs
        child.send_signal(how)
        deadline = time.monotonic() + 90  # the server first: it is stopped before the build's interpreter exits
        while time.monotonic() < deadline and _running(server):
            time.sleep(0.2)
        if _running(server) and child.poll() is None:  # the build's stacks, on the captured stderr
            child.send_signal(signal.SIGUSR1)
            time.sleep(2)
        assert not _running(server), f"Prefect server {server} outlived its build ({how!r})"
        # then the build itself ends (its interpreter shutdown took over 60 s once on a loaded 2-core CI run)
        try:
            child.wait(timeout=180)
        except subprocess.TimeoutExpired:
            child.send_signal(signal.SIGUSR1)
            time.sleep(2)
            raise
    finally:
        if child.poll() is None:
            child.kill()


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie (exited, not yet reaped by init) is not running
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize(("update", "key"), [
    ({"seed": -5}, "'seed'"), ({"seed": 2**128}, "'seed'"), ({"surrogate": {"seed": -1}}, "'surrogate.seed'"),
    ({"sizing": {"pv_zne_fraction": 1e300}}, "'sizing.pv_zne_fraction'"),
    ({"surrogate": {"hidden_size": 10**6}}, "'surrogate.hidden_size'"),
])
def test_absurd_config_numbers_name_their_key(update, key):
    with pytest.raises(InputError) as error:
        _config(**update)
    assert f"column/key {key}" in str(error.value) and "\n" not in str(error.value)


# ------------------------------------------------------------------ issue 30, part 7: the smaller items
FIXTURE_CONFIG = ROOT / "tests" / "fixtures" / "synthetic_district" / "district.toml"


def test_a_full_disk_names_the_output_folder_and_leaves_nothing(tmp_path, capsys):
    """A real ENOSPC (a 64 KiB tmpfs as the output root): one line naming where it wrote, nothing left there."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(disk)], capture_output=True)
    if mounted.returncode != 0:
        pytest.skip("mounting a small tmpfs needs root and CAP_SYS_ADMIN (mount -t tmpfs refused here)")
    try:
        status, line = _cli(["build", str(FIXTURE_CONFIG), "-o", str(disk), "--no-prefect", "--quiet",
                             "--surrogate-source", "none"], capsys)
        assert status == 2 and "No space left on device" in line and str(disk) in line
        assert list(disk.iterdir()) == []
    finally:
        subprocess.run(["umount", str(disk)], check=True)


def test_an_unusable_cache_root_is_one_line_before_any_work(tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    status, line = _cli(["build", str(FIXTURE_CONFIG), "-o", str(tmp_path / "out"), "--no-prefect", "--quiet",
                         "--cache-dir", str(tmp_path / "afile")], capsys)
    assert status == 2 and "column/key 'cache_dir'" in line and "afile" in line and "cannot be written" in line
    assert list((tmp_path / "out").iterdir()) == []   # refused before the staging folder was made


def test_a_schema_too_big_for_memory_is_one_line_before_loading(tmp_path, capsys):
    """100,000 buildings x 8,760 steps need ~330 GiB: refused naming the sizes (the buildings are never read)."""
    schema = tmp_path / "schema.json"
    schema.write_text(json.dumps({"simulation_start_time_step": 0, "simulation_end_time_step": 8759,
                                  "buildings": {f"Building_{i}": {} for i in range(100_000)}}))
    status, line = _cli(["run", "--schema", str(schema)], capsys)
    assert status == 2 and "100000 buildings x 8760 time steps need about" in line and "GiB are available" in line
    from pipeline.commands import check_memory

    check_memory(schema, available=2**50)   # enough memory: no error
    with pytest.raises(InputError, match=r"need about 326\.5 GiB of memory \(estimate\) and 1\.0 GiB are available"):
        check_memory(schema, available=2**30)


def test_a_truncated_pth_is_one_line(tmp_path):
    """torch's own message spans two lines; the error quoting it is one."""
    torch = pytest.importorskip("torch")
    whole = tmp_path / "whole.pth"
    torch.save({"w": torch.zeros(3)}, whole)
    cut = tmp_path / "cut.pth"
    cut.write_bytes(whole.read_bytes()[:200])
    with pytest.raises(SchemaError) as caught:
        read_pth_state_dict(cut)
    assert "\n" not in str(caught.value) and "cut.pth" in str(caught.value)
