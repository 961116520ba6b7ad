"""Evaluation of a surrogate on held-out ILV runs: one-step and closed-loop RMSE, monthly RMSE and MAPE.

Each evaluated segment is rolled out from its first hour like an environment episode: ``lookback`` warm-up
hours with the simulated temperature, then the stateful sliding window of :func:`surrogates.model.rollout`
from zero state, closed-loop (the environment's mode) or one-step (simulated temperature history).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from citylearn_env.dataset import DynamicsBlock
from citylearn_env.dynamics import LSTMBank, LSTMSpec, read_pth_state_dict
from citylearn_env.errors import InputError
from citylearn_env.outputs import write_output
from citylearn_env.settings import CORRECTED
from surrogates import model as lstm
from surrogates.ilv import validate_ilv
from surrogates.model import LSTMModel, Normalization
from surrogates.train import Segment


def predict_segment(model: LSTMModel, normalization: Normalization, inputs: Sequence[str], lookback: int,
                    table: pd.DataFrame, segment: Segment, closed_loop: bool = True) -> np.ndarray:
    """Predicted indoor temperature (degC) of hours ``lookback ..`` of ``segment``."""
    raw = lstm.feature_matrix(table.iloc[segment.start:segment.stop], inputs)
    x = torch.from_numpy(normalization.apply(raw).astype(np.float32)).unsqueeze(0)
    model.eval()
    with torch.no_grad(), lstm.torch_threads(1):
        y = lstm.rollout(model, x, lookback, closed_loop=closed_loop)[0].numpy().astype(float)
    return normalization.target_to_celsius(y)


def _rmse(error: np.ndarray) -> float:
    return float(np.sqrt(np.mean(error ** 2)))


def evaluate_segments(model: LSTMModel, normalization: Normalization, inputs: Sequence[str], lookback: int,
                      table: pd.DataFrame, segments: Sequence[Segment]) -> tuple[dict, pd.DataFrame]:
    """Metrics JSON (dict) and the per-hour frame (reference, timestamp, month, simulated, closed_loop,
    one_step) of all ``segments`` of a validated, sorted ILV table.

    Monthly metrics group the hours by (reference, calendar month); MAPE is in % of the simulated degC.
    """
    missing = [n for n in inputs if n not in lstm.available_inputs(table, inputs)]
    if missing:
        raise InputError("the model needs this input but the ILV table has no such column", column=missing[0])
    frames = []
    for seg in segments:
        if seg.stop - seg.start <= lookback:
            continue
        rows = table.iloc[seg.start + lookback:seg.stop]
        frames.append(pd.DataFrame({
            "reference": rows["reference"].to_numpy(), "timestamp": rows["timestamp"].to_numpy(),
            "month": rows["month"].to_numpy(), "simulated": rows["indoor_dry_bulb_temperature"].to_numpy(),
            "closed_loop": predict_segment(model, normalization, inputs, lookback, table, seg, True),
            "one_step": predict_segment(model, normalization, inputs, lookback, table, seg, False),
        }))
    hours = pd.concat(frames, ignore_index=True)
    error_cl = (hours["closed_loop"] - hours["simulated"]).to_numpy()
    error_os = (hours["one_step"] - hours["simulated"]).to_numpy()
    monthly = []
    for (ref, month), group in hours.groupby(["reference", "month"], sort=True):
        err = (group["closed_loop"] - group["simulated"]).to_numpy()
        monthly.append({"reference": int(ref), "month": int(month), "hours": len(group),
                        "rmse_c": round(_rmse(err), 4),
                        "mape_pct": round(float(np.mean(np.abs(err) / np.abs(group["simulated"]))) * 100, 3),
                        "one_step_rmse_c": round(_rmse((group["one_step"] - group["simulated"]).to_numpy()), 4)})
    monthly_rmse = np.array([m["rmse_c"] for m in monthly])
    metrics = {
        "hours": len(hours),
        "references": sorted(int(r) for r in hours["reference"].unique()),
        "one_step_rmse_c": round(_rmse(error_os), 4),
        "closed_loop_rmse_c": round(_rmse(error_cl), 4),
        "closed_loop_mae_c": round(float(np.mean(np.abs(error_cl))), 4),
        "closed_loop_bias_c": round(float(np.mean(error_cl)), 4),
        "monthly_rmse_c": {"median": round(float(np.median(monthly_rmse)), 4),
                           "mean": round(float(np.mean(monthly_rmse)), 4),
                           "max": round(float(np.max(monthly_rmse)), 4)},
        "monthly_mape_pct": {"median": round(float(np.median([m["mape_pct"] for m in monthly])), 3),
                             "max": round(float(np.max([m["mape_pct"] for m in monthly])), 3)},
        "monthly": monthly,
    }
    return metrics, hours


def write_json(data: dict, path: str | os.PathLike) -> Path:
    """Write JSON atomically: a new file beside it renamed into place, never through a link
    (:func:`citylearn_env.outputs.write_output`)."""
    path = Path(path)
    return write_output(path.parent, path.name, json.dumps(data, indent=2) + "\n")


def plot_predictions(hours: pd.DataFrame, path: str | os.PathLike, title: str = "") -> Path:
    """PNG: simulated vs closed-loop and one-step predicted indoor temperature of the first evaluated run,
    whole period on top and its first two weeks below."""
    import matplotlib  # lazy: choosing the Agg backend at import would change the importer's backend

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    ref = hours["reference"].iloc[0]
    run = hours[hours["reference"] == ref]
    fig, axes = plt.subplots(2, 1, figsize=(11, 6.5))
    for ax, part in zip(axes, (run, run.iloc[:336]), strict=True):
        ax.plot(part["timestamp"], part["simulated"], color="black", lw=1.0, label="simulated")
        ax.plot(part["timestamp"], part["closed_loop"], color="tab:red", lw=0.9, label="LSTM closed loop")
        ax.plot(part["timestamp"], part["one_step"], color="tab:blue", lw=0.6, alpha=0.7, label="LSTM one step")
        ax.set_ylabel("indoor temperature (°C)")
    axes[0].set_title(title or f"reference run {ref}")
    axes[0].legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    try:  # a new file renamed into place, never through a link (citylearn_env.outputs)
        write_output(path.parent, path.name, lambda stream: fig.savefig(
            stream, dpi=90, format="png", metadata={"Software": None}), binary=True)  # no version tag: reproducible
    finally:
        plt.close(fig)
    return path


def bank_rollout(pth: str | os.PathLike, block: dict, table: pd.DataFrame, segments: Sequence[Segment],
                 settings=None) -> pd.DataFrame:
    """Closed-loop prediction of each segment by the environment's LSTM runtime
    (:class:`citylearn_env.dynamics.LSTMBank`, weights read from the exported ``pth`` without torch).

    Each segment is one episode: the bank is reset, then stepped once per hour with that hour's data inputs
    (the indoor temperature input is the data value, replaced by the prediction as in the environment);
    the first ``lookback`` hours are warm-up. ``settings`` is a :class:`citylearn_env.settings.Behaviour`
    (``CORRECTED``: the environment's default; ``CITYLEARN_2_1``: upstream 2.1's day-type period 8 and
    float32). Returns the hours after warm-up: reference, timestamp, month, simulated, predicted (degC).
    """
    spec = LSTMSpec(read_pth_state_dict(pth), DynamicsBlock.from_schema(block), source=str(pth))
    bank = LSTMBank([spec], settings=settings or CORRECTED)
    frames = []
    for seg in segments:
        rows = table.iloc[seg.start:seg.stop]
        raw = np.stack([rows[name].to_numpy(dtype=float) for name in bank.input_names])
        bank.reset()
        mode = np.ones(1)
        predicted = np.array([bank.step_raw(raw[:, t:t + 1], mode)[0] for t in range(len(rows))])
        lookback = spec.lookback
        frames.append(pd.DataFrame({
            "reference": rows["reference"].to_numpy()[lookback:], "timestamp": rows["timestamp"].to_numpy()[lookback:],
            "month": rows["month"].to_numpy()[lookback:],
            "simulated": rows["indoor_dry_bulb_temperature"].to_numpy()[lookback:],
            "predicted": predicted[lookback:]}))
    return pd.concat(frames, ignore_index=True)


def replay_test_rmse(pth: str | os.PathLike, block: dict, table: pd.DataFrame,
                     test: Sequence[Mapping[str, int]]) -> tuple[float, int]:
    """Closed-loop RMSE [degC] and hours of an exported model on the held-out test segments its metrics record
    (``training.splits.test``: reference, start, stop rows of the validated table), run by the environment's
    runtime (:func:`bank_rollout`): the model's behaviour recomputed, not its recorded metrics copied."""
    segments = [Segment(int(s["reference"]), int(s["start"]), int(s["stop"])) for s in test]
    if not segments or any(not 0 <= s.start < s.stop <= len(table) for s in segments):
        raise InputError("the model's recorded test segments do not fit the house's ILV table",
                         column="training.splits.test")
    hours = bank_rollout(pth, block, validate_ilv(table, source="the house's ILV table"), segments)
    error = (hours["predicted"] - hours["simulated"]).to_numpy(dtype=float)
    return (_rmse(error) if np.isfinite(error).all() else float("inf")), int(len(error))


def monthly_rmse(hours: pd.DataFrame, prediction: str = "predicted") -> pd.DataFrame:
    """Closed-loop RMSE (degC) per (reference, calendar month) of an hours frame (``simulated`` and
    ``prediction`` columns); columns reference, month, hours, rmse_c."""
    error = (hours[prediction] - hours["simulated"]) ** 2
    grouped = error.groupby([hours["reference"], hours["month"]], sort=True)
    out = pd.DataFrame({"hours": grouped.size(), "rmse_c": np.sqrt(grouped.mean())}).reset_index()
    return out


def month_table(monthly: Sequence[dict]) -> str:
    """Plain-text table of per-(reference, month) closed-loop metrics (``evaluate_segments``' ``monthly``)."""
    lines = ["reference  month  hours  closed-loop RMSE C  one-step RMSE C  MAPE %"]
    for m in monthly:
        lines.append(f"{m['reference']:>9}  {m['month']:>5}  {m['hours']:>5}  {m['rmse_c']:>17.3f}  "
                     f"{m['one_step_rmse_c']:>15.3f}  {m['mape_pct']:>6.2f}")
    return "\n".join(lines)
