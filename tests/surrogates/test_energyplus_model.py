"""EULP metadata parsing and the epJSON house geometry (no engine runs)."""

from __future__ import annotations

import math

import pytest

from pipeline.errors import InputError
from surrogates.energyplus.house import build_house_model, footprint
from surrogates.energyplus.metadata import (
    house_parameters_from_metadata,
    parse_ach50,
    parse_floor_area_bin,
    parse_orientation,
    parse_r_value,
    parse_setpoint,
    parse_vintage,
    parse_window_to_wall,
)

GROUND = [20.0] * 12


def test_parsers_read_resstock_encodings():
    assert parse_r_value("R-30") == 30.0
    assert parse_r_value("Wood Stud, R-11") == 11.0
    assert parse_r_value("2ft R10 Under, Horizontal") == 10.0
    assert parse_r_value("Wood Stud, Uninsulated") == 0.0
    assert parse_ach50("7 ACH50") == 7.0
    assert parse_vintage("1980s") == 1980 and parse_vintage("<1940") == 1930
    assert parse_orientation("Northwest") == 315.0 and parse_orientation("South") == 180.0
    assert parse_setpoint("76F") == pytest.approx((76 - 32) / 1.8)
    assert parse_setpoint("24C") == 24.0
    assert parse_floor_area_bin("1500-1999") == 1750.0
    assert parse_window_to_wall("F18 B12 L12 R12") == pytest.approx(0.135)


def test_metadata_row_to_si_parameters():
    row = {"bldg_id": 7, "in.sqft": 2000, "in.geometry_stories": "2", "in.vintage": "2000s",
           "in.insulation_wall": "Wood Stud, R-13", "in.insulation_ceiling": "R-38",
           "in.infiltration": "10 ACH50", "in.orientation": "East", "in.occupants": "4",
           "in.cooling_setpoint": "77F", "in.heating_setpoint": "68F"}
    house = house_parameters_from_metadata(row)
    assert house.floor_area_m2 == pytest.approx(2000 * 0.09290304)
    assert house.wall_r_si == pytest.approx(13 * 0.1761102)
    assert house.ceiling_r_si == pytest.approx(38 * 0.1761102)
    assert house.ach_natural == pytest.approx(0.5)  # 10 ACH50 / 20
    assert house.cooling_setpoint_c == pytest.approx(25.0) and house.heating_setpoint_c == pytest.approx(20.0)
    assert (house.stories, house.occupants, house.front_azimuth_deg) == (2, 4.0, 90.0)


def test_bad_metadata_names_column_and_building():
    with pytest.raises(InputError, match=r"in\.infiltration.*bldg_id=5"):
        house_parameters_from_metadata({"bldg_id": 5, "in.sqft": 1500, "in.infiltration": "leaky"},
                                       source="m.csv")
    with pytest.raises(InputError, match=r"in\.sqft"):
        house_parameters_from_metadata({"bldg_id": 5})


def _polygon_area(vertices):
    # Newell's method: |sum of cross products| / 2 for a planar polygon
    nx = ny = nz = 0.0
    points = [(v["vertex_x_coordinate"], v["vertex_y_coordinate"], v["vertex_z_coordinate"])
              for v in vertices]
    for (x1, y1, z1), (x2, y2, z2) in zip(points, points[1:] + points[:1], strict=True):
        nx += (y1 - y2) * (z1 + z2)
        ny += (z1 - z2) * (x1 + x2)
        nz += (x1 - x2) * (y1 + y2)
    return 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)


def test_geometry_matches_floor_area_and_window_ratio():
    house = house_parameters_from_metadata({"bldg_id": 1, "in.sqft": 2400, "in.geometry_stories": "2",
                                            "in.window_areas": "F20 B20 L20 R20"})
    model = build_house_model(house, mode="ideal", ground_temperatures_c=GROUND)
    surfaces = model["BuildingSurface:Detailed"]
    floors = sum(_polygon_area(s["vertices"]) for s in surfaces.values() if s["surface_type"] == "Floor")
    assert floors == pytest.approx(2400 * 0.09290304, rel=1e-4)
    walls = sum(_polygon_area(s["vertices"]) for s in surfaces.values() if s["surface_type"] == "Wall")
    windows = 0.0
    for w in model["FenestrationSurface:Detailed"].values():
        a = [w[f"vertex_{i}_{c}_coordinate"] for i in (1, 3) for c in "xyz"]
        windows += math.hypot(a[3] - a[0], a[4] - a[1]) * abs(a[5] - a[2])
    assert windows / walls == pytest.approx(0.20, rel=1e-3)
    width, depth = footprint(house)
    assert width / depth == pytest.approx(1.5)
    # interzone surfaces point at each other
    assert surfaces["story_2_floor"]["outside_boundary_condition_object"] == "story_1_ceiling"
    assert surfaces["story_1_ceiling"]["outside_boundary_condition_object"] == "story_2_floor"


def test_replay_model_puts_sign_in_design_level():
    house = house_parameters_from_metadata({"bldg_id": 1, "in.sqft": 1500})
    model = build_house_model(house, mode="replay", ground_temperatures_c=GROUND, load_file="/tmp/x.csv")
    equipment = model["OtherEquipment"]
    assert equipment["story_1 ILV cool"]["design_level"] == -1.0
    assert equipment["story_1 ILV heat"]["design_level"] == 1.0
    assert "ZoneHVAC:IdealLoadsAirSystem" not in model and "ZoneControl:Thermostat" not in model


def _compact_value(fields: list[dict], month: int, day: int, weekend: bool, hour: int) -> float:
    """Read a ``Schedule:Compact``'s value at a standard-time hour (0 = 00:00-01:00) of a day."""
    through, day_type, until, found = None, None, 0, {}
    for item in (f["field"] for f in fields):
        if isinstance(item, str) and item.startswith("Through:"):
            m, d = map(int, item.split(":")[1].strip().split("/"))
            through = (m, d)
        elif isinstance(item, str) and item.startswith("For:"):
            day_type, until = ("Weekends" in item), 0
        elif isinstance(item, str) and item.startswith("Until:"):
            until = int(item.split(":")[1])
        else:
            found.setdefault((through, day_type), []).append((until, float(item)))
    period = min(t for t, w in found if t >= (month, day) and w == weekend)
    return next(v for end, v in found[(period, weekend)] if hour < end)


def test_set_point_offsets_keep_the_households_clock():
    from surrogates.energyplus.metadata import HouseParameters
    from surrogates.energyplus.setpoints import OffsetPeriod

    house = HouseParameters(bldg_id=1, floor_area_m2=150.0, cooling_setpoint_c=24.0, heating_setpoint_c=20.0,
                            offsets_k=(2.0, 0.0), offset_periods=(OffsetPeriod(night_sign=-1), OffsetPeriod()))
    summer = build_house_model(house, mode="ideal", ground_temperatures_c=GROUND, year=2018,
                               clock_zone="America/Chicago")
    winter = build_house_model(house, mode="ideal", ground_temperatures_c=GROUND, year=2018)
    cooling = summer["Schedule:Compact"]["cooling_setpoint"]["data"]
    # the night setback starts at 22:00 on the clock: 21:00 standard time from 11 March to 3 November 2018
    assert _compact_value(cooling, 7, 2, False, 21) == pytest.approx(22.0)
    assert _compact_value(cooling, 7, 2, False, 20) == pytest.approx(24.0)
    assert _compact_value(cooling, 7, 2, False, 6) == pytest.approx(24.0)  # 07:00 on the clock: over
    assert _compact_value(cooling, 3, 10, False, 21) == pytest.approx(24.0)
    assert _compact_value(cooling, 3, 11, True, 21) == pytest.approx(22.0)
    assert _compact_value(cooling, 11, 4, True, 21) == pytest.approx(24.0)
    assert _compact_value(cooling, 1, 8, False, 22) == pytest.approx(22.0)
    without = winter["Schedule:Compact"]["cooling_setpoint"]["data"]
    assert [f["field"] for f in without if str(f["field"]).startswith("Through")] == ["Through: 12/31"]
    assert _compact_value(without, 7, 2, False, 21) == pytest.approx(24.0)
    assert _compact_value(without, 7, 2, False, 22) == pytest.approx(22.0)
