"""The season of a benchmark period and the lines saying what a test period cannot exercise (no data needed)."""

import numpy as np

from citylearn_env.config import BuildingConfig
from pipeline.paper import seasons


def _building(**series: np.ndarray) -> BuildingConfig:
    return BuildingConfig(name="B1", series={k: np.asarray(v, dtype=float) for k, v in series.items()})


def test_season_is_the_larger_ideal_demand_over_the_period():
    # heating 3 kWh a step in the first half, cooling 2 kWh a step in the second
    building = _building(heating_demand=[3, 3, 3, 0, 0, 0], cooling_demand=[0, 0, 0, 2, 2, 2])
    assert seasons.season(building, (0, 5)) == "heating"      # 9 > 6
    assert seasons.season(building, (2, 5)) == "cooling"      # 3 < 6
    assert seasons.season(building, (0, 2)) == "heating"
    assert seasons.season(_building(), (0, 5)) == "cooling"   # neither: the paper's season
    assert seasons.DEVICE_OF[seasons.season(building, (0, 5))] == "heating_device"


def test_notes_name_what_the_period_cannot_exercise():
    flat = _building(electricity_pricing=[0.1] * 6, carbon_intensity=[0.4, 0.5] * 3, solar_generation=[0] * 6,
                     dhw_demand=[0] * 6, heating_demand=[1] * 6, cooling_demand=[0] * 6)
    cost = seasons.notes([flat], (0, 5), objective="cost", dhw=True, bess_pv=True, hp=False)
    assert len(cost) == 3
    assert "price of B1 is flat" in cost[0] and "no PV" in cost[1] and "no DHW demand" in cost[2]
    # carbon varies: the emissions objective applies
    assert seasons.notes([flat], (0, 5), objective="emissions", dhw=False, bess_pv=False, hp=False) == []
    heated = seasons.notes([flat], (0, 5), objective="discomfort_consumption", dhw=False, bess_pv=False, hp=True)
    assert len(heated) == 1 and "heating device" in heated[0] and "underheating" in heated[0]


def test_a_varying_period_has_no_notes():
    building = _building(electricity_pricing=[0.1, 0.3] * 3, solar_generation=[0, 1] * 3, dhw_demand=[1] * 6,
                         cooling_demand=[2] * 6)
    assert seasons.notes([building], (0, 5), objective="cost", dhw=True, bess_pv=True, hp=True) == []


def test_a_heated_test_period_controls_the_heating_device(tmp_path):
    """The 2023 phase-3 LSTM district turned into a heating month: B1's ideal cooling load served as heating
    (hvac_mode 2), its cooling device 0 kW. The heat-pump benchmark then controls the heating device, accepts a
    B1 without cooling, names the reward's sides for heating and says so in one line."""
    import dataclasses
    import json
    import shutil

    from citylearn_env import CityLearnEnv, load_schema
    from pipeline.paper.benchmarks import BENCHMARKS, benchmark_notes, benchmark_schema, episode_result
    from tests.conftest import DATASET, need_shared

    need_shared(DATASET)
    folder = tmp_path / "district"
    shutil.copytree(DATASET, folder)
    schema = json.loads((folder / "schema.json").read_text())
    schema.update(simulation_end_time_step=24 * 14 + 47)  # 13 training days, 2 test days
    (folder / "schema.json").write_text(json.dumps(schema))
    config = load_schema(folder / "schema.json")
    b1 = config.buildings[0]
    series = dict(b1.series)
    series["heating_demand"], series["cooling_demand"] = series["cooling_demand"], np.zeros_like(series["cooling_demand"])
    series["hvac_mode"] = np.full_like(series["cooling_demand"], 2.0)
    heated = config.replace(buildings=(dataclasses.replace(b1, series=series), *config.buildings[1:]))
    heated = (heated.with_device(b1.name, "heating_device", nominal_power=b1.cooling_device.nominal_power)
              .with_device(b1.name, "cooling_device", nominal_power=0.0))
    hp = next(b for b in BENCHMARKS if b.hp)
    env = CityLearnEnv(benchmark_schema(heated, hp, (24 * 13, 24 * 14 + 47)))
    assert [n.split(".")[-1] for n in env.action_names] == ["heating_device"]
    env.reset(seed=0)
    actions = []
    for _ in range(24):
        actions.append(np.full(env.action_space.shape, 0.5, dtype=np.float32))
        env.step(actions[-1])
    result = episode_result(env, hp, actions, seed=0, multiplier=3.0, controller="sac")
    assert result["season"] == "heating" and result["below_above"] == "underheating/overheating"
    # the heat pump heated: its device drew electricity
    assert env.series()["heating_electricity_consumption"][0].sum() > 0.0
    notes = benchmark_notes(heated, hp)
    assert len(notes) == 1 and "heating device" in notes[0]
    # the unchanged (cooled) district keeps the paper's cooling device and has nothing to say
    assert [n.split(".")[-1] for n in CityLearnEnv(benchmark_schema(config, hp, (312, 359))).action_names] == \
        ["cooling_device"]
    assert benchmark_notes(config, hp) == []
