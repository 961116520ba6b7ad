"""Key performance indicators of a recorded episode (CityLearn 2.1 ``evaluate``, the 2023 challenge score, and
the SimBuild paper's five objectives), computed from arrays after the episode, outside the step loop.

Every function takes ``series``: a mapping from CityLearn's building property names (the golden trace column
names: ``net_electricity_consumption``, ``..._without_storage_and_partial_load``, ``indoor_dry_bulb_temperature``,
``occupant_count``, ``power_outage``, ``energy_from_cooling_device``, ...) to arrays of shape (B, T): B buildings,
T time steps. Energies are kWh per step, cost $ per step, emissions kg per step, temperatures degC.

The table functions take ``settings`` (:class:`~citylearn_env.settings.Behaviour`); each CityLearn 2.1 quirk is
one field: ``kpi_plain_division`` (IEEE division that can give inf/NaN), ``kpi_discomfort_over_all_steps``
(delta statistics over all steps, unoccupied ones as zeros), ``kpi_baseline_from_first_building`` (the first
building decides the evaluation condition of all), ``kpi_float32_score`` (challenge score summed in float32).
:data:`~citylearn_env.settings.CITYLEARN_2_1` reproduces CityLearn 2.1 number for number; the default
:data:`~citylearn_env.settings.CORRECTED` applies the corrections listed in docs/environment_kpis.md. The
primitives take one keyword named after the quirk they implement (``plain``, ``plain_division``,
``over_all_steps``).
pandas is imported only inside the functions that build DataFrames.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from citylearn_env.errors import SchemaError
from citylearn_env.settings import CORRECTED, Behaviour

if TYPE_CHECKING:  # pandas is imported where a table is built (importing citylearn_env stays light)
    import pandas as pd

NET = "net_electricity_consumption"
DAY_STEPS, MONTH_STEPS, YEAR_STEPS = 24, 730, 8760
#: baseline suffix of a building without / with LSTM temperature dynamics (CityLearn's default conditions)
BASELINE = {False: "_without_storage", True: "_without_storage_and_partial_load"}
#: the 2023 challenge: KPI -> (display name, weight); all district values of ``evaluate`` at comfort band 1.0
CHALLENGE_WEIGHTS = {
    "carbon_emissions_total": ("Carbon emissions", 0.10),
    "discomfort_proportion": ("Unmet hours", 0.30),
    "ramping_average": ("Ramping", 0.075),
    "daily_one_minus_load_factor_average": ("Load factor", 0.075),
    "daily_peak_average": ("Daily peak", 0.075),
    "annual_peak_average": ("All-time peak", 0.075),
    "one_minus_thermal_resilience_proportion": ("Thermal resilience", 0.15),
    "power_outage_normalized_unserved_energy_total": ("Unserved energy", 0.15),
}
#: CityLearn 2.5's building KPIs in its order (``settings.kpi_names_2_5``); its district table adds
#: :data:`DISTRICT_KPIS_2_5` and the building means
BUILDING_KPIS_2_5 = (
    "electricity_consumption_total", "zero_net_energy", "carbon_emissions_total", "cost_total",
    "discomfort_proportion", "discomfort_cold_proportion", "discomfort_hot_proportion",
    "discomfort_cold_delta_minimum", "discomfort_cold_delta_maximum", "discomfort_cold_delta_average",
    "discomfort_hot_delta_minimum", "discomfort_hot_delta_maximum", "discomfort_hot_delta_average",
    "one_minus_thermal_resilience_proportion", "power_outage_normalized_unserved_energy_total",
    "annual_normalized_unserved_energy_total")
DISTRICT_KPIS_2_5 = ("ramping_average", "daily_one_minus_load_factor_average",
                     "monthly_one_minus_load_factor_average", "daily_peak_average", "all_time_peak_average")
#: the 2.1 name of a KPI under the 2.5 name of the same quantity
NAMES_2_1 = {"all_time_peak_average": "annual_peak_average"}
COOLING_SET_POINT = "indoor_dry_bulb_temperature_cooling_set_point"
HEATING_SET_POINT = "indoor_dry_bulb_temperature_heating_set_point"
DELIVERED = ("energy_from_cooling_device", "energy_from_cooling_storage", "energy_from_heating_device",
             "energy_from_heating_storage", "energy_from_dhw_device", "energy_from_dhw_storage",
             "energy_to_non_shiftable_load")
DEMANDS = ("cooling_demand", "heating_demand", "dhw_demand", "non_shiftable_load")


# ---------------------------------------------------------------------------------------------- primitives
def divide(numerator: float, denominator: float, *, plain: bool = False) -> float:
    """``numerator / denominator``. ``plain``: IEEE division (x/0 = +-inf, 0/0 = NaN; CityLearn 2.1);
    otherwise 0/0 = 1.0 (both sides agree there is nothing), x/0 = NaN, and any non-finite input gives NaN."""
    numerator, denominator = float(numerator), float(denominator)
    if plain:
        with np.errstate(divide="ignore", invalid="ignore"):
            return float(np.float64(numerator) / np.float64(denominator))
    if not (np.isfinite(numerator) and np.isfinite(denominator)):
        return float("nan")
    if denominator == 0.0:
        return 1.0 if numerator == 0.0 else float("nan")
    return numerator / denominator


def _blocks(values: np.ndarray, window: int) -> list[np.ndarray]:
    """Consecutive blocks of ``window`` steps from the first step (the last block may be shorter)."""
    return [values[i:i + window] for i in range(0, len(values), window)]


def ramping(net: np.ndarray) -> float:
    """Sum of absolute step-to-step changes of ``net`` (kWh per step)."""
    return float(np.abs(np.diff(np.asarray(net, dtype=float))).sum())


def one_minus_load_factor(net: np.ndarray, window: int, *, plain_division: bool = False) -> float:
    """Mean over ``window``-step blocks (from the first step; the last may be shorter) of 1 - mean/max of
    ``net`` (dimensionless). A block with max 0 is NaN and skipped (NaN when every block is); with
    ``plain_division`` (CityLearn 2.1) it is divided anyway and its inf/NaN enters the plain mean."""
    values = []
    for block in _blocks(np.asarray(net, dtype=float), window):
        values.append(1.0 - divide(block.mean(), block.max(), plain=True) if plain_division or block.max() != 0
                      else np.nan)
    values = np.array(values)
    if plain_division:
        return float(values.mean())
    return float(np.nanmean(values)) if np.isfinite(values).any() else float("nan")


def peak(net: np.ndarray, window: int) -> float:
    """Mean over ``window``-step blocks of the block maximum of ``net`` (kWh per step)."""
    return float(np.mean([block.max() for block in _blocks(np.asarray(net, dtype=float), window)]))


def positive_sum(values: np.ndarray) -> float:
    """Sum of the positive part (grid import kWh, emission kg, cost $; exports earn nothing)."""
    return float(np.clip(np.asarray(values, dtype=float), 0.0, None).sum())


def band_delta(temperature: np.ndarray, heating_set_point: np.ndarray, cooling_set_point: np.ndarray) -> np.ndarray:
    """Signed distance of the indoor temperature from the comfort band [heating set point, cooling set point]
    (degC): T - S_heating below the band (negative), T - S_cooling above it (positive), 0 inside. Edges given in
    the wrong order are swapped. With one set point S for both edges it is T - S."""
    temperature = np.asarray(temperature, dtype=float)
    heating, cooling = np.asarray(heating_set_point, dtype=float), np.asarray(cooling_set_point, dtype=float)
    low, high = np.minimum(heating, cooling), np.maximum(heating, cooling)
    return temperature - np.clip(temperature, low, high)


def discomfort(temperature: np.ndarray, set_point: np.ndarray, band: float, occupants: np.ndarray, *,
               over_all_steps: bool = False, cooling_set_point: np.ndarray | None = None) -> dict[str, float]:
    """Comfort statistics of one building: proportions of occupied steps with |D| > band (too cold: D < -band,
    too hot: D > band), and min/max/mean of D (degC), D = :func:`band_delta` of the band [``set_point``,
    ``cooling_set_point``]; without ``cooling_set_point`` the band is the one set point S and D = T - S
    (CityLearn 2.1).

    ``over_all_steps`` (CityLearn 2.1): deltas are zeroed on unoccupied steps and the min/max/mean run over all
    steps; otherwise they run over occupied steps only (NaN when none). Proportions are over occupied steps
    either way (NaN with no occupied step).
    """
    occupied = np.asarray(occupants, dtype=float) > 0.0
    delta = band_delta(temperature, set_point, set_point if cooling_set_point is None else cooling_set_point)
    delta = np.where(np.asarray(occupants, dtype=float) == 0.0, 0.0, delta)
    n = int(occupied.sum())
    cold, hot = int((delta < -band).sum()), int((delta > band).sum())
    stats = delta if over_all_steps else delta[occupied]
    empty = stats.size == 0
    return {
        "discomfort_proportion": _share(cold + hot, n),
        "discomfort_too_cold_proportion": _share(cold, n),
        "discomfort_too_hot_proportion": _share(hot, n),
        "discomfort_delta_minimum": float("nan") if empty else float(stats.min()),
        "discomfort_delta_maximum": float("nan") if empty else float(stats.max()),
        "discomfort_delta_average": float("nan") if empty else float(stats.mean()),
    }


def discomfort_2_5(temperature: np.ndarray, cooling_set_point: np.ndarray, heating_set_point: np.ndarray,
                   band: float, occupants: np.ndarray) -> dict[str, float]:
    """CityLearn 2.5's comfort statistics of one building (degC, proportions dimensionless): too hot where
    T - S_cooling > band, too cold where T - S_heating < -band, both deltas 0 on unoccupied steps; proportions
    over the occupied steps (NaN with none); the cold deltas' minimum / maximum / average are those of
    |min(T - S_heating, 0)| over every step, the hot ones of max(T - S_cooling, 0)."""
    occupied = np.asarray(occupants, dtype=float)
    temperature = np.asarray(temperature, dtype=float)
    hot_delta = np.where(occupied == 0.0, 0.0, temperature - np.asarray(cooling_set_point, dtype=float))
    cold_delta = np.where(occupied == 0.0, 0.0, temperature - np.asarray(heating_set_point, dtype=float))
    n = int((occupied > 0.0).sum())
    hot, cold = hot_delta > band, cold_delta < -band
    cold_size, hot_size = np.abs(np.minimum(cold_delta, 0.0)), np.maximum(hot_delta, 0.0)
    out = {"discomfort_proportion": _share(int((hot | cold).sum()), n),
           "discomfort_cold_proportion": _share(int(cold.sum()), n),
           "discomfort_hot_proportion": _share(int(hot.sum()), n)}
    for side, size in (("cold", cold_size), ("hot", hot_size)):
        out |= {f"discomfort_{side}_delta_minimum": float(size.min()), f"discomfort_{side}_delta_maximum":
                float(size.max()), f"discomfort_{side}_delta_average": float(size.mean())}
    return out


def divide_2_5(numerator: float, denominator: float) -> float:
    """CityLearn 2.5's KPI ratio: a part that is not a finite number reads as 0; x/0 is NaN, 0/0 is 1."""
    numerator = float(numerator) if np.isfinite(numerator) else 0.0
    denominator = float(denominator) if np.isfinite(denominator) else 0.0
    if denominator == 0.0:
        return 1.0 if numerator == 0.0 else float("nan")
    return numerator / denominator


def ramping_up(net: np.ndarray) -> float:
    """Sum of the step-to-step increases of ``net`` (kWh per step; decreases count 0, CityLearn 2.5)."""
    return float(np.clip(np.diff(np.asarray(net, dtype=float)), 0.0, None).sum())


def _share(count: int, total: int) -> float:
    return count / total if total else float("nan")


def normalized_unserved_energy(expected: np.ndarray, served: np.ndarray, outage: np.ndarray | None = None, *,
                               plain_division: bool = False) -> float:
    """Sum of (expected - served) over outage steps / sum of expected over outage steps (all steps when
    ``outage`` is None); energies in kWh, result dimensionless. NaN when there is no such step, 0 when nothing
    was expected nor unserved. ``plain_division`` (CityLearn 2.1): the plain IEEE quotient whatever the mask
    (0/0 = NaN, x/0 = inf)."""
    expected, served = np.asarray(expected, dtype=float), np.asarray(served, dtype=float)
    mask = np.ones(expected.shape, bool) if outage is None else np.asarray(outage, dtype=float) != 0.0
    unserved, total = (expected - served)[mask].sum(), expected[mask].sum()
    if plain_division:
        return divide(unserved, total, plain=True)
    if not mask.any():
        return float("nan")
    return 0.0 if total == 0.0 and unserved == 0.0 else divide(unserved, total)


# ---------------------------------------------------------------------------------------------- evaluate
def _prepare(series: Mapping[str, np.ndarray], window: slice | None, n_buildings: int | None = None):
    def get(name: str) -> np.ndarray:
        if name not in series:
            raise SchemaError(f"series {name!r} is missing (have: {', '.join(sorted(series))})", column=name)
        values = np.asarray(series[name], dtype=float)
        if values.ndim != 2 or (n_buildings is not None and values.shape[0] != n_buildings):
            raise SchemaError(f"series {name!r} has shape {values.shape}, expected ({n_buildings}, T)",
                              column=name)
        return values if window is None else values[:, window]
    return get


def comfort_band_edges(series: Mapping[str, np.ndarray], get, *, one_set_point: bool) -> tuple[np.ndarray, np.ndarray]:
    """The comfort band's lower and upper edges per building and step (degC): the heating and the cooling set
    point, or (``one_set_point``, CityLearn 2.1; or a series without the two) the one set point for both."""
    heating, cooling = "indoor_dry_bulb_temperature_heating_set_point", "indoor_dry_bulb_temperature_cooling_set_point"
    if one_set_point or heating not in series or cooling not in series:
        single = get("indoor_dry_bulb_temperature_set_point")
        return single, single
    return get(heating), get(cooling)


def _nanmean(values: Sequence[float]) -> float:
    values = np.array([np.nan if v is None else v for v in values], dtype=float)
    return float(np.nanmean(values)) if (~np.isnan(values)).any() else float("nan")


def evaluate(series: Mapping[str, np.ndarray], building_names: Sequence[str], *, dynamics: Sequence[bool],
             comfort_band: float = 2.0, window: slice | None = None,
             settings: Behaviour = CORRECTED) -> pd.DataFrame:
    """CityLearn's KPI table: a long DataFrame (cost_function, value, name, level).

    Building rows compare each building's control series (with storage, partial load and PV) to its baseline
    (``..._without_storage_and_partial_load`` if ``dynamics[b]``, else ``..._without_storage``); the
    ``District`` rows hold the district KPIs (on district sums) and the mean over buildings (NaN ignored) of
    the building KPIs. Ratios are dimensionless; discomfort deltas in degC. ``settings``: the ``kpi_*`` quirks.
    """

    rows = (building_kpis_2_5 if settings.kpi_names_2_5 else building_kpis)(
        series, building_names, dynamics=dynamics, comfort_band=comfort_band, window=window, settings=settings)
    return kpi_frame(rows, building_names, district_values(series, dynamics=dynamics, window=window,
                                                           settings=settings))


def district_values(series: Mapping[str, np.ndarray], *, dynamics: Sequence[bool], window: slice | None = None,
                    settings: Behaviour = CORRECTED) -> dict[str, float]:
    """The district KPIs of :func:`evaluate`'s table (CityLearn 2.1's or 2.5's names, as ``settings`` say) on
    the district sums of ``series``' net-consumption series; (1, T) sums of building groups give the same."""
    kpis = district_kpis_2_5 if settings.kpi_names_2_5 else district_kpis
    return kpis(series, dynamics=dynamics, window=window, settings=settings)


def kpi_frame(rows: Sequence[Mapping[str, float]], building_names: Sequence[str],
              district: Mapping[str, float]) -> pd.DataFrame:
    """:func:`evaluate`'s long table from its parts: one dict of building KPIs per building (in
    ``building_names`` order) and the district KPIs; a KPI without a district value gets the mean over
    buildings (NaN ignored). Tables of building groups evaluated apart combine here, with the district KPIs
    computed on the groups' summed series."""
    import pandas as pd  # lazy: importing citylearn_env does not import pandas (package docstring)

    names = sorted({k for r in rows for k in r} | set(district))
    district_rows = [{"cost_function": k, "value": district[k] if k in district else _nanmean([r[k] for r in rows]),
                      "name": "District", "level": "district"} for k in names]
    building_rows = [{"cost_function": k, "value": v, "name": name, "level": "building"}
                     for name, r in zip(building_names, rows, strict=True) for k, v in r.items()]
    frame = pd.DataFrame(district_rows + building_rows, columns=["cost_function", "value", "name", "level"])
    frame["value"] = frame["value"].astype(float)
    return frame


def _conditions(dynamics: Sequence[bool], from_first_building: bool) -> list[str]:
    """Baseline suffix per building. ``from_first_building``: CityLearn 2.1 fixes the condition of every
    building on the first building's."""
    dynamics = [bool(d) for d in dynamics]
    return [BASELINE[dynamics[0]] if from_first_building else BASELINE[d] for d in dynamics]


def building_kpis(series: Mapping[str, np.ndarray], building_names: Sequence[str], *, dynamics: Sequence[bool],
                  comfort_band: float = 2.0, window: slice | None = None,
                  settings: Behaviour = CORRECTED) -> list[dict]:
    """One dict of building-level KPIs per building (same order and names as CityLearn 2.1); ``settings``:
    the ``kpi_*`` quirks."""
    n = len(building_names)
    if len(dynamics) != n:
        raise SchemaError(f"dynamics has {len(dynamics)} entries for {n} buildings", column="dynamics")
    get = _prepare(series, window, n)
    out = []
    net, cost, emission = get(NET), get(f"{NET}_cost"), get(f"{NET}_emission")
    pricing, carbon = get("electricity_pricing"), get("carbon_intensity")
    temperature = get("indoor_dry_bulb_temperature")
    heating, cooling = comfort_band_edges(series, get, one_set_point=settings.kpi_discomfort_against_one_set_point)
    occupants, outage = get("occupant_count"), get("power_outage")
    expected = sum(get(k) for k in DEMANDS)
    served = sum(get(k) for k in DELIVERED)
    plain, all_steps = settings.kpi_plain_division, settings.kpi_discomfort_over_all_steps
    for b, suffix in enumerate(_conditions(dynamics, settings.kpi_baseline_from_first_building)):
        base_net, base_cost = get(f"{NET}{suffix}")[b], get(f"{NET}_cost{suffix}")[b]
        base_emission = get(f"{NET}_emission{suffix}")[b]
        comfort = discomfort(temperature[b], heating[b], comfort_band, occupants[b], over_all_steps=all_steps,
                             cooling_set_point=cooling[b])
        resilience = discomfort(temperature[b], heating[b], comfort_band,
                                np.where(outage[b] == 0.0, 0.0, occupants[b]), over_all_steps=all_steps,
                                cooling_set_point=cooling[b])
        kpi = {
            "electricity_consumption_total": divide(positive_sum(net[b]), positive_sum(base_net), plain=plain),
            "zero_net_energy": divide(net[b].sum(), base_net.sum(), plain=plain),
            "carbon_emissions_total": divide(positive_sum(emission[b]), positive_sum(base_emission),
                                             plain=plain) if carbon[b].sum() != 0 else float("nan"),
            "cost_total": divide(positive_sum(cost[b]), positive_sum(base_cost), plain=plain)
            if pricing[b].sum() != 0 else float("nan"),
            **comfort,
            "one_minus_thermal_resilience_proportion": resilience["discomfort_proportion"],
            "power_outage_normalized_unserved_energy_total":
                normalized_unserved_energy(expected[b], served[b], outage[b], plain_division=plain),
            "annual_normalized_unserved_energy_total":
                normalized_unserved_energy(expected[b], served[b], plain_division=plain),
        }
        out.append(kpi)
    return out


def building_kpis_2_5(series: Mapping[str, np.ndarray], building_names: Sequence[str], *,
                      dynamics: Sequence[bool], comfort_band: float = 2.0, window: slice | None = None,
                      settings: Behaviour = CORRECTED) -> list[dict]:
    """One dict of CityLearn 2.5's building KPIs per building (:data:`BUILDING_KPIS_2_5`, its definitions:
    :func:`discomfort_2_5` against the cooling and heating set points, :func:`divide_2_5`, unserved energy by
    plain division); ``settings.kpi_baseline_from_first_building`` as in :func:`building_kpis`."""
    n = len(building_names)
    if len(dynamics) != n:
        raise SchemaError(f"dynamics has {len(dynamics)} entries for {n} buildings", column="dynamics")
    get = _prepare(series, window, n)
    net, cost, emission = get(NET), get(f"{NET}_cost"), get(f"{NET}_emission")
    pricing, carbon = get("electricity_pricing"), get("carbon_intensity")
    temperature, cooling, heating = get("indoor_dry_bulb_temperature"), get(COOLING_SET_POINT), get(HEATING_SET_POINT)
    occupants, outage = get("occupant_count"), get("power_outage")
    expected, served = sum(get(k) for k in DEMANDS), sum(get(k) for k in DELIVERED)
    out = []
    for b, suffix in enumerate(_conditions(dynamics, settings.kpi_baseline_from_first_building)):
        base = {k: get(f"{NET}{k}{suffix}")[b] for k in ("", "_cost", "_emission")}
        comfort = discomfort_2_5(temperature[b], cooling[b], heating[b], comfort_band, occupants[b])
        resilience = discomfort_2_5(temperature[b], cooling[b], heating[b], comfort_band,
                                    np.where(outage[b] == 0.0, 0.0, occupants[b]))
        kpi = {
            "electricity_consumption_total": divide_2_5(positive_sum(net[b]), positive_sum(base[""])),
            "zero_net_energy": divide_2_5(net[b].sum(), base[""].sum()),
            "carbon_emissions_total": divide_2_5(positive_sum(emission[b]), positive_sum(base["_emission"])
                                                 if carbon[b].sum() != 0 else 0.0),
            "cost_total": divide_2_5(positive_sum(cost[b]), positive_sum(base["_cost"]) if pricing[b].sum() != 0
                                     else 0.0),
            **comfort,
            "one_minus_thermal_resilience_proportion": resilience["discomfort_proportion"],
            "power_outage_normalized_unserved_energy_total":
                normalized_unserved_energy(expected[b], served[b], outage[b], plain_division=True),
            "annual_normalized_unserved_energy_total":
                normalized_unserved_energy(expected[b], served[b], plain_division=True),
        }
        out.append({k: kpi[k] for k in BUILDING_KPIS_2_5})
    return out


def district_kpis_2_5(series: Mapping[str, np.ndarray], *, dynamics: Sequence[bool], window: slice | None = None,
                      settings: Behaviour = CORRECTED) -> dict[str, float]:
    """CityLearn 2.5's district KPIs (:data:`DISTRICT_KPIS_2_5`) on the district sums: ramping of increases
    only, ``all_time_peak_average`` over the whole series (one block), ratios by :func:`divide_2_5`; the
    baseline as in :func:`district_kpis`. The control series leaves out the last step: 2.5 sums its district
    consumption only for the steps it acted on, one fewer than its buildings' series (the current step, which
    ``settings.act_then_advance`` has not acted on yet)."""
    get = _prepare(series, window)
    first = settings.kpi_baseline_from_first_building
    suffix = _conditions(dynamics, True)[0] if first else BASELINE[True]
    control, base = get(NET).sum(axis=0)[:-1], get(f"{NET}{suffix}").sum(axis=0)

    def load_factor_ratio(window_steps: int) -> float:
        return divide_2_5(one_minus_load_factor(control, window_steps, plain_division=True),
                          one_minus_load_factor(base, window_steps, plain_division=True))

    everything = max(base.size, 1)
    return {
        "ramping_average": divide_2_5(ramping_up(control), ramping_up(base)),
        "daily_one_minus_load_factor_average": load_factor_ratio(DAY_STEPS),
        "monthly_one_minus_load_factor_average": load_factor_ratio(MONTH_STEPS),
        "daily_peak_average": divide_2_5(peak(control, DAY_STEPS), peak(base, DAY_STEPS)),
        "all_time_peak_average": divide_2_5(peak(control, everything), peak(base, everything)),
    }


def district_kpis(series: Mapping[str, np.ndarray], *, dynamics: Sequence[bool], window: slice | None = None,
                  settings: Behaviour = CORRECTED) -> dict[str, float]:
    """District-level KPIs on the district sums of the control and baseline net consumption (ratios).

    The district baseline is ``..._without_storage_and_partial_load`` (which equals ``..._without_storage``
    for buildings without dynamics); ``settings.kpi_baseline_from_first_building``: the first building's
    condition, as CityLearn 2.1. ``settings.kpi_plain_division``: plain IEEE ratios.
    """
    get = _prepare(series, window)
    first = settings.kpi_baseline_from_first_building
    suffix = _conditions(dynamics, True)[0] if first else BASELINE[True]
    control, base = get(NET).sum(axis=0), get(f"{NET}{suffix}").sum(axis=0)
    plain = settings.kpi_plain_division

    def load_factor_ratio(window_steps: int) -> float:
        return divide(one_minus_load_factor(control, window_steps, plain_division=plain),
                      one_minus_load_factor(base, window_steps, plain_division=plain), plain=plain)

    return {
        "ramping_average": divide(ramping(control), ramping(base), plain=plain),
        "daily_one_minus_load_factor_average": load_factor_ratio(DAY_STEPS),
        "monthly_one_minus_load_factor_average": load_factor_ratio(MONTH_STEPS),
        "daily_peak_average": divide(peak(control, DAY_STEPS), peak(base, DAY_STEPS), plain=plain),
        "annual_peak_average": divide(peak(control, YEAR_STEPS), peak(base, YEAR_STEPS), plain=plain),
    }


def evaluate_challenge(series: Mapping[str, np.ndarray], building_names: Sequence[str], *,
                       dynamics: Sequence[bool], window: slice | None = None,
                       settings: Behaviour = CORRECTED) -> pd.DataFrame:
    """The CityLearn Challenge 2023 table (kpi, display_name, weight, value) with an ``average_score`` row:
    sum of weight x district value over the KPIs that are not NaN, divided by the sum of all weights
    (lower is better). ``settings.kpi_float32_score``: both sums in float32, as CityLearn 2.1; the other
    ``kpi_*`` fields act in :func:`evaluate`."""
    import pandas as pd  # lazy: importing citylearn_env does not import pandas (package docstring)

    table = evaluate(series, building_names, dynamics=dynamics, comfort_band=1.0, window=window,
                     settings=settings)
    district = table[table["level"] == "district"].set_index("cost_function")["value"]
    names_2_1 = {v: k for k, v in NAMES_2_1.items()} if settings.kpi_names_2_5 else {}
    rows = [{"kpi": k, "display_name": name, "weight": weight, "value": float(district[names_2_1.get(k, k)])}
            for k, (name, weight) in CHALLENGE_WEIGHTS.items()]
    weights = np.array([r["weight"] for r in rows])
    weighted = weights * np.array([r["value"] for r in rows])
    dtype = np.float32 if settings.kpi_float32_score else np.float64
    score = float(np.nansum(weighted, dtype=dtype) / np.nansum(weights, dtype=dtype))
    rows.append({"kpi": "average_score", "display_name": "Score", "weight": float("nan"), "value": score})
    return pd.DataFrame(rows, columns=["kpi", "display_name", "weight", "value"])


# ---------------------------------------------------------------------------------------------- objectives
OBJECTIVES = ("cost", "emissions", "discomfort", "consumption", "average_daily_peak")


def objectives(series: Mapping[str, np.ndarray], *, window: slice | None = None,
               steps_per_day: int = DAY_STEPS, one_set_point: bool = False) -> dict:
    """The SimBuild paper's objectives in absolute units over ``window`` (to minimise).

    * cost ($) = sum_t max(e, 0) * price; emissions (kg) = sum_t max(e, 0) * carbon intensity;
      discomfort (degC h) = sum_t |D|, D = :func:`band_delta` outside the comfort band [heating set point,
      cooling set point] (``one_set_point``, CityLearn 2.1: D = T - T_set, the one set point);
      consumption (kWh) = sum_t max(e, 0) -- per building, summed;
    * average_daily_peak (kW) = (sum over days d of max_t in d of P) * steps_per_day / n, with P the district
      net demand (sum of building net consumption; kWh per 1-h step = kW), days in blocks of
      ``steps_per_day`` from the window start and n the number of steps.

    Returns ``{"cost": float, ..., "average_daily_peak": float, "per_building": {"cost": (B,), ...}}``
    (``per_building`` has the first four objectives).
    """
    get = _prepare(series, window)
    net = get(NET)
    grid = np.clip(net, 0.0, None)
    per_building = {
        "cost": (grid * get("electricity_pricing")).sum(axis=1),
        "emissions": (grid * get("carbon_intensity")).sum(axis=1),
        "discomfort": np.abs(band_delta(get("indoor_dry_bulb_temperature"),
                                        *comfort_band_edges(series, get, one_set_point=one_set_point))).sum(axis=1),
        "consumption": grid.sum(axis=1),
    }
    out: dict = {k: float(v.sum()) for k, v in per_building.items()}
    out["average_daily_peak"] = average_daily_peak(net.sum(axis=0), steps_per_day)
    out["per_building"] = per_building
    return out


def average_daily_peak(demand: np.ndarray, steps_per_day: int = DAY_STEPS) -> float:
    """(sum over days d of max_t in d of ``demand``) * steps_per_day / n [kW]: ``demand`` (n,) the district
    net demand [kWh per 1-h step], days in blocks of ``steps_per_day``; NaN for no steps."""
    n = demand.size
    return float(sum(block.max() for block in _blocks(demand, steps_per_day)) * steps_per_day / n) if n else np.nan
