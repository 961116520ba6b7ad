"""Export of a trained surrogate: ``<name>.pth`` (CityLearn checkpoint format), the schema ``dynamics`` block
and reading both back.

The .pth is ``torch.save({"model_state_dict": state_dict, "epoch": int, "train_loss": float,
"val_loss": float})`` with float32 tensors under the upstream keys ``l_lstm.weight_ih_l0`` ...
``l_linear.bias``: upstream CityLearn (``checkpoint["model_state_dict"]``), ``torch.load(weights_only=True)``
and citylearn_env's restricted reader all load it. Everything else (input names, min-max bounds, sizes,
lookback) lives in the dynamics block, in schema v2.2 layout::

    {"type": "citylearn.dynamics.LSTMDynamics",
     "attributes": {"input_size": 14, "hidden_size": 16, "num_layers": 2, "lookback": 12,
                    "filename": "Building_1.pth", "input_observation_names": [...],
                    "input_normalization_minimum": [...], "input_normalization_maximum": [...]}}
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import torch

from citylearn_env.dataset import DynamicsBlock
from citylearn_env.errors import InputError, SchemaError
from citylearn_env.outputs import check_output_name
from surrogates.config import TrainConfig
from surrogates.evaluate import evaluate_segments, plot_predictions, write_json
from surrogates.ilv import table_digest, validate_ilv
from surrogates.model import LSTMModel, Normalization
from surrogates.train import Trained, train_surrogate


def dynamics_block(trained: Trained, filename: str) -> DynamicsBlock:
    """The :class:`~citylearn_env.dataset.DynamicsBlock` of a trained surrogate; ``.to_schema()`` gives the
    schema ``dynamics`` object (plain JSON types)."""
    model = trained.model
    return DynamicsBlock(
        filename=filename, input_observation_names=tuple(trained.inputs),
        input_normalization_minimum=tuple(float(v) for v in trained.normalization.minimum),
        input_normalization_maximum=tuple(float(v) for v in trained.normalization.maximum),
        hidden_size=int(model.hidden_size), num_layers=int(model.num_layers), lookback=int(trained.config.lookback))


def save_checkpoint(trained: Trained, path: str | os.PathLike) -> Path:
    """Write the CityLearn-format checkpoint atomically."""
    path = Path(path)
    best = trained.history[trained.best_epoch] if trained.history else {}
    scale = float(trained.normalization.maximum[-1] - trained.normalization.minimum[-1])
    state = {k: v.detach().to(torch.float32).clone() for k, v in trained.model.state_dict().items()}
    checkpoint = {"model_state_dict": state, "epoch": int(trained.best_epoch),
                  "train_loss": float((best.get("train_rmse_c", 0.0) / scale) ** 2),
                  "val_loss": float((best.get("val_closed_loop_rmse_c", 0.0) / scale) ** 2)}
    private = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))  # 0700: no link planted in it
    try:
        temp = private / f".{path.name}.tmp"  # the name torch records in the archive, as before
        torch.save(checkpoint, temp)
        check_output_name(path.parent, path.name)  # a link at the name: refused (os.replace would replace it)
        os.replace(temp, path)
    finally:
        shutil.rmtree(private, ignore_errors=True)
    return path


def export_surrogate(trained: Trained, out_dir: str | os.PathLike, name: str) -> dict[str, Path]:
    """Write ``<name>.pth`` and ``<name>.dynamics.json`` into ``out_dir``; returns their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    pth = save_checkpoint(trained, out_dir / f"{name}.pth")
    block = write_json(dynamics_block(trained, pth.name).to_schema(), out_dir / f"{name}.dynamics.json")
    return {"pth": pth, "dynamics": block}


def record_path(pth: str | os.PathLike, suffix: str) -> Path:
    """A model's companion file ``<stem>.<suffix>``: next to the .pth (``surrogate train``'s layout), else under
    ``surrogates/`` beside it (a built district's); the first of the two when neither exists."""
    pth = Path(pth)
    places = [pth.with_name(f"{pth.stem}.{suffix}"), pth.parent / "surrogates" / f"{pth.stem}.{suffix}"]
    return next((place for place in places if place.is_file()), places[0])


def load_surrogate(pth: str | os.PathLike, dynamics: dict | str | os.PathLike | None = None):
    """Load an exported model: ``(model, normalization, input names, lookback)``.

    ``dynamics`` is the block (dict) or its JSON file; default ``<pth stem>.dynamics.json`` next to the .pth
    (``surrogate train``'s layout), else in ``surrogates/`` beside it (a built district's).
    """
    pth = Path(pth)
    if not pth.is_file():
        raise InputError("model file not found", file=pth)
    if not isinstance(dynamics, dict):
        block_path = Path(dynamics) if dynamics is not None else record_path(pth, "dynamics.json")
        if not block_path.is_file():
            raise InputError("dynamics block not found (written next to the .pth by 'surrogate train', or under "
                             "surrogates/ in a built district)", file=block_path)
        try:
            dynamics = json.loads(block_path.read_text())
        except json.JSONDecodeError as error:
            raise InputError(f"not valid JSON: {error}", file=block_path) from None
    try:
        block = DynamicsBlock.from_schema(dynamics)
    except SchemaError as error:
        raise InputError(f"bad dynamics block: {error}", file=pth, column=error.column) from None
    try:
        checkpoint = torch.load(pth, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises many types for a corrupt archive
        raise InputError(f"cannot read the model: {error}", file=pth) from None
    state = checkpoint.get("model_state_dict", checkpoint)
    model = LSTMModel(block.input_size, block.hidden_size, block.num_layers)
    try:
        model.load_state_dict(state)
    except RuntimeError as error:
        raise InputError(f"weights do not match the dynamics block: {error}", file=pth) from None
    model.eval()
    norm = Normalization(np.asarray(block.input_normalization_minimum, dtype=float),
                         np.asarray(block.input_normalization_maximum, dtype=float))
    return model, norm, list(block.input_observation_names), block.lookback


def train_and_export(table, out_dir: str | os.PathLike, name: str, config: TrainConfig | None = None,
                     source: object = "<ILV table>", progress=None) -> dict:
    """Train on an ILV table, evaluate on its held-out test segments, and write ``<name>.pth``,
    ``<name>.dynamics.json``, ``<name>.metrics.json`` and ``<name>.png`` into ``out_dir``; ``config`` None:
    the build's recipe (:func:`surrogates.config.recipe`), as everywhere.

    Returns the metrics dict (also in the JSON): ``source`` (the table's name), ``table_sha256`` (its content,
    :func:`surrogates.ilv.table_digest`: what ``surrogate install`` matches against the house's table), the
    held-out ``test`` metrics and the ``training`` summary. Bad input fails before any training or writing.
    """
    trained = train_surrogate(table, config, source=source, progress=progress)  # None: the build's recipe
    clean = validate_ilv(table, source=source)
    metrics, hours = evaluate_segments(trained.model, trained.normalization, trained.inputs,
                                       trained.config.lookback, clean, trained.splits["test"])
    paths = export_surrogate(trained, out_dir, name)
    report = {"building": name, "source": str(source), "table_sha256": table_digest(clean),
              "test": metrics, "training": trained.summary(),
              "files": {k: p.name for k, p in paths.items()}}
    write_json(report, Path(out_dir) / f"{name}.metrics.json")
    plot_predictions(hours, Path(out_dir) / f"{name}.png",
                     title=f"{name}: held-out run, closed-loop monthly RMSE median "
                           f"{metrics['monthly_rmse_c']['median']:.2f} °C")
    return report
