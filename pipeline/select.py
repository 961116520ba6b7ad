"""Stock selection: filter a building-stock metadata table and pick one building per k-means cluster.

Two metadata layouts are read (parquet or CSV), and both end up keyed by the characteristic name without
its prefix:

=================================== ================ ====================================================
layout                              id column        characteristic columns
=================================== ================ ====================================================
published EULP metadata             ``bldg_id``      ``in.<characteristic>`` (e.g. ``in.vintage``)
buildstockbatch results             ``building_id``  ``build_existing_model.<characteristic>``
=================================== ================ ====================================================

Selection (after CityLearn's neighbourhood builder, reference/pipeline_methods.md section 7.1, with two of
its pitfalls designed out):

1. filters ``KEY=VALUE``: a building stays when its characteristic ``KEY`` equals one of the values given for
   that key (values of one key are alternatives; different keys must all hold);
2. features (:data:`FEATURES`), each min-max scaled to 0..1 over the filtered rows; a feature whose column is
   missing or constant is left out, missing cells take the feature's median;
3. k-means (scikit-learn, ``n_init=10``, ``random_state=seed``) for every candidate k; the four
   cluster-validity indices are computed for each: SSE (inertia), Calinski-Harabasz (higher is better),
   silhouette (higher is better), Davies-Bouldin (lower is better);
4. ``clusters="auto"``: k = floor(mean(argmax CH, argmax silhouette, argmin DB)) over k = 2..max (the SSE is
   reported, as upstream, but not voted: it always falls with k);
5. one building per cluster: the medoid (the member with the least summed Euclidean distance to the other
   members in feature space; ties -> smaller id) or a seeded uniform draw within each cluster;
6. as many houses as filtered rows or more: every row once (k = the row count, each its own cluster), then repeats:
   whole rounds of every row, and the remainder drawn without replacement with the selection seed. Column
   ``repeat`` numbers a row's copies (0: the row itself); the build gives copy ``r`` the occupant-schedule seed
   ``[simulation] schedule_seed + r`` (:func:`pipeline.builder.houses.schedule_repeats`), so no two houses
   share their loads.

Orientation is encoded as sin/cos of 2*pi*i/8 for the 8 compass points (upstream divides by 7), and every
cluster contributes exactly one building (upstream weights draws by cluster size squared).
Rows are sorted by id first, so the same file, filters and seed give the same rows.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from citylearn_env.outputs import output_file, write_output
from pipeline.errors import InputError
from surrogates.energyplus.metadata import (
    parse_ach50,
    parse_orientation,
    parse_r_value,
    parse_vintage,
    parse_window_to_wall,
)

#: id column and characteristic prefix of each metadata layout
LAYOUTS = {"bldg_id": "in.", "building_id": "build_existing_model."}
KWH_PER_MBTU = 293.07107017222
METHODS = ("medoid", "draw")


# ----------------------------------------------------------------------------------------------- reading
def parse_stock_metadata(raw: pd.DataFrame, *, file: object = "<metadata>") -> pd.DataFrame:
    """Either layout -> one frame indexed by integer ``bldg_id`` (sorted), characteristic columns without
    prefix, plus the numeric extras ``floor_area_ft2`` and ``site_eui_kwh_per_ft2`` when derivable.

    Columns that are neither an id nor a prefixed characteristic are dropped except the two extras.
    """
    frame = raw.reset_index() if raw.index.name in LAYOUTS else raw
    id_column = next((c for c in LAYOUTS if c in frame.columns), None)
    if id_column is None:
        raise InputError("no building id column (expected 'bldg_id' or 'building_id')", file=file,
                         column="bldg_id")
    prefix = LAYOUTS[id_column]
    ids = pd.to_numeric(frame[id_column], errors="coerce")
    if ids.isna().any():
        raise InputError(f"non-numeric building id in row {int(np.flatnonzero(ids.isna())[0]) + 1}",
                         file=file, column=id_column)
    out = pd.DataFrame({c[len(prefix):]: frame[c].to_numpy() for c in frame.columns if c.startswith(prefix)},
                       index=pd.Index(ids.astype(np.int64).to_numpy(), name="bldg_id"))
    if out.index.has_duplicates:
        raise InputError(f"duplicate building id {int(out.index[out.index.duplicated()][0])}", file=file,
                         column=id_column)
    area = _first_numeric(frame, ("in.sqft", "upgrade_costs.floor_area_conditioned_ft_2",
                                  "in.floor_area_conditioned_ft_2"))
    if area is not None:
        out["floor_area_ft2"] = area.to_numpy()
    eui = _first_numeric(frame, ("out.site_energy.total.energy_consumption_intensity",
                                 "out.site_energy.total.energy_consumption_intensity.kwh_per_ft2"))
    total = _first_numeric(frame, ("report_simulation_output.energy_use_total_m_btu",))
    if eui is not None:
        out["site_eui_kwh_per_ft2"] = eui.to_numpy()
    elif total is not None and area is not None:
        out["site_eui_kwh_per_ft2"] = (total * KWH_PER_MBTU / area).to_numpy()
    return out.sort_index()


def read_stock_metadata(path: str | Path) -> pd.DataFrame:
    """Read a stock metadata file (``.parquet`` or ``.csv``, either layout); see :func:`parse_stock_metadata`."""
    return parse_stock_metadata(read_stock_table(path), file=Path(path))


def read_stock_table(path: str | Path) -> pd.DataFrame:
    """The raw rows of a stock metadata file (``.parquet`` or ``.csv``), columns as published."""
    path = Path(path)
    if not path.is_file():
        raise InputError("metadata file not found", file=path)
    try:
        return pd.read_parquet(path) if path.suffix.lower() == ".parquet" else pd.read_csv(path, low_memory=False)
    except (OSError, ValueError) as error:
        raise InputError(f"unreadable metadata table: {error}", file=path) from None


def _first_numeric(frame: pd.DataFrame, columns: Iterable[str]) -> pd.Series | None:
    for column in columns:
        if column in frame.columns:
            return pd.to_numeric(frame[column], errors="coerce").reset_index(drop=True)
    return None


# ----------------------------------------------------------------------------------------------- filters
def parse_filters(items: Iterable[str], *, source: object = "--filter") -> dict[str, tuple[str, ...]]:
    """``["KEY=VALUE", ...]`` -> ``{KEY: (VALUE, ...)}``; a key given twice collects alternatives. Surrounding
    quotes of a value are removed; a KEY with a layout prefix (``in.``) keeps working."""
    filters: dict[str, list[str]] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        key = _bare(key.strip())
        if not sep or not key:
            raise InputError(f"expected KEY=VALUE, got {item!r}", file=source, column="filter")
        filters.setdefault(key, []).append(value.strip().strip("'\""))
    return {k: tuple(v) for k, v in filters.items()}


def apply_filters(frame: pd.DataFrame, filters: Mapping[str, str | Sequence[str]], *,
                  file: object = "<metadata>") -> pd.DataFrame:
    """Rows of ``frame`` whose characteristic equals one of the allowed values, for every key."""
    keep = np.ones(len(frame), dtype=bool)
    for key, allowed in filters.items():
        key = _bare(key)
        if key not in frame.columns:
            raise InputError(f"unknown characteristic {key!r} in a filter", file=file, column=key)
        values = (allowed,) if isinstance(allowed, str) else tuple(allowed)
        keep &= frame[key].astype(str).isin([str(v) for v in values]).to_numpy()
    return frame[keep]


def _bare(key: str) -> str:
    for prefix in LAYOUTS.values():
        if key.startswith(prefix):
            return key[len(prefix):]
    return key


# ----------------------------------------------------------------------------------------------- features
def _r_value(text: object) -> float:

    return parse_r_value(str(text)) if str(text).strip().lower() not in ("none", "") else 0.0


def _vintage(text: object) -> float:

    return float(parse_vintage(str(text)))


def _ach50(text: object) -> float:

    return parse_ach50(str(text))


def _window_to_wall(row: pd.Series) -> float:

    window, wall = row.get("window_area_ft_2"), row.get("wall_area_above_grade_exterior_ft_2")
    if window is not None and wall is not None and pd.notna(window) and pd.notna(wall) and float(wall) > 0:
        return float(window) / float(wall)
    return parse_window_to_wall(str(row.get("window_areas")))


def _orientation_index(text: object) -> float:

    return parse_orientation(str(text)) / 45.0


#: feature name -> (characteristic columns it needs (any), function of the row). Orientation index i of the
#: 8 compass points (North = 0, clockwise) gives sin and cos of 2*pi*i/8.
FEATURES: dict[str, tuple[tuple[str, ...], Callable[[pd.Series], float]]] = {
    "window_to_wall": (("window_area_ft_2", "window_areas"), _window_to_wall),
    "vintage_decade": (("vintage",), lambda r: _vintage(r["vintage"])),
    "orientation_sin": (("orientation",), lambda r: math.sin(2 * math.pi * _orientation_index(r["orientation"]) / 8)),
    "orientation_cos": (("orientation",), lambda r: math.cos(2 * math.pi * _orientation_index(r["orientation"]) / 8)),
    "infiltration_ach50": (("infiltration",), lambda r: _ach50(r["infiltration"])),
    "ceiling_r": (("insulation_ceiling",), lambda r: _r_value(r["insulation_ceiling"])),
    "slab_r": (("insulation_slab",), lambda r: _r_value(r["insulation_slab"])),
    "wall_r": (("insulation_wall",), lambda r: _r_value(r["insulation_wall"])),
    "site_eui": (("site_eui_kwh_per_ft2",), lambda r: float(r["site_eui_kwh_per_ft2"])),
    "occupants": (("occupants",), lambda r: float(str(r["occupants"]).rstrip("+"))),
}


def selection_features(frame: pd.DataFrame, *, file: object = "<metadata>") -> pd.DataFrame:
    """The encoded features of :data:`FEATURES` per building, min-max scaled to 0..1 (module docstring)."""
    columns = {}
    for name, (needs, encode) in FEATURES.items():
        if not any(c in frame.columns for c in needs):
            continue
        values = []
        for bldg_id, row in frame.iterrows():
            try:
                values.append(encode(row))
            except (TypeError, ValueError, KeyError) as error:
                if all(pd.isna(row.get(c)) for c in needs if c in row.index):
                    values.append(np.nan)
                    continue
                raise InputError(f"feature {name}: {error}", file=file, column=needs[0],
                                 row=f"bldg_id={bldg_id}") from None
        series = pd.Series(values, index=frame.index, dtype=float)
        series = series.fillna(series.median())
        span = series.max() - series.min()
        if series.notna().all() and span > 0:
            columns[name] = (series - series.min()) / span
    if not columns:
        raise InputError("no usable selection feature (all missing or constant)", file=file)
    return pd.DataFrame(columns, index=frame.index)


# ----------------------------------------------------------------------------------------------- clustering
def validity_table(features: pd.DataFrame, ks: Iterable[int], seed: int) -> pd.DataFrame:
    """k-means for every k of ``ks``: columns ``k, sse, calinski_harabasz, silhouette, davies_bouldin``."""
    from sklearn.metrics import (  # scikit-learn loads only when a selection clusters
        calinski_harabasz_score,
        davies_bouldin_score,
        silhouette_score,
    )

    x = features.to_numpy(dtype=float)
    rows = []
    for k in ks:
        model = _kmeans(x, k, seed)
        labels = model.labels_
        distinct = len(set(labels))
        ok = 1 < distinct < len(x)
        rows.append({"k": k, "sse": float(model.inertia_),
                     "calinski_harabasz": float(calinski_harabasz_score(x, labels)) if ok else np.nan,
                     "silhouette": float(silhouette_score(x, labels)) if ok else np.nan,
                     "davies_bouldin": float(davies_bouldin_score(x, labels)) if ok else np.nan})
    return pd.DataFrame(rows)


def choose_k(table: pd.DataFrame) -> int:
    """floor(mean(k of max Calinski-Harabasz, k of max silhouette, k of min Davies-Bouldin))."""
    valid = table.dropna(subset=["calinski_harabasz", "silhouette", "davies_bouldin"])
    if valid.empty:
        raise InputError("no k with a defined cluster-validity index (too few distinct buildings)")
    votes = [int(valid.loc[valid["calinski_harabasz"].idxmax(), "k"]), int(valid.loc[valid["silhouette"].idxmax(), "k"]),
             int(valid.loc[valid["davies_bouldin"].idxmin(), "k"])]
    return int(math.floor(sum(votes) / 3))


def _kmeans(x: np.ndarray, k: int, seed: int):
    from sklearn.cluster import KMeans  # scikit-learn loads only when a selection clusters

    return KMeans(n_clusters=int(k), n_init=10, random_state=int(seed)).fit(x)


def medoid(points: np.ndarray) -> int:
    """Position of the member with the least summed Euclidean distance to the others (first on ties)."""
    distances = np.sqrt(((points[:, None, :] - points[None, :, :]) ** 2).sum(axis=-1))
    return int(np.argmin(distances.sum(axis=1)))


@dataclass(frozen=True)
class Selection:
    """The chosen buildings (``bldg_id``, ``cluster``, ``k``, ``repeat`` per row, in district order), the
    validity table and the features (none when every row is taken and repeated)."""

    chosen: pd.DataFrame
    validity: pd.DataFrame
    features: pd.DataFrame


def select_buildings(frame: pd.DataFrame, *, houses: int | str = "auto", seed: int = 0, method: str = "medoid",
                     max_clusters: int | None = None, file: object = "<metadata>") -> Selection:
    """``houses`` buildings of the (already filtered) stock ``frame`` (module docstring): one per k-means
    cluster when ``houses`` is below the row count, else every row (in id order) and seeded repeats.

    ``houses``: a number (>= 1), or ``"auto"`` (k chosen over 2..``max_clusters``, default ceil(N/2) capped
    at 20). ``method``: ``"medoid"`` or ``"draw"`` (seeded uniform draw per cluster).
    """
    if method not in METHODS:
        raise InputError(f"selection method must be one of {METHODS}, got {method!r}", file=file, column="method")
    frame = frame.sort_index()
    n = len(frame)
    if n == 0:
        raise InputError("no building left after the filters", file=file)
    if houses != "auto" and house_count(houses, file=file) >= n:  # every row (then repeats): no clustering
        return Selection(repeat_rows(frame.index, int(houses), seed), _undefined_validity(n),
                         pd.DataFrame(index=frame.index))
    features = selection_features(frame, file=file)
    if houses == "auto":
        top = min(max_clusters or min(math.ceil(n / 2), 20), n - 1)
        if top < 2:
            raise InputError(f"auto needs at least 3 buildings, {n} left after the filters", file=file)
        validity = validity_table(features, range(2, top + 1), seed)
        k = choose_k(validity)
    else:
        k = int(houses)
        validity = validity_table(features, [k], seed)
    labels = _kmeans(features.to_numpy(dtype=float), k, seed).labels_
    rng = np.random.default_rng(seed)
    rows = []
    for cluster in range(k):
        members = np.flatnonzero(labels == cluster)
        if method == "medoid":
            pick = members[medoid(features.to_numpy(dtype=float)[members])]
        else:
            pick = members[int(rng.integers(len(members)))]
        rows.append({"bldg_id": int(frame.index[pick]), "cluster": cluster, "k": k, "repeat": 0})
    chosen = pd.DataFrame(rows).sort_values("cluster", ignore_index=True)
    return Selection(chosen, validity, features)


def house_count(value: object, *, file: object = "<metadata>") -> int:
    """A number of houses: a whole number >= 1 (not a bool, not a fraction), else one error naming ``houses``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(f"houses must be a whole number >= 1 or 'auto', got {value!r}", file=file,
                         column="houses")
    return int(value)


def repeat_rows(ids: Sequence[int], houses: int, seed: int) -> pd.DataFrame:
    """``houses`` (>= the row count) buildings from the sorted ``ids``: every id once (its own cluster), then
    whole rounds of every id, then the remainder drawn without replacement with ``seed`` (in id order).
    Columns ``bldg_id, cluster, k, repeat``; ``repeat`` r >= 1 marks a row's r-th repeat."""
    ids = [int(i) for i in sorted(ids)]
    n = len(ids)
    rounds, rest = divmod(houses, n)
    drawn = sorted(np.random.default_rng(seed).choice(n, size=rest, replace=False).tolist()) if rest else []
    picks = [(position, r) for r in range(rounds) for position in range(n)] + [(p, rounds) for p in drawn]
    return pd.DataFrame([{"bldg_id": ids[p], "cluster": p, "k": n, "repeat": r} for p, r in picks])


def _undefined_validity(k: int) -> pd.DataFrame:
    """The validity row of k = the row count (every row its own cluster: SSE 0, the indices undefined)."""
    return pd.DataFrame([{"k": k, "sse": 0.0, "calinski_harabasz": np.nan, "silhouette": np.nan,
                          "davies_bouldin": np.nan}])


def select_from_file(path: str | Path, filters: Mapping[str, str | Sequence[str]], *, houses: int | str = "auto",
                     seed: int = 0, method: str = "medoid", max_clusters: int | None = None) -> Selection:
    """Read ``path``, apply ``filters`` and :func:`select_buildings`."""
    stock = read_stock_metadata(path)
    return select_buildings(apply_filters(stock, filters, file=path), houses=houses, seed=seed, method=method,
                            max_clusters=max_clusters, file=path)


def describe_selection(chosen: pd.DataFrame) -> str:
    """One line on how ``chosen`` was picked, naming the repeated rows (``bldg_id`` x copies)."""
    k = int(chosen["k"].iloc[0])
    repeats = chosen[chosen["repeat"] > 0] if "repeat" in chosen.columns else chosen.iloc[:0]
    if repeats.empty:
        return f"k = {k}, one building per k-means cluster"
    copies = chosen.groupby("bldg_id", sort=True).size()
    named = ", ".join(f"{i} x{c}" for i, c in copies[copies > 1].items())
    return (f"{len(chosen)} houses from {k} filtered rows: every row once and {len(repeats)} repeats, each with "
            f"its own occupant schedules ({named})")


def format_validity(table: pd.DataFrame, chosen_k: int) -> str:
    """The validity-index table as aligned text, the chosen k marked with ``*``."""
    lines = [f"{'k':>4} {'SSE':>10} {'Calinski-H':>11} {'silhouette':>11} {'Davies-B':>9}"]
    for row in table.itertuples():
        mark = "*" if row.k == chosen_k else " "
        lines.append(f"{row.k:>3}{mark} {row.sse:10.4f} {row.calinski_harabasz:11.4f} {row.silhouette:11.4f} "
                     f"{row.davies_bouldin:9.4f}")
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------------- command
def register(subparsers) -> None:
    """``districtgen select METADATA --filter KEY=VALUE ... --houses N|auto --seed S -o IDS.csv``."""
    parser = subparsers.add_parser("select", help="pick representative buildings from a stock metadata file")
    parser.add_argument("metadata", type=Path, help="EULP metadata (bldg_id, in.*) or buildstockbatch results "
                                                    "(building_id, build_existing_model.*), parquet or CSV")
    parser.add_argument("--filter", action="append", default=[], metavar="KEY=VALUE",
                        help="keep rows whose characteristic KEY (no prefix) equals VALUE; repeat a key for "
                             "alternatives")
    parser.add_argument("--houses", "--clusters", dest="houses", default="auto",
                        help="number of houses (one per k-means cluster up to the filtered rows; beyond them every "
                             "row and seeded repeats), or auto (k by the validity indices); --clusters: the old name")
    parser.add_argument("--max-clusters", type=int, default=None, help="largest k tried by auto")
    parser.add_argument("--method", choices=METHODS, default="medoid", help="one building per cluster: medoid "
                                                                            "or a seeded draw")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("-o", "--output", type=Path, required=True, help="CSV: bldg_id, cluster, k, repeat")
    parser.set_defaults(func=select_command)


def select_command(args) -> int:
    houses = args.houses if args.houses == "auto" else _int(args.houses)
    check_options(houses, args.max_clusters, args.seed)
    folder, name = output_file(args.output, column="--output")  # before the work: a link, a built district
    selection = select_from_file(args.metadata, parse_filters(args.filter), houses=houses, seed=args.seed,
                                 method=args.method, max_clusters=args.max_clusters)
    k = int(selection.chosen["k"].iloc[0])
    print(format_validity(selection.validity, k))
    write_output(folder, name, lambda stream: selection.chosen.to_csv(stream, index=False), column="--output")
    print(f"{len(selection.chosen)} buildings ({describe_selection(selection.chosen)}; {args.method}, seed "
          f"{args.seed}) -> {args.output}: {', '.join(str(i) for i in selection.chosen['bldg_id'])}")
    return 0


def check_options(houses: int | str, max_clusters: int | None, seed: int) -> None:
    """Refuse (one line naming the option) ``--houses`` or ``--max-clusters`` below 1 and a negative ``--seed``."""
    for option, value, least in (("--houses", houses, 1), ("--max-clusters", max_clusters, 1), ("--seed", seed, 0)):
        if isinstance(value, int) and value < least:
            raise InputError(f"{option} must be >= {least}, got {value}", column=option)


def _int(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise InputError(f"--houses must be a number or 'auto', got {text!r}", column="houses") from None
