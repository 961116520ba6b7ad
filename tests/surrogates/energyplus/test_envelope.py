"""Heat-loss coefficients of the house model and of a stock row's Manual J design loads (no ../shared needed)."""

import math

import pytest

from surrogates.energyplus.envelope import (
    AIR_DENSITY,
    AIR_SPECIFIC_HEAT,
    BTU_H_PER_W,
    ROOF_FILMS_M2K_W,
    WALL_FILMS_M2K_W,
    house_heat_loss,
    stock_heat_loss,
)
from surrogates.energyplus.house import EMPTY_CAVITY_R_SI
from surrogates.energyplus.metadata import HouseParameters


def test_house_heat_loss_by_hand():
    # a 100 m2 one-story square-ish box: footprint width = sqrt(100 * 1.5), depth = 100 / width
    house = HouseParameters(bldg_id=1, floor_area_m2=100.0, stories=1, window_to_wall=0.2, window_u=3.0,
                            wall_r_si=2.0, ceiling_r_si=5.0, ach50=10.0)
    width = math.sqrt(150.0)
    depth = 100.0 / width
    gross = 2 * (width + depth) * 2.44
    # the wall: siding 0.02 m at 0.7 W/mK, insulation 2.0 + 0.15 of sheathing, gypsum 12.7 mm at 0.16 W/mK
    wall_r = 0.02 / 0.7 + 2.15 + 0.0127 / 0.16 + WALL_FILMS_M2K_W
    roof_r = 0.012 / 0.16 + 0.0159 / 0.12 + 5.1 + 0.0127 / 0.16 + ROOF_FILMS_M2K_W
    loss = house_heat_loss(house)
    assert loss.walls == pytest.approx(0.8 * gross / wall_r, rel=1e-9)
    assert loss.windows == pytest.approx(0.2 * gross * 3.0, rel=1e-9)
    assert loss.roof == pytest.approx(100.0 / roof_r, rel=1e-9)
    # ACH50 / 20 = 0.5 air changes per hour of 244 m3
    assert loss.infiltration == pytest.approx(AIR_DENSITY * AIR_SPECIFIC_HEAT * 0.5 * 244.0 / 3600.0, rel=1e-9)
    assert loss.total == pytest.approx(loss.walls + loss.windows + loss.roof + loss.infiltration)


def test_uninsulated_wall_keeps_its_air_space():
    bare = house_heat_loss(HouseParameters(bldg_id=1, floor_area_m2=100.0, wall_r_si=0.0))
    thin = house_heat_loss(HouseParameters(bldg_id=1, floor_area_m2=100.0, wall_r_si=EMPTY_CAVITY_R_SI))
    assert bare.walls == pytest.approx(thin.walls)
    insulated = house_heat_loss(HouseParameters(bldg_id=1, floor_area_m2=100.0, wall_r_si=1.0))
    assert insulated.walls < bare.walls / 2


def test_stock_heat_loss_divides_by_the_design_difference():
    # 30 F design: 40 F = 22.2 K below Manual J's 70 F indoor; 3412 Btu/h = 1 kW
    loads = {"walls": 3412.142 * 2, "doors": 3412.142, "windows": 3412.142, "ceilings": 1000.0,
             "roofs": 2412.142, "infiltration": 3412.142 * 4}
    loss = stock_heat_loss(loads, 30.0)
    delta = 40.0 * 5 / 9
    assert loss.walls == pytest.approx(3000.0 / delta, rel=1e-6)
    assert loss.windows == pytest.approx(1000.0 / delta, rel=1e-6)
    assert loss.roof == pytest.approx(1000.0 / delta, rel=1e-6)
    assert loss.infiltration == pytest.approx(4000.0 / delta, rel=1e-6)
    assert BTU_H_PER_W == pytest.approx(3.412, abs=1e-3)


def test_stock_heat_loss_refuses_a_warm_design_temperature():
    with pytest.raises(ValueError, match="72"):
        stock_heat_loss({"walls": 1000.0}, 72.0)


def test_slab_boundary_is_the_annual_mean_of_the_ground():
    from surrogates.energyplus.house import build_house_model, slab_boundary_c

    monthly = [10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0]
    assert slab_boundary_c(monthly) == [21.0] * 12
    model = build_house_model(HouseParameters(bldg_id=1, floor_area_m2=100.0), mode="ideal",
                              ground_temperatures_c=monthly, run_period=((1, 1), (1, 2)))
    ground = model["Site:GroundTemperature:BuildingSurface"]["Site:GroundTemperature:BuildingSurface 1"]
    assert ground["january_ground_temperature"] == ground["july_ground_temperature"] == 21.0
