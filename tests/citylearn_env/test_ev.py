"""EVs and chargers (citylearn_env.ev, docs/ev.md): hand-computed steps, the charger CSV reader, the schema
section on upstream's EV dataset."""

from __future__ import annotations

import json

import numpy as np
import pytest

from citylearn_env.devices import BatteryParams, Curve, battery_charge
from citylearn_env.errors import SchemaError
from citylearn_env.ev import (
    ChargerData,
    ChargerParams,
    ElectricVehicles,
    advance_soc,
    away_soc,
    battery_request,
    charge_plugged_evs,
    charger_consumption,
    charger_efficiency,
    charger_energy,
    connection_soc,
    default_ev_battery,
    departure_shortfall,
    drift_soc,
    energy_to_required_soc,
    parse_ev_section,
    read_charger_table,
    upstream_uniform,
)
from citylearn_env.washing_machine import (
    add_cycle_load,
    cycle_starts,
    parse_washing_machines,
    read_washing_machine_table,
    window_changed,
)
from tests.conftest import ROOT, SHARED, need_shared

EV_DATASET = SHARED / "data" / "citylearn" / "upstream" / "v2.4.2" / "citylearn_challenge_2022_phase_all_plus_evs"
REFERENCE = ROOT / "benchmarks" / "upstream_2_5_0" / "ev_actions.json"


def chargers(*, curve: bool = False) -> ChargerParams:
    """Charger A: the dataset's charger_1_1 (11 kW, min 1.4 kW, discharge 7.2 kW, eta 0.95); B: charger_4_1
    (22 kW both ways, min 3.7 kW both ways, eta 0.9)."""
    return ChargerParams(names=("A", "B"), building=np.array([0, 1]),
                         max_charging_power=np.array([11.0, 22.0]), min_charging_power=np.array([1.4, 3.7]),
                         max_discharging_power=np.array([7.2, 22.0]), min_discharging_power=np.array([0.0, 3.7]),
                         efficiency=np.array([0.95, 0.9]),
                         charge_efficiency_curve=(((0.0, 0.8), (1.0, 1.0)) if curve else None, None),
                         discharge_efficiency_curve=(None, None))


def test_charger_energy_scales_and_holds_within_min_and_max_power():
    a = chargers()
    # A: 0.5 * 11 = 5.5 kWh; 0.05 * 11 = 0.55 raised to the 1.4 kW minimum; -0.5 * 7.2 = -3.6; 0 stays 0
    np.testing.assert_allclose(charger_energy(np.array([0.5, 1.0]), a), [5.5, 22.0])
    np.testing.assert_allclose(charger_energy(np.array([0.05, -0.01]), a), [1.4, -3.7])  # B: -0.22 -> -3.7
    np.testing.assert_allclose(charger_energy(np.array([-0.5, 0.0]), a), [-3.6, 0.0])
    # a quarter-hour step: 1.0 * 22 kW * 0.25 h = 5.5 kWh (>= 3.7)
    np.testing.assert_allclose(charger_energy(np.array([0.0, 1.0]), a, step_hours=0.25), [0.0, 5.5])


def test_battery_request_and_grid_consumption_through_the_charger_efficiency():
    eta = np.array([0.95, 0.9])
    request = battery_request(np.array([5.5, -3.6]), eta)
    np.testing.assert_allclose(request, [5.5 * 0.95, -3.6 / 0.9])  # 5.225 kWh in, 4.0 kWh out of the battery
    # the battery took 5.225 and gave 4.0: the grid sees 5.225 / 0.95 = 5.5 and -4.0 * 0.9 = -3.6
    np.testing.assert_allclose(charger_consumption(np.array([5.225, -4.0]), eta, np.array([True, True])), [5.5, -3.6])
    np.testing.assert_allclose(charger_consumption(np.array([5.225, -4.0]), eta, np.array([False, True])), [0, -3.6])


def test_charger_efficiency_curve_replaces_the_constant():
    a = chargers(curve=True)
    # A's charge curve 0.8 -> 1.0 over |a| 0..1: 0.9 at 0.5; discharging uses the constant 0.95; B constant 0.9
    np.testing.assert_allclose(charger_efficiency(np.array([0.5, 0.5]), a), [0.9, 0.9])
    np.testing.assert_allclose(charger_efficiency(np.array([-0.5, -1.0]), a), [0.95, 0.9])


def flat_battery(n: int) -> BatteryParams:
    """n 60 kWh / 50 kW batteries with a flat 0.81 round-trip efficiency (one way 0.9), full power at every
    SOC, no standby loss, no fade, depth of discharge 1."""
    ones = np.ones(n)
    return BatteryParams(capacity=60 * ones, nominal_power=50 * ones, efficiency=0.81 * ones,
                         loss_coefficient=0 * ones, capacity_loss_coefficient=0 * ones,
                         depth_of_discharge=ones, initial_soc=0.5 * ones,
                         power_efficiency=Curve.from_points([((0.0, 0.81), (1.0, 0.81))] * n),
                         capacity_power=Curve.from_points([((0.0, 1.0), (1.0, 1.0))] * n))


def data(state, ev, *, departure=None, required=None, arrival=None, soc_arrival=None) -> ChargerData:
    n = len(state[0])
    fill = [[-1] * n] * len(state)
    fill_soc = [[-0.1] * n] * len(state)
    return ChargerData(state=np.array(state), ev=np.array(ev), departure_time=np.array(departure or fill),
                       required_soc_departure=np.array(required or fill_soc, dtype=float),
                       estimated_arrival_time=np.array(arrival or fill),
                       estimated_soc_arrival=np.array(soc_arrival or fill_soc, dtype=float))


def test_charge_plugged_evs_steps_only_the_plugged_ev_with_an_action():
    # charger A holds EV 0 (state 1), charger B is empty (state 3); EV 1 is away
    d = data([[1], [3]], [[0], [-1]])
    vehicles = ElectricVehicles(names=("ev0", "ev1"), battery=flat_battery(2))
    soc0 = np.array([0.5, 0.3])
    soc, eff, cap, consumption, stepped = charge_plugged_evs(
        np.array([0.5, 1.0]), soc0, np.array([0.81, 0.81]), np.array([60.0, 60.0]), d, 0, chargers(), vehicles)
    # A: 5.5 kWh * 0.95 = 5.225 kWh asked; stored 5.225 * 0.9 = 4.7025 kWh: 30 -> 34.7025 kWh of 60
    np.testing.assert_allclose(soc, [34.7025 / 60, 0.3])
    np.testing.assert_allclose(consumption, [5.5, 0.0])  # balance 5.225 / 0.95; B has no EV
    np.testing.assert_array_equal(stepped, [True, False])
    np.testing.assert_allclose(eff, [0.81, 0.81])
    np.testing.assert_allclose(cap, [60.0, 60.0])
    # discharge A at -0.5: -3.6 kWh grid side, -3.6 / 0.95 asked of the battery, which loses that / 0.9
    soc, _, _, consumption, _ = charge_plugged_evs(
        np.array([-0.5, 0.0]), soc0, np.array([0.81, 0.81]), np.array([60.0, 60.0]), d, 0, chargers(), vehicles)
    asked = 3.6 / 0.95
    np.testing.assert_allclose(soc, [(30 - asked / 0.9) / 60, 0.3])
    np.testing.assert_allclose(consumption, [-asked * 0.95, 0.0])
    # zero action: nothing is stepped (upstream writes nothing)
    *_, consumption, stepped = charge_plugged_evs(
        np.zeros(2), soc0, np.array([0.81, 0.81]), np.array([60.0, 60.0]), d, 0, chargers(), vehicles)
    assert not stepped.any() and not consumption.any()


# one charger, EV 0: parked t0-1, away t2, incoming t3 (arrives with 40 %), parked t4, away t5, parked t6
STATES = [[1, 1, 3, 2, 1, 3, 1]]
EVS = [[0, 0, -1, 0, 0, -1, 0]]
REQUIRED = [[0.8, 0.8, -0.1, -0.1, 0.9, -0.1, 0.7]]
ARRIVAL_SOC = [[-0.1, -0.1, -0.1, 0.4, -0.1, -0.1, -0.1]]


def test_connection_rule_takes_arrival_soc_then_required_soc():
    d = data(STATES, EVS, required=REQUIRED, soc_arrival=ARRIVAL_SOC)
    got = [connection_soc(d, t)[0] for t in range(7)]
    # t0: new, no arrival SOC -> required 0.8; t1 continuing; t4 after state 2 -> row 3's 0.4;
    # t6 after state 3 -> row 5 has no arrival SOC -> required 0.7
    np.testing.assert_allclose(got, [0.8, np.nan, np.nan, np.nan, 0.4, np.nan, 0.7])


def test_away_rule_finds_plugged_and_connecting_evs():
    d = data(STATES, EVS, required=REQUIRED, soc_arrival=ARRIVAL_SOC)
    found, soc = away_soc(d, 0, 2)  # EV 0 plugged: found, untouched; EV 1 in no charger: drifts
    np.testing.assert_array_equal(found, [True, False])
    assert np.isnan(soc).all()
    found, _ = away_soc(d, 2, 2)  # away at t2 and only incoming at t3: drifts
    assert not found[0]
    found, soc = away_soc(d, 3, 2)  # incoming at t3, plugged at t4: SOC from row 3
    assert found[0] and soc[0] == 0.4
    found, soc = away_soc(d, 5, 2)  # away at t5, plugged at t6 without arrival SOC: found, untouched
    assert found[0] and np.isnan(soc[0])


def test_drift_multiplies_by_a_clipped_draw_and_stays_within_0_and_1():
    np.testing.assert_allclose(drift_soc(np.array([0.5, 0.5, 0.9, 0.5]), np.array([1.2, 2.0, 1.3, 0.1])),
                               [0.6, 0.7, 1.0, 0.3])  # 0.5*1.2; 0.5*1.4; 0.9*1.3 -> 1; 0.5*0.6


def test_required_soc_bookkeeping():
    # 60 kWh EV at 50 % needing 87 %: 0.37 * 60 = 22.2 kWh; missing requirement (-0.1): 0
    np.testing.assert_allclose(energy_to_required_soc(np.array([0.5, 0.5, 0.9]), np.array([0.87, -0.1, 0.8]),
                                                      np.array([60.0, 60.0, 60.0])), [22.2, 0.0, 0.0])
    d = data([[1, 1]], [[0, 0]], departure=[[1, 0]], required=[[0.8, 0.8]])
    np.testing.assert_allclose(departure_shortfall(np.array([0.5]), d, 1), [0.3])  # leaves at t1 with 0.5 < 0.8
    np.testing.assert_allclose(departure_shortfall(np.array([0.5]), d, 0), [0.0])  # not leaving yet


def test_default_ev_battery_at_u_zero_is_each_range_low_end():
    b = default_ev_battery([40.0], [50.0], [0.25], [0.85], u=0.0)
    assert b.efficiency[0] == pytest.approx(0.90) and b.loss_coefficient[0] == pytest.approx(0.001)
    assert b.capacity_loss_coefficient[0] == pytest.approx(1e-5)
    # power-efficiency points: e*0.85, e*0.90, e*0.98, e, e*0.95 with e = 0.9
    np.testing.assert_allclose(b.power_efficiency.xs[0], [0, 0.25, 0.65, 0.75, 1])
    np.testing.assert_allclose(b.power_efficiency.ys[0], [0.765, 0.81, 0.882, 0.9, 0.855])
    np.testing.assert_allclose(b.capacity_power.xs[0], [0, 0.75, 1])
    np.testing.assert_allclose(b.capacity_power.ys[0], [0.95, 0.90, 0.20])
    assert 0.0 <= upstream_uniform(2022) < 1.0


def test_default_ev_battery_matches_upstream_reference_run():
    """The realised EV battery parameters of CityLearn 2.5.0 (benchmarks/ev_upstream.py output)."""
    if not REFERENCE.exists():
        pytest.skip(f"{REFERENCE} absent: run benchmarks/ev_upstream.py --only ev")
    need_shared(EV_DATASET)
    upstream = json.loads(REFERENCE.read_text())["ev_battery"]
    schema = json.loads((EV_DATASET / "schema.json").read_text())
    draws = [upstream[name]["initial_soc"] for name in schema["electric_vehicles_def"]]
    section = parse_ev_section(schema, EV_DATASET, initial_soc_draws=draws)
    b = section.vehicles.battery
    for i, name in enumerate(section.vehicles.names):
        ref = upstream[name]
        for key in ("capacity", "nominal_power", "initial_soc", "depth_of_discharge", "efficiency",
                    "loss_coefficient", "capacity_loss_coefficient"):
            assert getattr(b, key)[i] == pytest.approx(ref[key], rel=1e-9), (name, key)
        np.testing.assert_allclose(np.c_[b.power_efficiency.xs[i], b.power_efficiency.ys[i]],
                                   ref["power_efficiency_curve"], rtol=1e-9)
        np.testing.assert_allclose(np.c_[b.capacity_power.xs[i], b.capacity_power.ys[i]],
                                   ref["capacity_power_curve"], rtol=1e-9)


HEADER8 = ("electric_vehicle_charger_state,electric_vehicle_id,electric_vehicle_battery_capacity_khw,current_soc,"
           "electric_vehicle_departure_time,electric_vehicle_required_soc_departure,"
           "electric_vehicle_estimated_arrival_time,electric_vehicle_estimated_soc_arrival")
ROWS8 = ["1,EV_a,60,40.89,12.0,87.0,,", "3,,,,,,,", "2,EV_a,,,,,0.0,76.0"]


def test_read_charger_table_by_header_in_both_layouts(tmp_path):
    eight = tmp_path / "eight.csv"
    eight.write_text("\n".join([HEADER8, *ROWS8]) + "\n")
    six = tmp_path / "six.csv"  # the 2.5 layout, columns in another order: matched by name
    six.write_text("electric_vehicle_id,electric_vehicle_charger_state,electric_vehicle_departure_time,"
                   "electric_vehicle_required_soc_departure,electric_vehicle_estimated_arrival_time,"
                   "electric_vehicle_estimated_soc_arrival\nEV_a,1,12,87,,\n,3,,,,\nEV_a,2,,,0,76\n")
    for path in (eight, six):
        t = read_charger_table(path, 3)
        np.testing.assert_array_equal(t.state, [1, 3, 2])
        assert list(t.ev_id) == ["EV_a", "", "EV_a"]
        np.testing.assert_array_equal(t.departure_time, [12, -1, -1])
        np.testing.assert_allclose(t.required_soc_departure, [0.87, -0.1, -0.1])  # percent -> fraction
        np.testing.assert_array_equal(t.estimated_arrival_time, [-1, -1, 0])
        np.testing.assert_allclose(t.estimated_soc_arrival, [-0.1, -0.1, 0.76])


@pytest.mark.parametrize(("row", "column", "line"), [
    ("4,EV_a,60,1,1,50,,", "electric_vehicle_charger_state", "row 1 (file line 3)"),
    ("1,,60,1,1,50,,", "electric_vehicle_id", "row 1 (file line 3)"),
    ("1,EV_a,60,1,soon,50,,", "electric_vehicle_departure_time", "row 1 (file line 3)"),
    ("1,EV_a,60,1,1,120,,", "electric_vehicle_required_soc_departure", "row 1 (file line 3)"),
])
def test_bad_charger_cell_is_one_error_naming_file_column_row(tmp_path, row, column, line):
    path = tmp_path / "charger.csv"
    path.write_text("\n".join([HEADER8, ROWS8[0], row]) + "\n")
    with pytest.raises(SchemaError) as error:
        read_charger_table(path, 2)
    message = str(error.value)
    assert str(path) in message and repr(column) in message and line in message


def test_missing_column_and_short_file_are_clear_errors(tmp_path):
    path = tmp_path / "charger.csv"
    path.write_text(HEADER8.replace(",electric_vehicle_estimated_soc_arrival", "") + "\n1,EV_a,60,1,1,50,\n")
    with pytest.raises(SchemaError, match="electric_vehicle_estimated_soc_arrival"):
        read_charger_table(path, 1)
    path.write_text("\n".join([HEADER8, *ROWS8]) + "\n")
    with pytest.raises(SchemaError, match="has 3 data rows"):
        read_charger_table(path, 4)


def test_real_charger_file_rows():
    need_shared(EV_DATASET)
    t = read_charger_table(EV_DATASET / "charger_1_1.csv", 8760)
    # file lines 2 and 18 (rows 0 and 16): "1,Electric_Vehicle_7,60,40.89,12.0,87.0,," and
    # "2,Electric_Vehicle_7,,,,,0.0,76.0"; rows 13..15 are "3,,,,,,,"
    assert t.state.shape == (8760,)
    assert (t.state[0], t.ev_id[0], t.departure_time[0], t.required_soc_departure[0]) == (1, "Electric_Vehicle_7",
                                                                                         12, 0.87)
    assert (t.state[16], t.estimated_arrival_time[16], t.estimated_soc_arrival[16]) == (2, 0, 0.76)
    np.testing.assert_array_equal(t.state[13:16], [3, 3, 3])


def test_parse_ev_section_of_the_upstream_ev_dataset():
    need_shared(EV_DATASET)
    schema = json.loads((EV_DATASET / "schema.json").read_text())
    with pytest.raises(SchemaError, match="Electric_Vehicle_2.battery.attributes.initial_soc"):
        parse_ev_section(schema, EV_DATASET)  # EVs 2-6 have no initial_soc; upstream draws it unseeded
    section = parse_ev_section(schema, EV_DATASET, initial_soc_draws=[0.5] * 8)
    # schema.json: EV capacities 40, 50, 75, 45, 90, 100, 60, 80 kWh; EVs 1, 7, 8 start at 0.25, 0.25, 0.2
    np.testing.assert_allclose(section.vehicles.battery.capacity, [40, 50, 75, 45, 90, 100, 60, 80])
    np.testing.assert_allclose(section.vehicles.battery.initial_soc, [0.25, 0.5, 0.5, 0.5, 0.5, 0.5, 0.25, 0.2])
    # chargers of Buildings 1, 4, 5, 7, 10, 12, 15, 15 (0-based building indices)
    assert section.chargers.names == ("charger_1_1", "charger_4_1", "charger_5_1", "charger_7_1", "charger_10_1",
                                      "charger_12_1", "charger_15_1", "charger_15_2")
    np.testing.assert_array_equal(section.chargers.building, [0, 3, 4, 6, 9, 11, 14, 14])
    np.testing.assert_allclose(section.chargers.min_discharging_power, [0, 3.7, 0, 0, 0, 0, 0, 0])
    assert section.data.state.shape == (8, 8760)
    assert section.data.ev[0, 0] == 6  # charger_1_1 serves Electric_Vehicle_7


# ------------------------------------------------------------------------------------------ washing machines
def test_washing_machine_cycle_starts_once_per_window_and_books_its_profile():
    # window rows: steps 1..3 -> window (1, 3); step 4 -> none; profile [3.647, 6.698] kWh
    start = np.array([[-1, 1, 1, 1, -1]])
    end = np.array([[-1, 3, 3, 3, -1]])
    running = np.array([False])
    has = np.array([True])
    assert not cycle_starts(np.array([1.0]), running, start[:, 0], end[:, 0], has, 0).any()  # no window at t0
    assert not cycle_starts(np.array([0.0]), running, start[:, 1], end[:, 1], has, 1).any()  # no request
    started = cycle_starts(np.array([0.3]), running, start[:, 2], end[:, 2], has, 2)
    assert started.all()
    load = add_cycle_load(np.zeros((1, 5)), started, [(3.647, 6.698)], 2)
    np.testing.assert_allclose(load, [[0, 0, 3.647, 6.698, 0]])
    running = running | started
    assert not cycle_starts(np.array([1.0]), running, start[:, 3], end[:, 3], has, 3).any()  # once per window
    assert not window_changed(start, end, 3).any() and window_changed(start, end, 4).all()
    # a profile longer than the episode is cut at the end: 3 values from t = 3 into 5 steps
    np.testing.assert_allclose(add_cycle_load(np.zeros((1, 5)), started, [(1.0, 2.0, 4.0)], 3), [[0, 0, 0, 1, 2]])


def test_read_washing_machine_table(tmp_path):
    path = tmp_path / "wm.csv"
    path.write_text('day_type,hour,wm_start_time_step,wm_end_time_step,load_profile\n7,24,-1,-1,-1\n'
                    '1,1,1,3,[3.157]\n2,5,29,31,"[3.647, 6.698]"\n')
    t = read_washing_machine_table(path, 3)
    np.testing.assert_array_equal(t.start, [-1, 1, 29])
    np.testing.assert_array_equal(t.end, [-1, 3, 31])
    assert t.profile == ((), (3.157,), (3.647, 6.698))
    path.write_text('day_type,hour,wm_start_time_step,wm_end_time_step,load_profile\n1,1,1,3,"[3.1, x]"\n')
    with pytest.raises(SchemaError, match=r"'load_profile', row 0 \(file line 2\)"):
        read_washing_machine_table(path, 1)


def test_real_washing_machine_file():
    need_shared(EV_DATASET)
    schema = json.loads((EV_DATASET / "schema.json").read_text())
    machines = parse_washing_machines(schema, EV_DATASET)
    # Washing_Machine_1.csv file line 31 (row 29): "2,5,29,31,[3.647, 6.698]"; Building_1 owns it
    assert machines.names == ("washing_machine_1",) and machines.building.tolist() == [0]
    assert (machines.start[0, 29], machines.end[0, 29], machines.profile[0][29]) == (29, 31, (3.647, 6.698))
    assert machines.start.shape == (1, 8760)


# ------------------------------------------------------------------------------------------ upstream parity
def test_ev_year_replays_upstream_2_5_0_run():
    """Replay the reference run of benchmarks/ev_upstream.py (CityLearn 2.5.0, seeded action table, recorded
    drift draws) with these functions: every EV's SOC and every charger's consumption over 8,759 steps."""
    if not REFERENCE.exists():
        pytest.skip(f"{REFERENCE} absent: run benchmarks/ev_upstream.py --only ev")
    need_shared(EV_DATASET)
    ref = json.loads(REFERENCE.read_text())
    schema = json.loads((EV_DATASET / "schema.json").read_text())
    section = parse_ev_section(schema, EV_DATASET, initial_soc_draws=[
        ref["ev_battery"][name]["initial_soc"] for name in schema["electric_vehicles_def"]])
    steps, n_ev = ref["time_steps"], len(section.vehicles.names)
    table = np.random.default_rng(ref["seed"]).uniform(ref["action_low"], ref["action_high"],
                                                       size=(steps, len(ref["action_names"])))
    actions = table[:, [ref["action_names"].index(f"electric_vehicle_storage_{c}") for c in section.chargers.names]]
    battery = section.vehicles.battery
    soc = np.zeros((n_ev, steps), dtype=np.float32)  # upstream stores SOC as float32, 0 until written
    efficiency, capacity = battery.efficiency.copy(), battery.capacity.copy()
    consumption = np.zeros((len(section.chargers.names), steps - 1))
    soc[:, 0] = advance_soc(battery.initial_soc, battery.initial_soc, section.data, 0, draw=None)
    for t in range(steps - 1):
        before = soc[:, max(t - 1, 0)].astype(np.float64)
        new, efficiency, capacity, consumption[:, t], stepped = charge_plugged_evs(
            actions[t], before, efficiency, capacity, section.data, t, section.chargers, section.vehicles,
            efficiency_from_request=True)
        soc[stepped, t] = new[stepped]
        draws = iter(ref["drift_normal_draws_per_step_call"][t])
        soc[:, t + 1] = advance_soc(soc[:, t].astype(np.float64), soc[:, t + 1], section.data, t + 1,
                                    draw=lambda k, it=draws: [next(it) for _ in range(k)])
    for v, name in enumerate(section.vehicles.names):
        np.testing.assert_allclose(soc[v], ref["ev_soc"][name], atol=1e-6, err_msg=name)
    for c, name in enumerate(section.chargers.names):
        np.testing.assert_allclose(consumption[c], ref["charger_electricity_consumption"][name][:steps - 1],
                                   atol=1e-5, err_msg=name)


def test_battery_efficiency_read_at_the_request_in_citylearn_2_5():
    """A 60 kWh / 50 kW battery at 95 % asked for 10 kWh is held to 3 kWh: the efficiency curve (0.8 at 0, 1.0 at
    full power) is read at 3 / 50 = 0.06 (0.812) by default, at min(10, 50) / 50 = 0.2 (0.84) in 2.5."""
    battery = BatteryParams(capacity=np.array([60.0]), nominal_power=np.array([50.0]), efficiency=np.array([0.9]),
                            loss_coefficient=np.zeros(1), capacity_loss_coefficient=np.zeros(1),
                            depth_of_discharge=np.ones(1), initial_soc=np.array([0.95]),
                            power_efficiency=Curve.from_points([((0.0, 0.8), (1.0, 1.0))]),
                            capacity_power=Curve.from_points([((0.0, 1.0), (1.0, 1.0))]))
    args = (np.array([10.0]), np.array([0.95]), np.zeros(1), battery, np.array([0.9]), np.array([60.0]))
    soc, _, efficiency, _ = battery_charge(*args)
    # 3 kWh in, stored 3 * sqrt(efficiency): 57 + 3 * 0.9011 kWh of 60
    assert efficiency[0] == pytest.approx(0.812) and soc[0] == pytest.approx(0.95 + 3 * 0.812**0.5 / 60)
    soc, _, efficiency, _ = battery_charge(*args, efficiency_from_request=True)
    assert efficiency[0] == pytest.approx(0.84) and soc[0] == pytest.approx(0.95 + 3 * 0.84**0.5 / 60)
