"""The thermal model of LSTM buildings: heat-pump demand from device actions, indoor temperature from the LSTM.

Owned and stepped by :class:`citylearn_env.district.District` (CityLearn 2.1 semantics):

* before the devices run at step t, :meth:`ThermalModel.demands` turns each warm LSTM building's device action a
  into the thermal demand its heat pump serves: ``min(max(a, 0) * P, P) * COP(t)`` [kWh] in the mode that
  ``hvac_mode(t)`` selects (cooling 1, heating 2; 0 in the other mode). In auto mode 3 (CityLearn 2.4+) both
  devices are available and the actions decide: the cooling action drives the cooling demand and the heating
  action the heating demand (with the combined ``cooling_or_heating_device`` action its sign picks one, the
  other gets 0), as upstream's ``LSTMDynamicsBuilding.update_cooling_demand`` / ``update_heating_demand``
  (intelligent-environments-lab/CityLearn, citylearn/building.py: cooling in modes 1 and 3, heating in 2 and 3)
  do; there is no thermostat logic in the environment itself -- the data set's own demands, which a building
  simulation with both set points produced (cooling above the cooling set point, heating below the heating
  one), stand wherever no action applies. A building whose model is still warming up (fewer than
  ``lookback + 1`` steps since the episode start or the last switch of model) keeps the data set's demand;
* after the devices ran, :meth:`ThermalModel.update` feeds the step's inputs (weather, calendar, the energy
  delivered, the indoor temperature held so far) to the LSTM bank and writes the predicted indoor temperature;
  a prediction outside :data:`INDOOR_RANGE_C` stops the episode with one :class:`DynamicsError`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial

import numpy as np

from citylearn_env import backends, device_kernels
from citylearn_env.actions import Actions
from citylearn_env.config import BuildingConfig
from citylearn_env.dynamics import build_bank
from citylearn_env.errors import DynamicsError
from citylearn_env.settings import Behaviour
from citylearn_env.state import DYNAMIC, EndUseState

#: end use, the hvac_mode values that make its device available (3 = auto: both), device action
MODES = (("cooling", (1.0, 3.0), "cooling_device"), ("heating", (2.0, 3.0), "heating_device"))
#: indoor temperatures [degC] a building can have; a prediction outside stops the episode (DynamicsError)
INDOOR_RANGE_C = (-50.0, 80.0)


def check_indoor_range(predicted_c: np.ndarray, names: Sequence[str], t: int,
                       bounds_c: tuple[float, float] = INDOOR_RANGE_C) -> bool:
    """Refuse predicted indoor temperatures [degC] outside ``bounds_c`` (NaN: a model still warming up, not
    checked) with one :class:`DynamicsError` naming the first such building (``names`` aligned with
    ``predicted_c``) and the time step ``t``. Returns whether every value is a number (no NaN)."""
    low, high = bounds_c
    if predicted_c.min() >= low and predicted_c.max() <= high:  # the common case; NaN falls through
        return True
    bad = np.flatnonzero(~np.isnan(predicted_c) & ~((predicted_c >= low) & (predicted_c <= high)))
    if bad.size:
        i = int(bad[0])
        raise DynamicsError(f"the LSTM predicted an indoor temperature of {predicted_c[i]:.4g} degC at time step {t}, "
                            f"outside {low:g}..{high:g} degC: its weights or normalisation do not fit this "
                            "building; the episode stops", column=f"buildings.{names[i]}.dynamics", row=t)
    return False


class ThermalModel:
    """The LSTM bank of a district's dynamics buildings and its coupling to their heat pumps.

    ``buildings``: every building of the district; ``dynamics`` (B,) bool marks those with LSTM models.
    The district passes in what the model reads of it: its data series, observed values and end uses."""

    def __init__(self, buildings: Sequence[BuildingConfig], dynamics: np.ndarray, settings: Behaviour,
                 backend: str = "auto"):
        self.use_backend(backend)
        self.index = np.flatnonzero(dynamics)
        #: the dynamics buildings as a slice when they are all the buildings (views, not copies, each step)
        self._rows: slice | np.ndarray = slice(None) if len(self.index) == len(buildings) else self.index
        self.names = [buildings[i].name for i in self.index]
        self.bank = build_bank([buildings[i] for i in self.index], settings=settings)
        self._warm = np.zeros(len(buildings), dtype=bool)

    def use_backend(self, backend: str) -> None:
        """Compute the heat pumps' demands with the compiled kernel ("numba", or "auto" with numba installed) or
        the numpy function ("numpy"), as :meth:`citylearn_env.district.District.use_backend`."""
        kernels = backends.compiled(backend, device_kernels.get_kernels)
        self._heat_pump_demand = partial(device_kernels.heat_pump_demand, kernels=kernels)

    def reset(self, hvac_mode: np.ndarray, data_series: Callable[[str], np.ndarray],
              changing: tuple[str, ...] = ()) -> None:
        """Episode start: empty every model's window and state; find where each model input comes from.
        ``hvac_mode`` (B, T) of the episode; ``data_series(name)`` the (B, T) episode series of a data input;
        ``changing``: data inputs that change during the episode (set points occupants override), read each
        step like the simulated ones."""
        self.bank.reset()
        self.hvac_mode = hvac_mode
        #: end use -> (B, T) bool: hvac_mode makes its device available (:data:`MODES`)
        self._available = {name: (hvac_mode == modes[0]) | (hvac_mode == modes[1]) for name, modes, _ in MODES}
        # data inputs: the dynamics buildings' rows of the episode series, stacked once as (T, n_data, k);
        # the simulated ones (delivered energy, indoor temperature) are read each step
        names = self.bank.input_names
        stepped = (*DYNAMIC, *changing)
        data = [j for j, name in enumerate(names) if name not in stepped]
        self._data_rows = np.array(data, dtype=np.intp)
        self._data = np.ascontiguousarray(np.stack([data_series(names[j])[self.index].T for j in data],
                                                   axis=1)) if data else None
        self._simulated = [(j, name) for j, name in enumerate(names) if name in stepped]
        self._raw = np.zeros((len(names), len(self.index)))

    def demands(self, t: int, actions: Actions, end_use: Callable[[str], EndUseState]
                ) -> dict[str, np.ndarray] | None:
        """Thermal demand [kWh] the device actions ask for at step ``t``, per end use ("cooling", "heating"):
        (B,) arrays, NaN where the data set's demand stays. None when no action applies. ``end_use(name)`` is
        the episode state of an end use (nominal power [kW], COP)."""
        warm = self._warm
        warm[self._rows] = self.bank.warm(self.hvac_mode[self._rows, t])
        out = {}
        for name, _, action_name in MODES:
            a = getattr(actions, action_name)
            use = warm & np.isfinite(a)
            if not use.any():
                continue
            state = end_use(name)
            out[name] = self._heat_pump_demand(a, self._available[name][:, t], state.params.nominal_power,
                                               state.cop[:, t], use)
        return out or None

    def warm_now(self) -> np.ndarray:
        """(B,) bool over the district: the building's model predicted at the last :meth:`update`."""
        out = np.zeros(len(self._warm), dtype=bool)
        out[self.index] = self.bank.is_warm
        return out

    def update(self, t: int, observed: Callable[[str, int], np.ndarray], temperature: np.ndarray) -> None:
        """Predict the indoor temperature [degC] at step ``t`` and write it into ``temperature`` (B, T) where
        the model is warm; ``observed(name, t)`` is the (B,) value of a simulated input at t."""
        rows = self._rows
        raw = self._raw
        if self._data is not None:
            raw[self._data_rows] = self._data[t]
        for j, name in self._simulated:
            raw[j] = observed(name, t)[rows]
        predicted = self.bank.step_raw(raw, self.hvac_mode[rows, t])
        if check_indoor_range(predicted, self.names, t):  # every model predicted (no NaN)
            temperature[rows, t] = predicted
        else:
            temperature[rows, t] = np.where(np.isnan(predicted), temperature[rows, t], predicted)
