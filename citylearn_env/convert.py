"""Rewrite a CityLearn dataset from one file layout to the other (v2.1 positional <-> v2.2 named columns).

Values are copied unchanged (the text of every cell is kept); only headers, the carbon column name and the
``dynamics`` block change. LSTM weight files are copied next to the new schema (a dataset's files stay
inside its folder, see :mod:`citylearn_env.paths`).
"""

from __future__ import annotations

import copy
import json
import os
import shutil
from pathlib import Path

from citylearn_env import dataset

_KINDS = {"energy_simulation": "building", "weather": "weather", "pricing": "pricing",
          "carbon_intensity": "carbon"}


def convert_dataset(schema_path: str | Path, out_dir: str | Path, *, to_layout: str = "v2.2") -> Path:
    """Write the dataset of ``schema_path`` into ``out_dir`` in ``to_layout``; return the new schema path."""
    schema_path = Path(schema_path)
    raw = json.loads(schema_path.read_text())
    root = Path(raw.get("root_directory") or schema_path.resolve().parent)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    new = copy.deepcopy(raw)
    new["root_directory"] = None
    done: set[str] = set()
    for spec in new["buildings"].values():
        for key, kind in _KINDS.items():
            name = spec.get(key)
            if name and name not in done:
                _convert_file(root / name, out / name, kind, to_layout)
                done.add(name)
        dynamics = spec.get("dynamics")
        if dynamics:
            spec["dynamics"] = _convert_dynamics(dynamics, root, to_layout, out)
    path = out / "schema.json"
    path.write_text(json.dumps(new, indent=2))
    return path


def _convert_file(src: Path, dst: Path, kind: str, to_layout: str) -> None:
    frame = dataset.read_frame(src)
    mapping = dataset.columns_of(frame.columns, kind, src)
    table = dataset.TABLES[kind]
    names = [n for n in table if n in mapping]
    result = frame[[mapping[n] for n in names]].copy()
    if kind == "carbon":
        result.columns = ["kg_CO2/kWh"] if to_layout == "v2.1" else ["carbon_intensity"]
    else:
        result.columns = dataset.header({n: table[n] for n in names}, to_layout)
    tmp = dst.with_suffix(dst.suffix + ".tmp")
    result.to_csv(tmp, index=False)
    os.replace(tmp, dst)


def _convert_dynamics(dynamics: dict, root: Path, to_layout: str, out: Path) -> dict:
    def absolute(block: dict) -> dict:  # the weights file copied into ``out``, referenced by its name
        block = copy.deepcopy(block)
        attrs = block.setdefault("attributes", {})
        if "filename" in attrs:
            name = Path(attrs["filename"]).name
            shutil.copyfile(root / attrs["filename"], out / name)
            attrs["filename"] = name
        return block

    if to_layout == "v2.2":
        single = dynamics if "type" in dynamics else dynamics.get("cooling") or dynamics.get("heating")
        return absolute(single)
    if "type" in dynamics:
        return {"cooling": absolute(dynamics), "heating": absolute(dynamics)}
    return {mode: absolute(block) for mode, block in dynamics.items()}
