"""Upstream behaviour as one frozen settings object: one named field per CityLearn quirk.

Every place where CityLearn 2.1 (the version behind the SimBuild 2024 results) behaves differently from the
documented or physically consistent behaviour is one field here, read where it acts and nowhere else.
Presets:

* :data:`CORRECTED` -- the default: every quirk corrected;
* :data:`CITYLEARN_2_1` -- CityLearn 2.1.2 number for number, bugs included (golden-trace parity);
* :data:`CITYLEARN_2_5` -- CityLearn 2.5.0 where it differs from the corrected default: its physics (legacy
  outage draws, battery efficiency read at the request, the EV state-of-charge bookkeeping of docs/ev.md
  section 4, the two bugs of its EV reward), its dynamics (one LSTM across hvac_mode switches, act-then-advance
  step timing, float32 LSTM, drawn device defaults) and its KPI table; every other field corrected.

``CityLearnEnv(schema, compat=True)`` is shorthand for ``settings=CITYLEARN_2_1``. Change one field with
``dataclasses.replace(CORRECTED, lstm_day_type_period=8.0)``. Each field's effect is in its comment; the
measured effect of each correction on the data sets is in docs/environment.md.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from citylearn_env.errors import SchemaError


@dataclass(frozen=True)
class Behaviour:
    """Which upstream quirks the environment reproduces (the defaults are the corrected behaviour)."""

    # ---------------------------------------------------------------- data sets
    #: a building file without an ``hvac_mode`` column: True = mode 0 ("off", what CityLearn 2.1.0 did),
    #: False = mode 1 (cooling, as the documentation says and CityLearn 2.1.2 does -- so both presets keep False)
    missing_hvac_mode_is_off: bool = False

    # ---------------------------------------------------------------- devices
    #: battery efficiency and capacity-power curves beyond their last point: True = extrapolate the first
    #: segment (CityLearn 2.1), False = hold the last y
    battery_curve_extrapolates_first_segment: bool = False
    #: battery round-trip efficiency read on the power-efficiency curve at min(|request|, capacity-power limit) /
    #: nominal power (CityLearn 2.5, building batteries and EV batteries) instead of at |clipped energy| /
    #: nominal power (CityLearn 2.1, the corrected default)
    battery_efficiency_from_request: bool = False
    #: the ``electrical_storage`` action is a fraction of the battery's nominal power in [-1, 1] (request =
    #: action * nominal power * step hours, CityLearn 2.5) instead of a fraction of its capacity with bounds
    #: +-nominal power / capacity (CityLearn 2.1, the corrected default)
    battery_action_fraction_of_nominal_power: bool = False
    #: a building battery whose schema leaves out a curve, efficiency, standby loss or capacity loss gets
    #: CityLearn 2.5's drawn defaults (a fresh ``RandomState`` of the device's seed per draw, docs/ev.md
    #: section 1) instead of CityLearn 2.1's fixed ones (the corrected default)
    battery_defaults_drawn: bool = False
    #: an autosized building battery gets CityLearn 2.1's size: capacity = peak PV output x SF of the zero-size PV
    #: placeholder the building holds when its battery is sized (always 0). False: CityLearn 2.2+'s rule on the
    #: baseline consumption (offline, :mod:`citylearn_env.pv_battery_autosize`)
    battery_autosize_from_placeholder_pv: bool = False
    #: a storage tank, heat pump or electric heater whose schema leaves out an attribute CityLearn 2.5 draws gets
    #: 2.5's drawn value ``low + (high - low) u``, ``u`` the first uniform number of the device's seed
    #: (:func:`citylearn_env.ev.upstream_device_seed`): tank efficiency 0.90..0.98 and standby loss 0.001..0.009,
    #: heat-pump efficiency 0.2..0.3, target heating 45..50 degC and cooling 7..10 degC temperatures, heater
    #: efficiency 0.90..0.99. False: CityLearn 2.1's fixed defaults (tank efficiency 1, heat pump 0.2 / 45 / 8 degC)
    thermal_device_defaults_drawn: bool = False
    #: the ``dhw_storage`` action is a fraction of the *heating* storage's capacity and ``heating_storage`` of the
    #: *cooling* storage's (CityLearn 2.4+'s copy-paste bug: a DHW tank in a building without heating storage never
    #: charges nor discharges). False: each action is a fraction of its own tank's capacity
    storage_action_scaled_by_other_tank: bool = False
    #: a thermal storage action is bounded by +-min(device nominal power [kW] / capacity [kWh], 1) (CityLearn 2.5)
    #: instead of +-min(peak demand over the simulation [kWh] / capacity, 1) (CityLearn 2.1)
    thermal_storage_bounds_from_device_power: bool = False

    # ---------------------------------------------------------------- electric vehicles (docs/ev.md section 4)
    #: an EV's SOC at a step that nothing writes (no charger action, no arrival, no drift) is 0, as CityLearn
    #: 2.5 leaves its SOC array: a plugged EV under a zero action is observed empty and starts the next step
    #: from 0 (energy lost). False: the SOC carries over from the previous step less the standby loss
    ev_unwritten_soc_is_zero: bool = False
    #: a charger's battery step at t starts from the EV's SOC at t - 1 even when the EV arrived at t with a
    #: forced arrival SOC (CityLearn 2.5: an arrival without an announcing state-2 row starts from a stale
    #: SOC). False: the step starts from the SOC the EV holds at t (its arrival SOC when it just arrived)
    ev_step_starts_from_previous_soc: bool = False
    #: charger and washing-machine rows indexed by the episode time step counted from the simulation start
    #: (CityLearn 2.5 does not re-window them to the episode: a later episode replays the first rows). False:
    #: the rows of the episode's own time steps
    ev_data_from_range_start: bool = False
    #: the drift of an away EV's SOC drawn from ``numpy.random.RandomState(reset seed)`` (the stream of
    #: CityLearn 2.5's global ``numpy.random`` seeded with that number) instead of the env's own generator
    legacy_ev_drift_draws: bool = False

    # ---------------------------------------------------------------- LSTM temperature model
    #: period of the day_type sin/cos model inputs [days]: 8 (CityLearn 2.1: holidays as day 8) or 7
    lstm_day_type_period: float = 7.0
    #: de-normalise the predicted temperature with the *last* input's min-max bounds (CityLearn 2.1) instead
    #: of the indoor temperature's own bounds
    lstm_output_uses_last_input_bounds: bool = False
    #: round the input window and the prediction to float32, as CityLearn 2.1's and 2.5's torch models do
    lstm_float32: bool = False
    #: a v2.2+ schema's single ``dynamics`` model runs as one model with one state whatever the hvac_mode
    #: (CityLearn 2.5). False: it serves as two copies, one for heating (mode 2), one for the other modes, and
    #: the copy a cooling<->heating switch selects starts again from an empty window (a new warm-up of
    #: ``lookback + 1`` steps serving the ideal load), as a v2.1 schema's two models do in every preset
    lstm_one_model_across_modes: bool = False

    # ---------------------------------------------------------------- step timing
    #: CityLearn 2.5's step timing: ``reset`` books row 0 uncontrolled as before, then step call k acts on row k
    #: (row 0 included), computes the reward there and then advances: the observation returned is row k + 1's
    #: before control (its consumption and storage state 0, its temperature the data set's) and row T - 1 is
    #: never acted on. False: CityLearn 2.1's timing, call k advances to row k + 1 and acts there (row 0 is never
    #: controlled)
    act_then_advance: bool = False
    #: with ``act_then_advance``, row 0's consumption is booked three times, as CityLearn 2.5's reset, first step
    #: call and update each add it: the uncontrolled loads at reset, then what the first call's devices draw (their
    #: power already reduced by the reset's booking), then once more the delivered energy plus storage balance over
    #: the COP; the non-shiftable load three times, the battery's balance twice. False: row 0 holds what the
    #: first call draws
    first_step_booked_three_times: bool = False

    # ---------------------------------------------------------------- episodes and outages
    #: random episode split drawn with legacy ``RandomState(random_seed * (episode + 1))``, never the last
    #: split (CityLearn 2.1), instead of the env's seeded generator over all splits
    legacy_random_episode_split: bool = False
    #: stochastic outages drawn as CityLearn 2.1's ReliabilityMetricsPowerOutage (day 0 never out but its
    #: draw shifts later days; int truncation; whole days only) instead of the corrected per-day draw
    legacy_outage_draws: bool = False

    # ---------------------------------------------------------------- rewards
    #: IndependentSACReward: -max(e, 0) (CityLearn's operator-precedence bug) instead of -max(e, 0)^3
    independent_sac_reward_precedence_bug: bool = False
    #: ComfortReward / SolarPenaltyAndComfortReward: float32 subtraction and rounding of the parts
    comfort_reward_float32: bool = False
    #: StorageSignalReward with stored energy D <= 0: multiply by D itself instead of its sign
    storage_signal_reward_multiplies_by_delta: bool = False
    #: Electric_Vehicles_Reward_Function: a charger without a plugged-in EV never scores (CityLearn 2.5: its
    #: ``no_car_charging`` weight is unreachable). False: a charger asked for more than 0.1 kWh with no EV plugged
    #: in scores ``no_car_charging`` x the reward's multiplier
    ev_reward_skips_unplugged_chargers: bool = False
    #: Electric_Vehicles_Reward_Function: an EV leaving 0.25 or more below its required SOC scores
    #: ``soc_under ** 2`` (CityLearn 2.5: +25 with the default weight -5, more than a near miss earns) instead
    #: of ``soc_under * |soc_under|`` (-25: the weight's sign kept, its size squared)
    ev_reward_squares_soc_under_weight: bool = False

    # ---------------------------------------------------------------- KPIs
    #: KPI ratios by plain IEEE division (x/0 = inf, 0/0 = NaN) instead of 0/0 = 1 and x/0 = NaN
    kpi_plain_division: bool = False
    #: discomfort statistics over all steps with unoccupied deltas as 0 instead of over occupied steps
    kpi_discomfort_over_all_steps: bool = False
    #: the first building's dynamics decide every building's KPI baseline (CityLearn 2.1)
    kpi_baseline_from_first_building: bool = False
    #: the 2023 challenge score summed in float32
    kpi_float32_score: bool = False
    #: discomfort (the 2.1 KPI table's ``discomfort_*`` and the paper objective ``discomfort``) measured against
    #: the one set point ``indoor_dry_bulb_temperature_set_point`` (CityLearn 2.1: T - S, where S jumps between the
    #: heating and the cooling set point with hvac_mode, so a temperature inside the deadband counts) instead of
    #: against the comfort band [heating set point, cooling set point] (0 inside, T - S_heating below, T -
    #: S_cooling above: CityLearn 2.5's cold/hot definition). One set point only (v2.1 data): the same either way
    kpi_discomfort_against_one_set_point: bool = False
    #: the partial-load baseline of an LSTM building converts every step's heating difference with the heating
    #: COP of the last step of the series (CityLearn 2.1.2 and 2.5 read the current outdoor temperature only;
    #: the 2.1 golden data sets have no heating partial load, so it moves none of their numbers); False: each
    #: step's own COP
    kpi_partial_load_heating_cop_of_last_step: bool = False
    #: ``evaluate()`` returns CityLearn 2.5's table (docs/environment.md, "The CityLearn 2.5 preset"): its names
    #: (``all_time_peak_average`` over the episode, ``discomfort_cold_*`` / ``discomfort_hot_*``), cold discomfort
    #: below the *heating* set point - band and hot above the *cooling* set point + band, their delta minimum /
    #: maximum / average as
    #: |negative part| / positive part over every step (unoccupied as 0), ramping of increases only, the district
    #: control series without its last step (2.5 sums it only over acted steps), a ratio whose parts are not
    #: finite read as 0 (x/0 NaN, 0/0 1). False: CityLearn 2.1's table against the one set point
    kpi_names_2_5: bool = False

    # ---------------------------------------------------------------- observation wrapper
    #: period of day_type in NormalizedObservationWrapper's cos/sin encoding [days]: 8 or 7
    wrapper_day_type_period: float = 7.0

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


#: every quirk corrected (the default)
CORRECTED = Behaviour()

#: fields that only older 2.1 releases had a quirk for (CITYLEARN_2_1 keeps their default)
ONLY_BEFORE_2_1_2 = ("missing_hvac_mode_is_off",)
#: the boolean quirks CityLearn 2.1.2 has
QUIRKS_2_1 = ("battery_curve_extrapolates_first_segment", "lstm_output_uses_last_input_bounds", "lstm_float32",
              "legacy_random_episode_split", "legacy_outage_draws", "independent_sac_reward_precedence_bug",
              "battery_autosize_from_placeholder_pv",
              "comfort_reward_float32", "storage_signal_reward_multiplies_by_delta", "kpi_plain_division",
              "kpi_discomfort_over_all_steps", "kpi_baseline_from_first_building", "kpi_float32_score",
              "kpi_discomfort_against_one_set_point",
              "kpi_partial_load_heating_cop_of_last_step")
#: CityLearn 2.1.2 exactly, bugs included: its quirks, and day_type with period 8 [days] (holidays as day 8)
CITYLEARN_2_1 = Behaviour(**dict.fromkeys(QUIRKS_2_1, True), lstm_day_type_period=8.0, wrapper_day_type_period=8.0)

#: fields that only CityLearn 2.5 has a quirk for (CITYLEARN_2_1 keeps the corrected value)
ONLY_IN_2_5 = ("battery_efficiency_from_request", "battery_action_fraction_of_nominal_power",
               "battery_defaults_drawn", "ev_unwritten_soc_is_zero", "ev_step_starts_from_previous_soc",
               "ev_data_from_range_start", "legacy_ev_drift_draws", "ev_reward_skips_unplugged_chargers",
               "ev_reward_squares_soc_under_weight", "thermal_device_defaults_drawn",
               "storage_action_scaled_by_other_tank", "thermal_storage_bounds_from_device_power",
               "lstm_one_model_across_modes", "act_then_advance", "first_step_booked_three_times",
               "kpi_names_2_5")
#: CityLearn 2.1 quirks CityLearn 2.5.0 still has
SHARED_2_1_2_5 = ("legacy_outage_draws", "lstm_float32", "kpi_baseline_from_first_building",
                  "kpi_partial_load_heating_cop_of_last_step")
#: CityLearn 2.5.0 (the v2.4.2 data sets and their EVs): its own quirks, the 2.1 quirks it kept, its step
#: timing and KPI table (docs/environment.md, "The CityLearn 2.5 preset")
CITYLEARN_2_5 = Behaviour(**dict.fromkeys((*ONLY_IN_2_5, *SHARED_2_1_2_5), True))

PRESETS: dict[str, Behaviour] = {"corrected": CORRECTED, "citylearn-2.1": CITYLEARN_2_1,
                                 "citylearn-2.5": CITYLEARN_2_5}


def resolve(settings: Behaviour | str | None = None, compat: bool = False) -> Behaviour:
    """The settings to run with: ``settings`` (an object or a preset name), else the 2.1 preset when
    ``compat`` (the documented shorthand), else :data:`CORRECTED`."""
    if isinstance(settings, Behaviour):
        return settings
    if isinstance(settings, str):
        try:
            return PRESETS[settings]
        except KeyError:
            raise SchemaError(f"unknown behaviour preset {settings!r}; known: {', '.join(PRESETS)}",
                              column="settings") from None
    if settings is not None:
        raise TypeError(f"settings must be a Behaviour or a preset name, not {type(settings).__name__}")
    return CITYLEARN_2_1 if compat else CORRECTED
