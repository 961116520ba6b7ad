"""What makes the oracle's problem meaningful, checked before HiGHS sees it (issue 50): each check is one
:class:`pipeline.errors.InputError` naming the option or the building, slot and step.

* weights: only their ratios matter (the oracle scales its LP's coefficients, ``oracle.lp_scale``); a weight of
  1e15 or 1e-12 is a slip, not a preference: every weight is at most :data:`WEIGHT_MAX` and the largest at
  least :data:`WEIGHT_MIN`;
* import coefficients (cost weight x price + emissions weight x carbon + consumption weight) >= 0 wherever a
  storage can change the import: max(net, 0) x a negative coefficient is not convex, the LP leaves such steps
  out of its objective and its plan and bound would not be the env's (the environment itself accepts prices
  down to -100 $/kWh, ``citylearn_env.ranges``);
* devices: the env accepts any efficiency above 0 and a standing loss up to 1 per step; the LP divides by the
  one-way efficiency, by the device's heat per kWh of electricity and by the retention, so each must be at
  least :data:`ONE_WAY_MIN`, :data:`DELIVERY_MIN` and :data:`RETENTION_MIN`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pipeline.errors import InputError
from pipeline.optimal import objectives as obj
from pipeline.optimal.plant import Plant

#: the largest weight may be no smaller [objective-units^-1]
WEIGHT_MIN = 1e-6
#: no weight may be larger
WEIGHT_MAX = 1e6
#: smallest one-way efficiency sqrt(round trip) [-] (round trip 1e-6)
ONE_WAY_MIN = 1e-3
#: smallest heat delivered per kWh of electricity by a tank's heater or heat pump (1 / electricity) [-]
DELIVERY_MIN = 1e-3
UNITS = {"cost": "$", "emissions": "kg", "consumption": "kWh", "average_daily_peak": "kW"}
#: smallest retention per step (1 - loss_coefficient) [-]
RETENTION_MIN = 1e-3


def check_weights(weights: Mapping[str, float]) -> None:
    """Refuse weights outside the stated range (see the module docstring)."""
    used = {k: w for k, w in weights.items() if w}
    high = max(used.values(), default=0.0)
    if high > WEIGHT_MAX or high < WEIGHT_MIN:
        raise InputError(f"objective weights must be at most {WEIGHT_MAX:g} with the largest at least "
                         f"{WEIGHT_MIN:g} (only their ratios matter: scale them), got {used}", column="objective")


def check_baseline(weights: Mapping[str, float], baseline: Mapping[str, float]) -> None:
    """Refuse to normalise by a no-control value that is not > 0 (a negative one flips the objective's sign)."""
    for k, w in weights.items():
        if w and not (np.isfinite(baseline[k]) and baseline[k] > 0):
            raise InputError(f"--normalise divides each weight by its objective's no-control value, which must be "
                             f"> 0: {k} is {baseline[k]:.6g} {UNITS[k]} over this period (negative prices?); weigh the "
                             "objectives without --normalise", column="--normalise")


def check_prices(plant: Plant, weights: Mapping[str, float]) -> None:
    """Refuse a negative import coefficient at a controlled step of a building with a storage, naming the
    building, the episode step and its price and carbon intensity."""
    coefficient = obj.import_coefficients(weights, plant.price, plant.carbon)
    owners = np.zeros(len(plant.building_names), dtype=bool)
    owners[[s.building for s in plant.storages]] = True
    bad = owners[:, None] & (coefficient < 0) & ~plant.outage
    bad[:, 0] = False  # step 0 is not controlled: a constant
    if bad.any():
        b, t = (int(i[0]) for i in np.nonzero(bad))
        raise InputError(f"the import of a building with storage is weighed {coefficient[b, t]:.6g} per kWh here "
                         f"(price {plant.price[b, t]:g} $/kWh, carbon {plant.carbon[b, t]:g} kg/kWh): the oracle "
                         "needs cost x price + emissions x carbon + consumption >= 0 (max(net, 0) x a negative "
                         "price is not convex); the environment runs such prices, optimal does not",
                         file=plant.building_names[b], column="electricity_pricing", row=f"episode step {t}")


def check_devices(plant: Plant) -> None:
    """Refuse a storage whose efficiencies or retention the LP cannot divide by (see the module docstring)."""
    for s in plant.storages:
        where = {"file": plant.building_names[s.building], "column": s.slot}
        one_way = [s.one_way]
        if s.battery is not None:
            one_way += [s.battery.one_way_prev, np.sqrt(np.asarray(s.battery.efficiency.ys, dtype=float))]
        lowest = min(float(np.min(x)) for x in one_way if np.size(x))
        if not lowest >= ONE_WAY_MIN:
            raise InputError(f"a round-trip efficiency of {lowest ** 2:.3g} (efficiency or its curve): the oracle "
                             f"needs at least {ONE_WAY_MIN ** 2:g} (the environment accepts > 0)", **where)
        worst = float(np.max(s.electricity)) if s.electricity.size else 0.0
        if not worst <= 1.0 / DELIVERY_MIN:
            raise InputError(f"its heater or heat pump delivers {1.0 / worst:.3g} kWh of heat per kWh of "
                             f"electricity: the oracle needs at least {DELIVERY_MIN:g} (efficiency)", **where)
        if not s.retention >= RETENTION_MIN:
            raise InputError(f"a standing loss of {1.0 - s.retention:.6g} per step leaves nothing to store: the "
                             f"oracle needs loss_coefficient <= {1.0 - RETENTION_MIN:g}", **where)
