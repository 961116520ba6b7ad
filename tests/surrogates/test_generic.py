"""The generic starting model (surrogates/generic.py): pooling, the input mapping, the shipped file, and that a
training started from it begins far closer to an unseen house than a random start."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from citylearn_env.errors import InputError
from surrogates.config import BUILD_RECIPE, DEFAULT_INPUTS, TARGET, TrainConfig
from surrogates.generic import (
    GENERIC_FILE,
    generic_state,
    pool_tables,
    read_generic,
    scale_to_unit,
    write_generic,
)
from surrogates.ilv import read_ilv
from surrogates.model import seeded_model
from surrogates.train import train_surrogate

ROOT = Path(__file__).resolve().parents[2]
FIXTURE_TABLE = ROOT / "tests" / "fixtures" / "synthetic_district" / "ilv" / "900001.parquet"


def test_scale_to_unit_and_pool_by_hand():
    a = pd.DataFrame({"reference": [0, 2, 2, 3], "month": [6, 6, 7, 7], "outdoor_dry_bulb_temperature": [9.0, 10.0, 20.0, 15.0],
                      "occupant_count": [2.0] * 4, "indoor_dry_bulb_temperature_set_point": [21.0] * 4})
    b = a.drop(columns=["indoor_dry_bulb_temperature_set_point"]).assign(outdoor_dry_bulb_temperature=[0.0, 0.0, 4.0, 2.0])
    scaled = scale_to_unit(a[a["reference"] != 0], ["outdoor_dry_bulb_temperature", "occupant_count", "month"])
    assert scaled["outdoor_dry_bulb_temperature"].tolist() == [0.0, 1.0, 0.5]
    assert scaled["occupant_count"].tolist() == [0.0] * 3 and scaled["month"].tolist() == [6, 7, 7]  # constant; calendar
    pooled = pool_tables([a, b], ["outdoor_dry_bulb_temperature", "occupant_count"])
    assert pooled["reference"].tolist() == [102, 102, 103, 202, 202, 203]            # no ideal replay, runs apart
    assert pooled["outdoor_dry_bulb_temperature"].tolist() == [0.0, 1.0, 0.5, 0.0, 1.0, 0.5]
    assert "indoor_dry_bulb_temperature_set_point" not in pooled                    # not every table has it


def test_the_input_mapping_follows_names_and_zeroes_unknown_inputs(tmp_path):
    model = seeded_model(3, 4, 1, seed=3)
    path = write_generic(tmp_path / "g.json", model, ["a", "b", TARGET], {"rows": [1]})
    first = model.state_dict()["l_lstm.weight_ih_l0"]
    state = generic_state(["b", "new", "a", TARGET], 4, 1, path)
    mapped = state["l_lstm.weight_ih_l0"]
    assert mapped.shape == (16, 4)
    assert torch.equal(mapped[:, 0], first[:, 1]) and torch.equal(mapped[:, 2], first[:, 0])
    assert torch.equal(mapped[:, 3], first[:, 2]) and not mapped[:, 1].any()        # an unknown input: no effect
    assert torch.equal(state["l_linear.weight"], model.state_dict()["l_linear.weight"])
    assert generic_state(["a", "b", TARGET], 8, 1, path) is None                     # another size: no generic start
    assert generic_state(["a", TARGET, "b"], 4, 1, path) is None                     # the target must come last
    assert generic_state(["a", TARGET], 4, 1, tmp_path / "absent.json") is None


def test_the_shipped_generic_model_fits_the_build_size():
    record = read_generic(GENERIC_FILE)
    assert record is not None, "surrogates/data/generic_lstm.json is missing (benchmarks/generic_start.py)"
    assert (record["hidden_size"], record["num_layers"]) == (BUILD_RECIPE.hidden_size, BUILD_RECIPE.num_layers)
    assert record["inputs"][-1] == TARGET and len(record["about"]["rows"]) >= 8
    state = generic_state(list(DEFAULT_INPUTS), BUILD_RECIPE.hidden_size, BUILD_RECIPE.num_layers)
    model = seeded_model(len(DEFAULT_INPUTS), BUILD_RECIPE.hidden_size, BUILD_RECIPE.num_layers, seed=0)
    model.load_state_dict(state)                                                    # every tensor's shape fits
    at = DEFAULT_INPUTS.index("indoor_dry_bulb_temperature_set_point")
    assert not model.l_lstm.weight_ih_l0[:, at].any()                               # the generic model lacks it
    assert all(np.isfinite(np.asarray(v, dtype=float)).all() for v in record["state"].values())


def test_a_generic_start_begins_closer_to_an_unseen_house_than_a_random_one():
    """No warm start and one closed-loop epoch at a vanishing rate: the kept model is (nearly) where training
    began, so its validation error measures the start. The synthetic fixture house is none of the stock rows
    the generic model was trained on."""
    table = read_ilv(FIXTURE_TABLE)
    quiet = replace(BUILD_RECIPE, pretrain_steps=0, epochs=1, long_chunk_epochs=0, finetune_learning_rate=1e-9,
                    progress=False, precision="float32")
    errors = {start: train_surrogate(table, replace(quiet, start=start)).history[0]["val_closed_loop_rmse_c"]
              for start in ("random", "generic")}
    assert errors["generic"] < 0.5 * errors["random"], errors


def test_an_unknown_start_is_one_clear_error():
    with pytest.raises(InputError, match="start"):
        TrainConfig(start="pretrained")


def test_surrogate_train_takes_the_start(tmp_path):
    import json

    from pipeline.cli import main

    code = main(["surrogate", "train", str(FIXTURE_TABLE), "-o", str(tmp_path), "--name", "Building_1",
                 "--start", "generic", "--hidden", "16", "--layers", "2", "--epochs", "1", "--pretrain-steps", "0",
                 "--precision", "float32", "--quiet"])
    assert code == 0
    metrics = json.loads((tmp_path / "Building_1.metrics.json").read_text())
    assert metrics["training"]["config"]["start"] == "generic"
