"""The trainer's settings, torch-free: :class:`TrainConfig` and the surrogate's input names. The CLI and the
build read them without loading torch; :mod:`surrogates.train` runs them."""

from __future__ import annotations

import datetime
from dataclasses import asdict, dataclass, replace

from citylearn_env.errors import InputError
from surrogates.precision import check_precision

TARGET = "indoor_dry_bulb_temperature"
#: default inputs, upstream order with both loads (a mixed-climate house needs heating and cooling) and
#: without upstream's day_type_sin/cos: CityLearn 2.1 encodes the day type with period 8 at run time where
#: the models are trained with 7, so a model that reads the day type runs differently there (on the
#: validation suite, up to 0.2 degC worse monthly median); occupancy carries the weekly schedule
#: (docs/surrogates.md, fifth pass). The day-type inputs stay available by name. ``non_shiftable_load`` (the
#: hour's lights and appliances, the house's internal gains; the building table's column at run time) is read
#: where the ILV table has it (docs/surrogates.md, section 11).
DEFAULT_INPUTS: tuple[str, ...] = (
    "direct_solar_irradiance", "diffuse_solar_irradiance", "outdoor_dry_bulb_temperature",
    "indoor_dry_bulb_temperature_set_point", "occupant_count", "non_shiftable_load", "cooling_demand",
    "heating_demand", "month_sin", "month_cos", "hour_sin", "hour_cos", TARGET,
)
#: upstream's full input set: the defaults with the day-type encoding before the temperature (the default
#: before the fifth pass; its ablation recipes and the CityLearn 2.1 comparison use it)
INPUTS_WITH_DAY_TYPE: tuple[str, ...] = (*DEFAULT_INPUTS[:-1], "day_type_sin", "day_type_cos", TARGET)


#: where a training's weights begin (:attr:`TrainConfig.start`)
STARTS = ("random", "generic")


#: settings the training records state that are no longer settings: (key, its value, the field it follows).
#: ``lookback`` (the window, :attr:`TrainConfig.lookback`) and ``ensemble`` (seeds merged into one LSTM) were
#: knobs no recipe used (benchmarks/surrogate_recipes.md); the records keep them, so a district's files read
#: as before
FIXED_SETTINGS: tuple[tuple[str, int, str], ...] = (
    ("lookback", 1, "num_layers"), ("ensemble", 1, "validation_hours"))


@dataclass(frozen=True)
class TrainConfig:
    """Hyper-parameters; the defaults are the best recipe measured on the independent validation suite
    (docs/surrogates.md, section 4 and its eighth pass): a plain stateful LSTM (:attr:`lookback` 1), a
    teacher-forced warm start on 48-h sequences, then closed-loop epochs on 48-h and 168-h chunks. The build
    and ``districtgen surrogate train`` train :data:`BUILD_RECIPE` (:func:`recipe`), not these defaults."""

    inputs: tuple[str, ...] = DEFAULT_INPUTS
    hidden_size: int = 32
    num_layers: int = 2
    epochs: int = 32
    seed: int = 0
    pretrain_steps: int = 6000
    #: sequences per one-step update of the warm start
    pretrain_batch_size: int = 32
    #: length (h) of the teacher-forced sequences of the warm start (state carried through each, from zero); at
    #: most the longest training segment allows
    pretrain_sequence_hours: int = 48
    chunk_hours: int = 48
    #: the last ``long_chunk_epochs`` epochs (at most ``epochs - 1``; 0: none) train on chunks of
    #: ``long_chunk_hours`` hours (at most the longest training segment allows) at
    #: ``long_chunk_learning_rate``, continuing from the current weights: a low-rate fine-tune on longer
    #: closed-loop horizons, which corrects multi-day drift that shorter chunks do not see
    #: (docs/surrogates.md)
    long_chunk_hours: int = 168
    long_chunk_epochs: int = 10
    long_chunk_learning_rate: float = 2.5e-4
    batch_size: int = 128
    learning_rate: float = 0.01
    #: Adam rate of the closed-loop epochs before the long phase (fresh moments after the warm start)
    finetune_learning_rate: float = 0.0005
    #: standard deviation (normalised temperature units; x the training range in degC) of Gaussian noise
    #: added to every temperature of the history in the one-step phase, drawn afresh per update: the model
    #: learns not to copy its temperature input, which it will be fed back from its own predictions, and
    #: drifts less in closed loop (docs/surrogates.md, sixth and seventh passes)
    pretrain_noise: float = 0.06
    #: the first ``pretrain_clean_hours`` temperatures of each warm-start sequence carry no noise: with its state
    #: still empty the model should trust its temperature input, as it must at the start of a rollout, where
    #: that input is measured (docs/surrogates.md, eighth pass)
    pretrain_clean_hours: int = 6
    #: the validated and exported weights are an exponential moving average of the closed-loop iterates, this
    #: decay per update (0: the iterates themselves)
    ema_decay: float = 0.95
    use_free_float: bool = False
    use_ideal: bool = False
    #: calendar months (1-12) the model is trained and validated on; empty: every month of the table. A
    #: district serves its surrogates only in its period, so the build trains on the period's months and one
    #: month either side (:func:`season_months`): the same updates spent on the season the
    #: model runs in (docs/surrogates.md, section 11)
    months: tuple[int, ...] = ()
    test_runs: int = 1
    validation_hours: int = 336
    max_seconds: float | None = None
    threads: int = 1
    progress: bool = True
    #: numeric mode of the one-step and closed-loop updates (:data:`surrogates.precision.PRECISIONS`):
    #: ``bfloat16`` runs them under bfloat16 autocast (float32 Adam; validation and the exported weights
    #: stay float32; not bit-identical to float32); ``auto`` picks bfloat16 only where the CPU multiplies it
    #: natively and a short measurement of this network's update finds it faster (:func:`update_precision`)
    precision: str = "auto"
    #: the weights the warm start begins from: ``random`` (seeded) or ``generic`` (:mod:`surrogates.generic`:
    #: one model trained on many houses, used where its size matches, else random)
    start: str = "random"
    #: the warm start's Adam rate when it begins from the generic model (``learning_rate`` otherwise): at the
    #: random start's 0.02 a generic start diverged in winter months (docs/surrogates.md, section 11)
    generic_learning_rate: float = 0.01

    def __post_init__(self):
        if self.inputs and self.inputs[-1] != TARGET:
            raise InputError(f"the last input must be {TARGET!r}", column="inputs")
        for key in ("hidden_size", "num_layers", "epochs", "chunk_hours", "long_chunk_hours", "batch_size",
                    "pretrain_batch_size", "pretrain_sequence_hours"):
            if getattr(self, key) < 1:
                raise InputError("must be >= 1", column=key)
        for key in ("long_chunk_epochs", "pretrain_noise", "pretrain_clean_hours", "ema_decay"):
            if getattr(self, key) < 0:
                raise InputError("must be >= 0", column=key)
        check_precision(self.precision, column="precision")
        if self.start not in STARTS:
            raise InputError(f"unknown start {self.start!r}; known: {', '.join(STARTS)}", column="start")
        bad = [m for m in self.months if not 1 <= m <= 12]
        if bad:
            raise InputError(f"calendar months are 1-12, got {bad[0]}", column="months")

    @property
    def lookback(self) -> int:
        """Window length (h) of the trained model: 1, CityLearn's sliding window of one row, which is a plain
        stateful LSTM (the warm start teacher-forces whole sequences). Not a setting: longer windows lost on
        the validation suite and left the trainer (benchmarks/surrogate_recipes.md); exported models of any
        lookback still evaluate and run in the environment."""
        return 1

    def record(self) -> dict:
        """The settings as plain data, in the order of the training records (``training.config`` of
        ``<name>.metrics.json``): every field, and the fixed ``lookback`` 1 and ``ensemble`` 1 (one model)
        where the records have always stated them (:data:`FIXED_SETTINGS`)."""
        out: dict = {}
        for key, value in asdict(self).items():
            out[key] = value
            out.update({fixed: stated for fixed, stated, after in FIXED_SETTINGS if after == key})
        return out

    @property
    def long_start(self) -> int | None:
        """Epoch at which the long-chunk phase starts (None: no long phase)."""
        long = min(self.long_chunk_epochs, self.epochs - 1)
        return self.epochs - long if long > 0 else None


def season_months(start: datetime.date, end: datetime.date, margin: int = 0) -> tuple[int, ...]:
    """The calendar months (1-12) of the days ``start`` .. ``end`` and ``margin`` months either side, sorted;
    ``()`` (:attr:`TrainConfig.months`: every month) when they cover the year."""
    span = (end.year - start.year) * 12 + end.month - start.month + 1 + 2 * margin
    if span >= 12:
        return ()
    return tuple(sorted((start.month - 1 - margin + k) % 12 + 1 for k in range(span)))


#: the build's recipe, the one source of its training settings: the ``[surrogate]`` keys default to its values
#: (:class:`pipeline.config.Surrogate`) and ``districtgen surrogate train`` trains it unless told otherwise
#: (:func:`recipe`). Cut to fit about 30 s of CPU per building-year in float32 on an
#: AVX2-only CPU (AMD EPYC, no native bfloat16), where ``TrainConfig()`` takes 72-92 s: hidden 16; the model
#: underfits, so the budget goes to the warm start: 5000 updates of batch 16 (about 1.5x cheaper per update
#: than 32) at rate 0.02, then 16 closed-loop epochs of which the last 6 on 168-h chunks. Against 2000 updates
#: of 32 at 0.01 and 24 / 8 epochs it lowers the judge's monthly median on every default house by 0.00-0.06
#: degC (docs/surrogates.md, section 11). The kept epoch is chosen on 720-h validation chunks: on 336-h ones a
#: house whose closed-loop validation error oscillates kept an early epoch (Building_5 of the default district:
#: epoch 2, full-year judge 0.26 / 0.38 degC; with 720 h epoch 10, 0.24 / 0.34; the other houses' epochs the same
#: or better), for about 1.5-2 s more CPU per house (a longer sequential rollout). The warm start's temperature
#: noise is 0.2 of the training range (``TrainConfig``: 0.06): with the internal gains as an input, 0.06 -> 0.2
#: lowers every default house's full-year judge median (by 0.007-0.024 degC, Building_6 0.309 -> 0.286) and
#: its December-February mean (docs/surrogates.md, section 11). The warm start begins from the generic model
#: (:mod:`surrogates.generic`, at rate 0.01): the six default houses' full-year judge medians 0.03-0.06 degC
#: lower at the same CPU, Building_6's year within the bound (0.294 -> 0.237 degC; docs/surrogates.md, section 11)
BUILD_RECIPE = TrainConfig(hidden_size=16, pretrain_steps=5000, pretrain_batch_size=16, learning_rate=0.02,
                           epochs=16, long_chunk_epochs=6, validation_hours=720, pretrain_noise=0.2,
                           start="generic")


def recipe(**settings: object) -> TrainConfig:
    """:data:`BUILD_RECIPE` (read when called) with ``settings`` over it; a setting given as None keeps the
    recipe's value (a command-line option not given)."""
    return replace(BUILD_RECIPE, **{key: value for key, value in settings.items() if value is not None})
