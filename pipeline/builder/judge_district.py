"""Judge a district's surrogate against its house's physics from the command line: ``districtgen surrogate
evaluate MODEL --judge CONFIG`` (the work is :func:`surrogates.judge.judge_surrogate`; the house, weather and
training settings come from the district configuration, so this lives with the build)."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from pipeline.builder.surrogates import judge_config, judge_row, judge_training_config
from pipeline.config import read_build_config
from pipeline.errors import InputError


def judge(pth: str | os.PathLike, config_path: str | os.PathLike, bldg_id: int | None = None) -> dict:
    """Judge an exported model against its house's physics (:mod:`surrogates.judge`): a fresh EnergyPlus run
    of the house of district configuration ``config_path`` (stock row, weather, the ``[simulation]`` ILV
    settings the model was trained on) at another zone timestep count and seed. ``bldg_id``: default from
    ``buildings.json`` beside the model (a built district). Returns the judge's record."""
    from surrogates.judge import judge_surrogate  # torch: not at parser build

    config = read_build_config(config_path)
    pth = Path(pth)
    bldg_id = bldg_id if bldg_id is not None else _district_bldg_id(pth)
    row = judge_row(config, bldg_id)
    if row is None:
        raise InputError("no house to judge against: the configuration has neither inputs.characteristics nor "
                         "surrogate.source = 'energyplus'", file=config_path, column="inputs.characteristics")
    return judge_surrogate(pth, row, Path(config.inputs.weather), judge_training_config(config), judge_config(config),
                           source=config.inputs.characteristics or config_path)


def _district_bldg_id(pth: Path) -> int:
    """The bldg_id of model ``<building>.pth`` from ``buildings.json`` beside it (a built district)."""
    notes = pth.parent / "buildings.json"
    try:
        return int(json.loads(notes.read_text())[pth.stem]["bldg_id"])
    except (OSError, KeyError, ValueError, TypeError):
        raise InputError(f"no bldg_id of {pth.stem} in buildings.json beside the model: pass --bldg-id",
                         file=notes, column="--bldg-id") from None


def judge_command(args: argparse.Namespace) -> int:
    """``surrogate evaluate MODEL --judge CONFIG [--bldg-id ID] [--json]``: print the judge's monthly table."""
    record = judge(args.model, args.judge, args.bldg_id)
    if args.json:
        print(json.dumps(record, indent=2))
        return 0
    ilv = record["judge_ilv"]
    print("reference  month  hours  closed-loop RMSE C")
    for m in record["monthly"]:
        print(f"{m['reference']:>9}  {m['month']:>5}  {m['hours']:>5}  {m['rmse_c']:>18.3f}")
    verdict = "within the bound" if record["passes"] else "OVER the bound"
    print(f"judge: fresh EnergyPlus run at {ilv['timesteps_per_hour']} timesteps/h, seed {ilv['seed']} (training data "
          f"per the configuration: {record['training_ilv']['timesteps_per_hour']}/h, seed "
          f"{record['training_ilv']['seed']}): monthly RMSE "
          f"median {record['median_c']:.3f} C, worst month {record['worst_c']:.3f} C ({verdict}: "
          f"{record['median_bound_c']} / {record['worst_bound_c']} C); mean abs error {record['mean_abs_c']:.3f} C, "
          f"with ideal loads {record['ideal_mean_abs_c']:.3f} C")
    return 0
