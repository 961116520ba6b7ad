"""The envelope mapping from ResStock characteristics (issue 27): the roof assembly's insulation, the windows'
U-factor and SHGC, and the ground temperature under the slab (no engine runs)."""

from __future__ import annotations

from pathlib import Path

import pytest

from surrogates.energyplus.epw import read_epw_ground_temperatures, read_epw_latitude
from surrogates.energyplus.metadata import (
    GLAZING,
    R_IP_TO_SI,
    VINTAGE_DEFAULTS,
    house_parameters_from_metadata,
    parse_ceiling_r,
    parse_roof_r,
    parse_window_properties,
)

ROOT = Path(__file__).resolve().parents[2]
BASE = {"bldg_id": 1, "in.sqft": 1698, "in.vintage": "1980s"}


def test_window_options_get_the_u_and_shgc_resstock_defines():
    # Btu/(h ft2 F) x 5.678263 -> W/(m2 K)
    assert parse_window_properties("Double, Clear, Metal, Air") == pytest.approx((0.76 * 5.678263, 0.67))
    assert parse_window_properties("Double, Clear, Non-metal, Air") == pytest.approx((0.49 * 5.678263, 0.56))
    assert parse_window_properties("Single, Clear, Metal") == pytest.approx((1.16 * 5.678263, 0.76))
    assert parse_window_properties("double, low-e, non-metal, air, m-gain") == pytest.approx(
        (0.38 * 5.678263, 0.44))
    # an option outside the table falls back to its glazing class
    assert parse_window_properties("Double, Low-E, Insulated, Argon") == GLAZING["double_low_e"]
    house = house_parameters_from_metadata({**BASE, "in.windows": "Single, Clear, Non-metal"})
    assert (house.window_u, house.window_shgc) == pytest.approx((0.84 * 5.678263, 0.63))


def test_ceiling_none_means_no_attic_floor_not_uninsulated():
    assert parse_ceiling_r("None") is None
    assert parse_ceiling_r("R-30") == 30.0 and parse_ceiling_r("Uninsulated") == 0.0
    assert parse_roof_r("Finished, R-13") == 13.0 and parse_roof_r("Finished, Uninsulated") == 0.0
    assert parse_roof_r("Unfinished, Uninsulated") is None and parse_roof_r("None") is None


@pytest.mark.parametrize(("ceiling", "roof", "r_ip"), [
    ("None", "Finished, R-13", 13.0),              # cathedral ceiling: the roof deck's insulation
    ("R-30", "Unfinished, Uninsulated", 30.0),     # vented attic: the attic floor's insulation
    ("None", "Finished, Uninsulated", 0.0),        # a finished roof without insulation
    (None, None, VINTAGE_DEFAULTS[1980][1]),       # neither given: the vintage default
])
def test_roof_assembly_r_follows_the_characteristics(ceiling, roof, r_ip):
    row = {**BASE, **({"in.insulation_ceiling": ceiling} if ceiling else {}),
           **({"in.insulation_roof": roof} if roof else {})}
    assert house_parameters_from_metadata(row).ceiling_r_si == pytest.approx(r_ip * R_IP_TO_SI)


def test_buildstock_layout_row_reads_the_roof_insulation():
    row = {"building_id": 61, "upgrade_costs.floor_area_conditioned_ft_2": 1698.0,
           "build_existing_model.insulation_ceiling": "None",
           "build_existing_model.insulation_roof": "Finished, R-19"}
    assert house_parameters_from_metadata(row).ceiling_r_si == pytest.approx(19 * R_IP_TO_SI)


def _epw_with_ground(tmp_path: Path, ground_line: str) -> Path:
    header = ["LOCATION,x,TX,USA,s,1,30,-97,-6,100", "DESIGN CONDITIONS,0", "TYPICAL/EXTREME PERIODS,0",
              ground_line, "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0", "COMMENTS 1,", "COMMENTS 2,",
              "DATA PERIODS,1,1,Data,Monday, 1/ 1,12/31"]
    path = tmp_path / "w.epw"
    path.write_text("\n".join(header) + "\n")
    return path


def test_ground_under_the_slab_is_the_deepest_epw_depth(tmp_path):
    shallow = ",".join(str(v) for v in range(1, 13))
    deep = ",".join(str(v + 100) for v in range(1, 13))
    path = _epw_with_ground(tmp_path, f"GROUND TEMPERATURES,2,.5,,,,{shallow},4,,,,{deep}")
    assert read_epw_ground_temperatures(path) == [float(v + 100) for v in range(1, 13)]
    one = _epw_with_ground(tmp_path, f"GROUND TEMPERATURES,1,.5,,,,{shallow}")
    assert read_epw_ground_temperatures(one) == [float(v) for v in range(1, 13)]


def test_travis_county_ground_in_june_is_the_4m_value():
    ground = read_epw_ground_temperatures(ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw")
    assert ground[5] == pytest.approx(22.49)  # 4 m depth; 0.5 m would be 27.71


def test_latitude_is_read_from_the_location_line(tmp_path):
    from citylearn_env.errors import InputError


    epw = tmp_path / "site.epw"
    epw.write_text("LOCATION,Camp Mabry,TX,USA,TMY3,722544,30.32,-97.77,-6.0,198.0\n")
    assert read_epw_latitude(epw) == 30.32
    epw.write_text("LOCATION,Nowhere,XX,XX,TMY3,0,north,0,0,0\n")
    with pytest.raises(InputError, match="LOCATION") as error:
        read_epw_latitude(epw)
    assert "site.epw" in str(error.value)


def test_clock_zone_follows_the_location_lines_country_state_and_offset(tmp_path):
    from citylearn_env.errors import InputError
    from surrogates.energyplus.epw import read_epw_timezone

    epw = tmp_path / "site.epw"
    for line, expected in (("LOCATION,Camp Mabry,TX,USA,TMY3,722544,30.32,-97.77,-6.0,198.0", "America/Chicago"),
                           ("LOCATION,Boston Logan,MA,USA,TMY3,725090,42.37,-71.02,-5.0,6.0", "America/New_York"),
                           ("LOCATION,Phoenix Sky Harbor,AZ,USA,TMY3,722780,33.45,-111.98,-7.0,337.0",
                            "America/Phoenix"),
                           ("LOCATION,Toronto,ON,CAN,CWEC,716240,43.67,-79.63,-5.0,173.0", None)):
        epw.write_text(line + "\n")
        assert read_epw_timezone(epw) == expected, line
    assert read_epw_timezone(ROOT / "raw" / "weather" / "USA_TX_Travis.County_AMY2018.epw") == "America/Chicago"
    epw.write_text("LOCATION,Somewhere,TX,USA,TMY3,0,30.0,-97.0,central,0\n")
    with pytest.raises(InputError, match="time zone") as error:
        read_epw_timezone(epw)
    assert "site.epw" in str(error.value)
    epw.write_text("DESIGN CONDITIONS,0\n")
    with pytest.raises(InputError, match="LOCATION"):
        read_epw_timezone(epw)
