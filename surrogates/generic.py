"""A generic starting point for a house's LSTM: one model trained once on many houses' ILV tables.

A house's surrogate starts its warm start from these weights instead of random ones
(:attr:`surrogates.config.TrainConfig.start` ``"generic"``): the generic model already maps loads, weather and
time to a normalised indoor temperature, so the house's 5,000 updates refine rather than discover. Each
house's table is scaled to its own [0, 1] per input column before the tables are pooled, which is the
normalisation a house's own training applies (:class:`surrogates.model.Normalization`), so the weights mean
the same thing in both. Measured (docs/surrogates.md, section 11): the six default houses' full-year judge
medians 0.03-0.06 degC lower at the same CPU.

The weights live in ``surrogates/data/generic_lstm.json`` (plain JSON: input names, sizes, the rows and recipe
they came from, and the tensors as nested lists); ``benchmarks/generic_start.py`` regenerates the file.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from surrogates.config import TARGET

#: the shipped generic model
GENERIC_FILE = Path(__file__).parent / "data" / "generic_lstm.json"

#: the columns a pooled table keeps unscaled: calendar fields (encoded by the model) and the run's bookkeeping
UNSCALED = ("timestamp", "month", "hour", "day_type", "reference", "daylight_savings_status")


def scale_to_unit(table: pd.DataFrame, inputs: Sequence[str]) -> pd.DataFrame:
    """A copy of ``table`` with each of ``inputs`` that is a plain numeric column (not a calendar field)
    scaled to [0, 1] by its own minimum and maximum (a constant column becomes 0)."""
    out = table.copy()
    for name in inputs:
        if name in out.columns and name not in UNSCALED:
            values = out[name].to_numpy(dtype=float)
            low, high = float(np.min(values)), float(np.max(values))
            out[name] = (values - low) / (high - low) if high > low else 0.0
    return out


def pool_tables(tables: Iterable[pd.DataFrame], inputs: Sequence[str]) -> pd.DataFrame:
    """One ILV table of many houses: each scaled to [0, 1] (:func:`scale_to_unit`) without its ideal replay
    (reference 0), its runs renumbered ``100 k + reference`` so that no two houses share a run; only the
    columns every table has are kept (an optional column some lack, e.g. the set point, is left out)."""
    frames = []
    for k, table in enumerate(tables, 1):
        part = table[table["reference"] != 0]
        frames.append(scale_to_unit(part, inputs).assign(reference=part["reference"] + 100 * k))
    common = set.intersection(*(set(f.columns) for f in frames))
    return pd.concat([f[[c for c in frames[0].columns if c in common]] for f in frames], ignore_index=True)


def write_generic(path: Path, model: torch.nn.Module, inputs: Sequence[str], about: dict) -> Path:
    """Write ``model``'s weights with its ``inputs`` and ``about`` (rows, recipe, ...) as JSON."""
    state = {k: v.detach().cpu().tolist() for k, v in model.state_dict().items()}
    record = {"inputs": list(inputs), "hidden_size": model.hidden_size, "num_layers": model.num_layers,
              "about": about, "state": state}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, separators=(",", ":")) + "\n")
    return path


def read_generic(path: Path = GENERIC_FILE) -> dict | None:
    """The generic model's record (:func:`write_generic`), or None when the file is absent."""
    return json.loads(path.read_text()) if path.is_file() else None


def generic_state(inputs: Sequence[str], hidden_size: int, num_layers: int,
                  path: Path = GENERIC_FILE) -> dict[str, torch.Tensor] | None:
    """The generic weights for a model of ``inputs`` (the target last), ``hidden_size`` and ``num_layers``:
    the first layer's input weights rearranged to ``inputs``' order, an input the generic model lacks (e.g.
    the optional set point) with zero weights, so it starts without effect; None when there is no generic
    model of that size, or it lacks the target."""
    record = read_generic(path)
    if record is None or record["hidden_size"] != hidden_size or record["num_layers"] != num_layers:
        return None
    known = record["inputs"]
    if TARGET not in known or inputs[-1] != TARGET:
        return None
    state = {k: torch.tensor(v, dtype=torch.float32) for k, v in record["state"].items()}
    first = state["l_lstm.weight_ih_l0"]
    columns = [first[:, known.index(n)] if n in known else torch.zeros(first.shape[0]) for n in inputs]
    state["l_lstm.weight_ih_l0"] = torch.stack(columns, dim=1)
    return state
