"""The thermal model of LSTM buildings: heat-pump demand from device actions, indoor temperature from the LSTM.

Owned and stepped by :class:`citylearn_env.district.District` (CityLearn 2.1 semantics):

* before the devices run at step t, :meth:`ThermalModel.demands` turns each warm LSTM building's device action a
  into the thermal demand its heat pump serves: ``min(max(a, 0) * P, P) * COP(t)`` [kWh] in the mode that
  ``hvac_mode(t)`` selects (cooling 1, heating 2; 0 in the other mode). A building whose model is still warming
  up (fewer than ``lookback + 1`` steps since the episode start or the last cooling<->heating switch) keeps the
  data set's demand;
* after the devices ran, :meth:`ThermalModel.update` feeds the step's inputs (weather, calendar, the energy
  delivered, the indoor temperature held so far) to the LSTM bank and writes the predicted indoor temperature.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from citylearn_env.settings import Behaviour

if TYPE_CHECKING:
    from citylearn_env.district import Actions, District

#: end use, hvac_mode value that selects it, device action
MODES = (("cooling", 1.0, "cooling_device"), ("heating", 2.0, "heating_device"))


class ThermalModel:
    """The LSTM bank of a district's dynamics buildings and its coupling to their heat pumps."""

    def __init__(self, district: District, settings: Behaviour):
        from citylearn_env.dynamics import build_bank

        self.district = district
        self.index = np.flatnonzero(district.dynamics)
        self.bank = build_bank([district.config.buildings[i] for i in self.index], settings=settings)
        self.hvac_mode = district.signals["hvac_mode"]
        self._warm = np.zeros(district.n, dtype=bool)

    def reset(self) -> None:
        """Episode start: empty every model's window and state; find where each model input comes from."""
        from citylearn_env.observations import DYNAMIC, static_series

        self.bank.reset()
        d = self.district
        self.hvac_mode = d.episode["hvac_mode"]
        # data inputs: the dynamics buildings' rows of the episode series, stacked once as (T, n_data, k);
        # the simulated ones (delivered energy, indoor temperature) are read each step
        names = self.bank.input_names
        data = [j for j, name in enumerate(names) if name not in DYNAMIC]
        self._data_rows = np.array(data, dtype=np.intp)
        self._data = np.ascontiguousarray(np.stack([static_series(d, names[j])[self.index].T for j in data],
                                                   axis=1)) if data else None
        self._simulated = [(j, name) for j, name in enumerate(names) if name in DYNAMIC]
        self._raw = np.zeros((len(names), len(self.index)))

    def demands(self, t: int, actions: Actions) -> dict[str, np.ndarray] | None:
        """Thermal demand [kWh] the device actions ask for at step ``t``, per end use ("cooling", "heating"):
        (B,) arrays, NaN where the data set's demand stays. None when no action applies."""
        d = self.district
        hvac = self.hvac_mode[:, t]
        warm = self._warm
        warm[:] = False
        warm[self.index] = self.bank.warm(hvac[self.index])
        out = {}
        for end_use, mode, action_name in MODES:
            a = getattr(actions, action_name)
            use = warm & np.isfinite(a)
            if not use.any():
                continue
            state = d.end_use(end_use)
            power = state.params.nominal_power
            q = np.where(hvac == mode, np.minimum(np.maximum(a, 0.0) * power, power), 0.0)
            out[end_use] = np.where(use, q * state.cop[:, t], np.nan)
        return out or None

    def update(self, t: int) -> None:
        """Predict the indoor temperature at step ``t`` and write it where the model is warm."""
        from citylearn_env.observations import dynamic_value

        d = self.district
        idx = self.index
        raw = self._raw
        if self._data is not None:
            raw[self._data_rows] = self._data[t]
        for j, name in self._simulated:
            raw[j] = dynamic_value(d, name, t)[idx]
        predicted = self.bank.step_raw(raw, self.hvac_mode[idx, t])
        temps = d.building_record.indoor_dry_bulb_temperature
        temps[idx, t] = np.where(np.isnan(predicted), temps[idx, t], predicted)
