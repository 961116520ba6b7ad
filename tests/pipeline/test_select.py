"""Stock selection (pipeline.select): layouts, filters, features, auto-k, medoids, determinism and the command.

The real file is the embedded copy in raw/ of the 100 ResStock dwellings (buildstockbatch layout; 85 of them
single-family detached, as ../shared/data/README.md states)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline import select
from pipeline.cli import main
from pipeline.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
STOCK = ROOT / "raw" / "eulp" / "resstock_characteristics_100_dwellings.parquet"
SFD = {"geometry_building_type_recs": "Single-Family Detached"}


@pytest.fixture(scope="module")
def stock() -> pd.DataFrame:
    return select.read_stock_metadata(STOCK)


def test_both_layouts_read_the_same(stock):
    raw = pd.read_parquet(STOCK)
    published = raw.rename(columns=lambda c: c.replace("build_existing_model.", "in.")).rename(
        columns={"building_id": "bldg_id", "upgrade_costs.floor_area_conditioned_ft_2": "in.sqft"})
    other = select.parse_stock_metadata(published)
    assert list(other.index) == list(stock.index) == sorted(raw["building_id"])
    assert (other["vintage"] == stock["vintage"]).all()
    assert np.allclose(other["floor_area_ft2"], stock["floor_area_ft2"])
    # EUI [kWh/ft2] = total MBtu x 293.07107 kWh/MBtu / floor area, only derivable from the buildstock layout
    row = raw.iloc[0]
    expected = row["report_simulation_output.energy_use_total_m_btu"] * 293.07107017222 / row[
        "upgrade_costs.floor_area_conditioned_ft_2"]
    assert stock.loc[int(row["building_id"]), "site_eui_kwh_per_ft2"] == pytest.approx(expected)


def test_filters_keys_alternatives_and_errors(stock):
    assert len(select.apply_filters(stock, SFD)) == 85                              # as the data README says
    filters = select.parse_filters(["geometry_building_type_recs=Single-Family Detached", "vintage=1980s",
                             "in.vintage='1990s'"])
    assert filters == {"geometry_building_type_recs": ("Single-Family Detached",), "vintage": ("1980s", "1990s")}
    chosen = select.apply_filters(stock, filters)
    assert len(chosen) > 0 and set(chosen["vintage"]) <= {"1980s", "1990s"}
    assert len(chosen) == ((stock["geometry_building_type_recs"] == "Single-Family Detached")
                           & stock["vintage"].isin(["1980s", "1990s"])).sum()
    with pytest.raises(InputError, match="'colour'.*unknown characteristic"):
        select.apply_filters(stock, {"colour": "blue"}, file="m.parquet")
    with pytest.raises(InputError, match="expected KEY=VALUE"):
        select.parse_filters(["vintage"])


def test_orientation_and_scaling_by_hand():
    frame = pd.DataFrame({"orientation": ["North", "East", "South", "West"], "vintage": ["1950s", "1960s",
                                                                                          "<1940", "2010s"]},
                         index=pd.Index([1, 2, 3, 4], name="bldg_id"))
    features = select.selection_features(frame)
    # 8 compass points: East = 2 of 8 -> angle pi/2 -> sin 1; min-max scaling of sin(0, pi/2, pi, 3pi/2) -> 0.5, 1, .5, 0
    assert features["orientation_sin"].to_numpy() == pytest.approx([0.5, 1.0, 0.5, 0.0])
    assert features["orientation_cos"].to_numpy() == pytest.approx([1.0, 0.5, 0.0, 0.5])
    # decades 1950, 1960, 1930, 2010 over the span 80 years
    assert features["vintage_decade"].to_numpy() == pytest.approx([20 / 80, 30 / 80, 0.0, 1.0])


def test_medoid_by_hand():
    # summed distances: 0 -> 1 + 10 = 11, 1 -> 1 + 9 = 10, 10 -> 10 + 9 = 19
    assert select.medoid(np.array([[0.0], [1.0], [10.0]])) == 1


def test_auto_k_finds_three_separated_groups():
    # three far-apart groups of five houses, each a "plus" of infiltration +-1 ACH50 and occupants +-1 around
    # its centre: 3 clusters by construction, and each group's medoid is its centre (j = 4)
    rows = []
    for group, (ach, occupants) in enumerate(((3, 1), (15, 4), (40, 8))):
        for j, (da, do) in enumerate(((-1, 0), (1, 0), (0, -1), (0, 1), (0, 0))):
            rows.append({"bldg_id": 10 * group + j, "in.infiltration": f"{ach + da} ACH50",
                         "in.occupants": str(occupants + do)})
    frame = select.parse_stock_metadata(pd.DataFrame(rows))
    selection = select.select_buildings(frame, houses="auto", seed=0, max_clusters=6)
    assert selection.chosen["k"].iloc[0] == 3
    assert sorted(selection.chosen["bldg_id"]) == [4, 14, 24]


def test_auto_k_on_the_real_file_votes_by_the_rule():
    selection = select.select_from_file(STOCK, SFD, houses="auto", seed=3, max_clusters=10)
    table = selection.validity
    assert list(table["k"]) == list(range(2, 11))
    votes = (table.loc[table["calinski_harabasz"].idxmax(), "k"], table.loc[table["silhouette"].idxmax(), "k"],
             table.loc[table["davies_bouldin"].idxmin(), "k"])
    assert selection.chosen["k"].iloc[0] == math.floor(sum(votes) / 3) == select.choose_k(table)
    assert (np.diff(table["sse"]) < 0).all()                     # SSE falls with k (why it does not vote)


def test_same_seed_same_rows_and_draws_stay_in_their_cluster(stock):
    sfd = select.apply_filters(stock, SFD)
    a = select.select_buildings(sfd, houses=8, seed=3)
    b = select.select_buildings(sfd.sample(frac=1.0, random_state=1), houses=8, seed=3)   # row order does not matter
    assert a.chosen.equals(b.chosen)
    assert a.chosen["bldg_id"].is_unique and len(a.chosen) == 8
    drawn = select.select_buildings(sfd, houses=8, seed=3, method="draw")
    assert drawn.chosen.equals(select.select_buildings(sfd, houses=8, seed=3, method="draw").chosen)
    assert drawn.chosen["bldg_id"].is_unique


def test_command_writes_eight_single_family_ids_twice_the_same(tmp_path, capsys):
    args = [str(STOCK), "--filter", 'geometry_building_type_recs="Single-Family Detached"', "--clusters", "8",
            "--seed", "3"]
    assert main(["select", *args, "-o", str(tmp_path / "a.csv")]) == 0
    printed = capsys.readouterr().out
    assert "Calinski-H" in printed and "silhouette" in printed and "Davies-B" in printed
    assert main(["select", *args, "-o", str(tmp_path / "b.csv")]) == 0
    a, b = pd.read_csv(tmp_path / "a.csv"), pd.read_csv(tmp_path / "b.csv")
    assert a.equals(b)
    assert list(a.columns) == ["bldg_id", "cluster", "k", "repeat"] and len(a) == 8 and a["bldg_id"].is_unique
    raw = pd.read_parquet(STOCK).set_index("building_id")
    assert (raw.loc[a["bldg_id"], "build_existing_model.geometry_building_type_recs"]
            == "Single-Family Detached").all()


def test_command_bad_input_is_one_line(tmp_path, capsys):
    assert main(["select", str(STOCK), "--filter", "colour=blue", "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "colour" in err[0]
    assert main(["select", str(tmp_path / "missing.parquet"), "-o", str(tmp_path / "x.csv")]) == 2


# ------------------------------------------------------------------------------------- any number of houses
HOT_HUMID = {**SFD, "building_america_climate_zone": "Hot-Humid", "vacancy_status": "Occupied"}


def test_more_houses_than_rows_takes_every_row_then_balanced_seeded_repeats(stock):
    rows = select.apply_filters(stock, HOT_HUMID)
    assert len(rows) == 17                                        # the 17 hot-humid single-family rows
    chosen = select.select_buildings(rows, houses=40, seed=3).chosen
    assert len(chosen) == 40 and list(chosen.columns) == ["bldg_id", "cluster", "k", "repeat"]
    # 40 = 17 + 17 + 6: every row once, a whole round of repeats, then 6 rows drawn for a third copy
    assert list(chosen["bldg_id"][:17]) == sorted(rows.index) and (chosen["repeat"][:17] == 0).all()
    assert list(chosen["bldg_id"][17:34]) == sorted(rows.index) and (chosen["repeat"][17:34] == 1).all()
    third = chosen[chosen["repeat"] == 2]
    assert len(third) == 6 and third["bldg_id"].is_unique
    assert sorted(chosen["bldg_id"].value_counts().unique()) == [2, 3]
    assert (chosen["k"] == 17).all()
    # each (bldg_id, repeat) once: no two houses share a row and a schedule seed
    assert not chosen.duplicated(["bldg_id", "repeat"]).any()
    again = select.select_buildings(rows.sample(frac=1.0, random_state=2), houses=40, seed=3).chosen
    assert again.equals(chosen)                                   # same seed, same repeats (row order aside)
    others = {tuple(select.select_buildings(rows, houses=40, seed=s).chosen["bldg_id"][34:]) for s in range(6)}
    assert len(others) > 1                                        # the seed draws which rows repeat
    text = select.describe_selection(chosen)
    assert "40 houses from 17 filtered rows" in text and "23 repeats" in text
    assert f"{third['bldg_id'].iloc[0]} x3" in text


def test_houses_up_to_the_rows_is_one_medoid_per_cluster(stock):
    rows = select.apply_filters(stock, HOT_HUMID)
    chosen = select.select_buildings(rows, houses=6, seed=3).chosen
    assert len(chosen) == 6 and chosen["bldg_id"].is_unique and (chosen["repeat"] == 0).all()
    assert select.describe_selection(chosen) == "k = 6, one building per k-means cluster"
    every = select.select_buildings(rows, houses=17, seed=3).chosen   # k = the row count: every row, in id order
    assert list(every["bldg_id"]) == sorted(rows.index) and (every["repeat"] == 0).all()


@pytest.mark.parametrize("bad", [0, -2, 2.5, True, "many"])
def test_a_bad_house_count_is_one_error_naming_the_key(bad):
    from pipeline.config import parse_build_config

    data = {"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
            "inputs": {"characteristics": "c.parquet", "weather": "w", "tariff": "t", "fuel_mix": "f"}}
    with pytest.raises(InputError, match=r"cfg.toml.*'selection.houses'.*whole number >= 1 or 'auto'"):
        parse_build_config({**data, "selection": {"houses": bad}}, file="cfg.toml")
    with pytest.raises(InputError, match=r"house"):
        select.house_count(bad)


def test_houses_and_clusters_are_one_setting():
    from pipeline.config import parse_build_config

    data = {"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
            "inputs": {"characteristics": "c.parquet", "weather": "w", "tariff": "t", "fuel_mix": "f"}}
    for section in ({"houses": 30}, {"clusters": 30}, {"houses": 30, "clusters": 30}):
        selection = parse_build_config({**data, "selection": section}).selection
        assert selection.houses == selection.clusters == 30
    assert parse_build_config({**data, "selection": {}}).selection.houses == "auto"
    with pytest.raises(InputError, match=r"'selection'.*clusters is the former name of houses"):
        parse_build_config({**data, "selection": {"houses": 30, "clusters": 6}})


def test_command_houses_beyond_the_rows_writes_the_repeats(tmp_path, capsys):
    filters = [f"--filter={k}={v}" for k, v in HOT_HUMID.items()]
    assert main(["select", str(STOCK), *filters, "--houses", "20", "--seed", "3", "-o", str(tmp_path / "a.csv")]) == 0
    assert "20 houses from 17 filtered rows" in capsys.readouterr().out
    assert main(["select", str(STOCK), *filters, "--clusters", "20", "--seed", "3", "-o", str(tmp_path / "b.csv")]) == 0
    a = pd.read_csv(tmp_path / "a.csv")
    assert a.equals(pd.read_csv(tmp_path / "b.csv"))               # --clusters: the old name, the same meaning
    assert len(a) == 20 and (a["repeat"] == 1).sum() == 3 and a["bldg_id"].nunique() == 17


def test_a_repeat_gets_its_own_schedule_seed_and_eulp_rows_cannot_repeat():
    from pipeline.builder.houses import check_repeats, house_config, schedule_repeats
    from pipeline.config import parse_build_config

    assert schedule_repeats([7, 9, 7, 7, 9, 4]) == [0, 0, 1, 2, 1, 0]
    data = {"name": "x", "period": {"start": "2018-06-01", "end": "2018-06-02"},
            "inputs": {"characteristics": "c.parquet", "buildings": [7, 7], "tariff": "t", "fuel_mix": "f",
                       "weather": str(ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw")},
            "simulation": {"schedule_seed": 2**32 - 1}}
    config = parse_build_config(data)
    check_repeats(config)                                          # simulated houses may repeat
    assert house_config(config, 0) is config
    assert house_config(config, 2).simulation.schedule_seed == 1   # (2**32 - 1 + 2) mod 2**32
    from pipeline.builder.cache import cache_key
    from pipeline.builder.houses import simulation_cache_parts
    from pipeline.builder.surrogates import ilv_config, judge_training_config

    repeat = house_config(config.model_copy(update={"simulation": config.simulation.model_copy(
        update={"schedule_seed": 0})}), 1)
    # the repeat's seed reaches the EnergyPlus pass, the judge's training config and the simulation cache key
    assert ilv_config(repeat).schedule_seed == judge_training_config(repeat).schedule_seed == 1
    row = {"bldg_id": 7, "in.sqft": 1900}
    assert cache_key(simulation_cache_parts(repeat, row)) != cache_key(simulation_cache_parts(
        house_config(repeat, 0).model_copy(update={"simulation": config.simulation.model_copy(
            update={"schedule_seed": 0})}), row))
    eulp = parse_build_config({**data, "inputs": {**data["inputs"], "characteristics": None, "eulp": "e"}},
                              file="cfg.toml")
    with pytest.raises(InputError, match=r"cfg.toml.*'inputs.buildings'.*bldg_id 7 repeats \(position 2\)"):
        check_repeats(eulp)


def _repeat_district(cache: Path) -> object:
    """raw/district.toml for three June days with the one hot-humid single-family row of the 1990s (bldg_id 59)
    asked for twice: the row and one repeat; one EnergyPlus step per hour, one partial-load run, no surrogate."""
    import tomllib

    from pipeline.config import parse_build_config

    data = tomllib.loads((ROOT / "raw" / "district.toml").read_text())
    data.update(name="repeat2", period={"start": "2018-06-01", "end": "2018-06-03"}, cache_dir=str(cache))
    data["selection"] = {"filters": {**HOT_HUMID, "vintage": "1990s"}, "houses": 2, "seed": 3}
    data["simulation"] = {**data["simulation"], "partial_runs": 1, "month_runs": 0, "timesteps_per_hour": 1}
    data["surrogate"] = {"source": "none"}
    return parse_build_config(data, file=ROOT / "raw" / "district.toml", base=ROOT / "raw")


@pytest.mark.slow  # 4 EnergyPlus passes of June (2 houses, built twice from empty caches)
def test_two_copies_of_one_row_have_their_own_loads_and_rebuild_byte_identical(tmp_path):
    from pipeline.builder.driver import build_district_local
    from pipeline.builder.manifest import district_digest
    from surrogates.energyplus.engine import find_energyplus

    try:
        find_energyplus()
    except Exception as error:  # noqa: BLE001 - any reason the engine is missing
        pytest.skip(f"EnergyPlus is not installed ({error}): the houses cannot be simulated")
    first = build_district_local(_repeat_district(tmp_path / "cache_a"), tmp_path / "a")
    chosen = pd.read_csv(first / "selection.csv")
    assert list(chosen["bldg_id"]) == [59, 59] and list(chosen["repeat"]) == [0, 1]
    assert "2 houses from 1 filtered rows: every row once and 1 repeats" in (first / "report" / "summary.md").read_text()
    one, two = pd.read_csv(first / "Building_1.csv"), pd.read_csv(first / "Building_2.csv")
    for column in ("non_shiftable_load", "dhw_demand", "occupant_count"):
        assert not np.allclose(one[column], two[column]), column      # other households, other loads
    assert one["non_shiftable_load"].sum() > 0 and two["non_shiftable_load"].sum() > 0
    again = build_district_local(_repeat_district(tmp_path / "cache_b"), tmp_path / "b")   # simulated afresh
    assert district_digest(again) == district_digest(first)
    for name in ("Building_1.csv", "Building_2.csv", "schema.json", "selection.csv"):
        assert (again / name).read_bytes() == (first / name).read_bytes(), name
