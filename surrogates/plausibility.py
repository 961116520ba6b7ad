"""When a surrogate's behaviour contradicts its record: the one rule that ``surrogate install`` and the build
(for a cached model) apply after replaying a model closed loop on its held-out runs
(:func:`surrogates.evaluate.replay_test_rmse`).

Kept apart from the trainer's modules: a change here changes no cache key (the surrogate and judgement caches
are keyed on the trainer's sources, ``pipeline.builder.surrogates.TRAINER_SOURCES``).
"""

from __future__ import annotations

#: a model is far off its record when its replayed held-out closed-loop RMSE exceeds this many times the RMSE
#: its metrics claim, plus :data:`REPLAY_MARGIN_C` [degC] (the environment's float64 runtime and the trainer's
#: torch float32 agree to about 1e-4 degC; the margin covers a model trained in bfloat16)
REPLAY_FACTOR, REPLAY_MARGIN_C = 1.5, 0.1


def replay_far_off(rmse: float, claimed: float) -> bool:
    """Whether a replayed closed-loop RMSE [degC] is far above the ``claimed`` one [degC] (:data:`REPLAY_FACTOR`,
    :data:`REPLAY_MARGIN_C`); a NaN replay is far off."""
    return not rmse <= REPLAY_FACTOR * claimed + REPLAY_MARGIN_C
