"""The numeric-mode probe: what it reads off the CPU, how it decides, and that with no native bfloat16 every
default path (paper SAC, surrogate trainer, the build's training settings) runs float32."""

from __future__ import annotations

import json
import time
import warnings
from dataclasses import replace
from pathlib import Path

import pytest
import torch

from citylearn_env.errors import InputError
from surrogates import precision
from surrogates.precision import Probe, capability, choose


@pytest.fixture
def fresh_choices(monkeypatch, tmp_path):
    """No choice cached from earlier tests in this process (and none left behind), no machine record."""
    monkeypatch.setattr(precision, "_CHOICES", {})
    monkeypatch.setenv("DISTRICTGEN_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture
def no_native_bf16(monkeypatch, fresh_choices):
    """The probe told this CPU has no native bfloat16 (whatever it really has)."""
    real = capability()
    monkeypatch.setattr(precision, "capability", lambda: replace(real, native_bf16=False))


@pytest.fixture
def native_bf16(monkeypatch, fresh_choices):
    real = capability()
    monkeypatch.setattr(precision, "capability", lambda: replace(real, native_bf16=True))


def counting_probe(name: str, seconds: dict[torch.dtype, float]) -> tuple[Probe, list[torch.dtype]]:
    """A workload that takes ``seconds[dtype]`` per run (sleeping), and the list of dtypes it ran in."""
    calls: list[torch.dtype] = []

    def run(dtype: torch.dtype) -> None:
        calls.append(dtype)
        time.sleep(seconds[dtype])

    return Probe(name, run), calls


def test_capability_reads_this_cpu():
    found = capability()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        text = cpuinfo.read_text()
        names = [line.split(":", 1)[1].strip() for line in text.splitlines()
                 if line.split(":")[0].strip().lower() in ("model name", "cpu model", "hardware")]
        if names:
            assert found.cpu == names[0]
        flags = set()
        for line in text.splitlines():
            if line.split(":")[0].strip().lower() in ("flags", "features"):
                flags.update(line.split(":", 1)[1].split())
        assert set(found.isa) == flags & set(precision.RELEVANT_ISA)
    assert found.native_bf16 == bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    assert found.cpu in found.describe() and ("native" if found.native_bf16 else "emulated") in found.describe()


def test_float32_asked_runs_float32_without_measuring(fresh_choices):
    probe, calls = counting_probe("float32 asked", {torch.float32: 0.0, torch.bfloat16: 0.0})
    choice = choose("float32", probe)
    assert (choice.precision, choice.dtype, calls) == ("float32", torch.float32, [])


def test_auto_without_native_bf16_is_float32_without_measuring(no_native_bf16):
    probe, calls = counting_probe("auto, emulated", {torch.float32: 0.0, torch.bfloat16: 0.0})
    choice = choose("auto", probe)
    assert choice.precision == "float32" and not choice.bf16 and calls == []
    assert "no native bfloat16" in choice.reason and choice.bf16_speedup is None


def test_auto_with_native_bf16_follows_the_measurement(native_bf16):
    faster, _ = counting_probe("bf16 faster", {torch.float32: 0.02, torch.bfloat16: 0.005})
    slower, _ = counting_probe("bf16 slower", {torch.float32: 0.005, torch.bfloat16: 0.006})
    picked, refused = choose("auto", faster), choose("auto", slower)
    assert picked.precision == "bfloat16" and picked.bf16_speedup == pytest.approx(4.0, rel=0.5)
    assert refused.precision == "float32" and refused.bf16_speedup < precision.MIN_SPEEDUP
    assert "measured" in refused.reason


def test_auto_is_measured_once_per_machine_and_reused(native_bf16, monkeypatch):
    """A later process (a fresh per-process cache) reuses the machine's recorded decision even where a new
    measurement (a busy CPU) would have decided otherwise: two builds of one configuration train in one mode."""
    timings = {torch.float32: 0.02, torch.bfloat16: 0.005}
    probe, calls = counting_probe("recorded workload", timings)
    first = choose("auto", probe)
    assert first.precision == "bfloat16" and precision.record_path().is_file()
    measured = len(calls)
    monkeypatch.setattr(precision, "_CHOICES", {})  # another process
    timings[torch.bfloat16] = 0.05  # bfloat16 would now measure slower
    again = choose("auto", probe)
    assert again.precision == "bfloat16" and len(calls) == measured  # not measured again
    assert "recorded for this machine" in again.reason


def test_a_malformed_machine_record_is_measured_again(native_bf16, monkeypatch):
    precision.record_path().parent.mkdir(parents=True)
    precision.record_path().write_text("{not json")
    probe, calls = counting_probe("after a bad record", {torch.float32: 0.005, torch.bfloat16: 0.006})
    assert choose("auto", probe).precision == "float32" and calls
    assert precision.record_key(probe) in precision.recorded_choices()


def test_bfloat16_where_emulated_warns_once_with_the_slowdown(no_native_bf16):
    probe, calls = counting_probe("emulated workload", {torch.float32: 0.002, torch.bfloat16: 0.02})
    with pytest.warns(RuntimeWarning, match=r"emulated workload.*emulated.*x slower") as caught:
        choice = choose("bfloat16", probe)
    # the warning names the slowdown it measured (sleep overshoot on a busy machine moves it below 10x)
    assert choice.precision == "bfloat16" and choice.bf16_speedup < 0.5 and calls
    assert f"measured {1 / choice.bf16_speedup:.1f}x slower" in str(caught[0].message)
    ran = len(calls)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert choose("bfloat16", probe) is choice  # cached: no second measurement, no second warning
    assert len(calls) == ran


def inverse_probe() -> Probe:
    """A real workload torch runs in float32 only: its bfloat16 matrix inverse raises RuntimeError, as a
    library without a bfloat16 kernel for a workload does."""
    return Probe("an inverse", lambda dtype: torch.linalg.inv(torch.eye(4, dtype=dtype) * 2.0))


def test_auto_where_bfloat16_cannot_run_is_float32_and_says_why(native_bf16):
    choice = choose("auto", inverse_probe())
    assert choice.precision == "float32" and choice.requested == "auto"
    assert "bfloat16 cannot run an inverse here" in choice.reason and "BFloat16" in choice.reason


def test_bfloat16_asked_where_it_cannot_run_is_one_clear_error(fresh_choices):
    with pytest.raises(InputError, match=r"precision bfloat16: an inverse cannot run in bfloat16 here") as caught:
        choose("bfloat16", inverse_probe())
    assert "\n" not in str(caught.value) and caught.value.__cause__ is None


def test_unknown_precision_is_one_clear_error():
    with pytest.raises(InputError, match="unknown precision 'half'.*auto, float32, bfloat16"):
        precision.check_precision("half")
    from surrogates.config import TrainConfig

    with pytest.raises(InputError, match="precision"):
        TrainConfig(precision="fp16")


def test_every_default_path_runs_float32_without_native_bf16(no_native_bf16, tmp_path):
    """Forced "no bfloat16": the paper's default SAC back end (and the torch one), the surrogate trainer's
    default and the build's [surrogate] defaults all resolve to float32, and the paper records it."""
    from citylearn_env.example import write_example_district
    from pipeline.builder.surrogates import train_config
    from pipeline.config import read_build_config
    from pipeline.paper.benchmarks import RunOptions
    from pipeline.paper.sac.train import sac_precision
    from pipeline.paper.tasks import run_paper
    from surrogates.config import TrainConfig
    from surrogates.train import update_precision

    assert sac_precision(RunOptions().precision, 9, 2).precision == "float32"
    assert update_precision(TrainConfig()).precision == "float32"
    from surrogates.ilv import read_ilv
    from surrogates.train import train_surrogate

    table = read_ilv(Path(__file__).parents[1] / "fixtures" / "synthetic_district" / "ilv" / "900001.parquet")
    tiny = replace(TrainConfig(), hidden_size=4, epochs=1, long_chunk_epochs=0, pretrain_steps=3, progress=False)
    summary = train_surrogate(table, tiny).summary()
    assert (summary["precision"], summary["precision_requested"], summary["config"]["precision"]) == (
        "float32", "auto", "float32")
    config = read_build_config(Path(__file__).parents[2] / "raw" / "district.toml")  # [surrogate] defaults
    assert config.surrogate.precision == "auto" and update_precision(train_config(config)).precision == "float32"
    schema = write_example_district(tmp_path / "district", n_buildings=2, hours=360, seed=3)
    rows = run_paper(schema, tmp_path / "paper", only=["rlc-b1-c-bess_pv", "rbc-b1-c-bess_pv"], sweep=(),
                     options=RunOptions(sac_episodes=1), log=lambda *_: None)["results"]
    by_id = {r["id"]: r for r in rows}
    assert by_id["rlc-b1-c-bess_pv"]["precision"] == "float32" and by_id["rbc-b1-c-bess_pv"]["precision"] == "-"
    assert "SAC: fast in float32 (--precision auto) on " in (tmp_path / "paper" / "results.md").read_text()
    runs = (tmp_path / "paper" / "runs.csv").read_text().splitlines()
    assert "precision" in runs[0].split(",")
    stored = json.loads((tmp_path / "paper" / "tasks" / "rlc-b1-c-bess_pv-m3-s0.json").read_text())
    assert stored["result"]["precision"] == "float32"
