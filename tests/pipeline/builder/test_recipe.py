"""One training recipe: the build's ``[surrogate]`` settings and ``districtgen surrogate train`` both resolve to
:data:`surrogates.config.BUILD_RECIPE`, read when they resolve (a changed recipe changes both); the sizing keys
default to :class:`citylearn_env.sizing.SizingRules`."""

from __future__ import annotations

import argparse
from dataclasses import replace
from datetime import date
from pathlib import Path

import pytest

import surrogates.config as trainer
from citylearn_env.sizing import SizingRules
from pipeline.builder.surrogates import train_config
from pipeline.config import RECIPE_KEYS, Sizing, Surrogate, parse_build_config, read_build_config
from pipeline.errors import InputError
from surrogates.cli import register, train_settings
from surrogates.config import FIXED_SETTINGS, TrainConfig

ROOT = Path(__file__).resolve().parents[3]
DISTRICT = ROOT / "raw" / "district.toml"  # a June district whose [surrogate] names source and seed only


def cli_settings(*options: str) -> TrainConfig:
    """What ``districtgen surrogate train TABLE -o OUT [options]`` would train (nothing is trained)."""
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers(dest="command"))
    return train_settings(parser.parse_args(["surrogate", "train", "table.csv", "-o", "out", *options]))


def test_the_build_and_the_command_train_the_recipe():
    config = read_build_config(DISTRICT)
    assert train_config(config) == replace(trainer.BUILD_RECIPE, months=(6,), progress=False, threads=1)
    assert cli_settings() == trainer.BUILD_RECIPE
    assert cli_settings("--quiet", "--months", "12,1") == replace(trainer.BUILD_RECIPE, progress=False,
                                                                  months=(12, 1))


def test_the_command_trains_what_a_full_year_build_trains():
    """``districtgen surrogate train``'s default settings are a full-year build's (every month), down to the
    generic start and its rate; they differ only in the progress bar and the thread count the build pins."""
    config = read_build_config(DISTRICT)
    whole = config.model_copy(update={"period": config.period.model_copy(
        update={"start": date(2018, 1, 1), "end": date(2018, 12, 31)})})
    build, command = train_config(whole), cli_settings()
    assert build == replace(command, progress=False, threads=1)
    assert (command.start, command.generic_learning_rate, command.months) == ("generic", 0.01, ())
    assert command == trainer.recipe()


def test_a_changed_recipe_changes_what_both_resolve_to(monkeypatch):
    # every [surrogate] training key away from the shipped recipe, and a setting that key does not name
    changed = replace(trainer.BUILD_RECIPE, hidden_size=24, num_layers=1, epochs=5, pretrain_steps=70,
                      long_chunk_epochs=2, max_seconds=90.0, seed=3, precision="float32", start="random",
                      pretrain_noise=0.1)
    assert all(getattr(changed, key) != getattr(trainer.BUILD_RECIPE, key) for key in RECIPE_KEYS)
    monkeypatch.setattr(trainer, "BUILD_RECIPE", changed)

    section = Surrogate()
    assert {key: getattr(section, key) for key in RECIPE_KEYS} == {key: getattr(changed, key) for key in RECIPE_KEYS}
    # the file names seed = 0: a key given wins over the recipe, in the file and on the command line
    assert train_config(read_build_config(DISTRICT)) == replace(changed, seed=0, months=(6,), progress=False,
                                                                threads=1)
    assert cli_settings() == changed
    assert cli_settings("--hidden", "8", "--start", "generic").hidden_size == 8
    assert cli_settings("--start", "generic").start == "generic"


def test_the_section_refuses_what_the_trainer_does_not_know():
    base = {"name": "d", "period": {"start": "2018-06-01", "end": "2018-06-30"},
            "inputs": {"weather": "w.epw", "tariff": "t.csv", "fuel_mix": "f.csv", "eulp": "e", "buildings": [1]}}
    with pytest.raises(InputError, match=r"'surrogate.start'.*'random' or 'generic'"):
        parse_build_config({**base, "surrogate": {"start": "warm"}})
    with pytest.raises(InputError, match=r"'surrogate.precision'.*'auto', 'float32' or 'bfloat16'"):
        parse_build_config({**base, "surrogate": {"precision": "half"}})
    with pytest.raises(InputError, match=r"'surrogate.lookback'.*Extra inputs"):  # no longer a setting
        parse_build_config({**base, "surrogate": {"lookback": 6}})


def test_the_record_keeps_its_keys_in_their_order():
    """``training.config`` of a model's metrics lists the settings in the order of the fields, with the fixed
    lookback 1 after ``num_layers`` and ensemble 1 after ``validation_hours``, as every record before."""
    record = trainer.BUILD_RECIPE.record()
    keys = list(record)
    assert keys[keys.index("num_layers") + 1] == "lookback" and record["lookback"] == 1
    assert keys[keys.index("validation_hours") + 1] == "ensemble" and record["ensemble"] == 1
    assert [k for k in keys if k not in ("lookback", "ensemble")] == list(TrainConfig.__dataclass_fields__)
    assert {fixed for fixed, _, _ in FIXED_SETTINGS} == {"lookback", "ensemble"}
    assert trainer.BUILD_RECIPE.lookback == 1
    with pytest.raises(TypeError):
        TrainConfig(lookback=6)  # type: ignore[call-arg]


def test_sizing_keys_default_to_the_sizing_rules():
    assert Sizing().rules() == SizingRules()
