"""LSTM indoor-temperature dynamics: a torch-free ``.pth`` reader and a batched bank of building models.

``read_pth_state_dict`` reads a PyTorch checkpoint (zip or pre-1.6 legacy) with a restricted unpickler (tensors and plain
containers only, nothing executed). :class:`LSTMBank` advances the LSTM models of all dynamics buildings of a
district together, one call per environment step, with CityLearn 2.1 semantics (see
docs/environment_dynamics.md for the window/state rules and the ``lstm_*`` quirks of
:class:`~citylearn_env.settings.Behaviour`).
"""

from __future__ import annotations

import collections
import io
import pickle
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from citylearn_env import backends, dataset, lstm_kernels
from citylearn_env.dataset import DynamicsBlock, split_periodic_name
from citylearn_env.errors import SchemaError
from citylearn_env.settings import CORRECTED, Behaviour

TEMPERATURE = "indoor_dry_bulb_temperature"
#: periods of the sin/cos encoded LSTM inputs (hour 1-24, month 1-12, day_type 1-7); the day_type period is
#: replaced by ``settings.lstm_day_type_period`` in :class:`LSTMBank`
PERIODS = dataset.PERIODS


def input_periods(settings: Behaviour = CORRECTED) -> dict[str, float]:
    """Periods of the periodic LSTM inputs: hour 24 [h], month 12 [months], day_type
    ``settings.lstm_day_type_period`` [days] (8 in CityLearn 2.1)."""
    return dict(PERIODS, day_type=float(settings.lstm_day_type_period))

# ------------------------------------------------------------------------------------------- .pth reader
_STORAGE_DTYPES = {
    "DoubleStorage": "<f8", "FloatStorage": "<f4", "HalfStorage": "<f2", "BFloat16Storage": "bfloat16",
    "LongStorage": "<i8", "IntStorage": "<i4", "ShortStorage": "<i2", "CharStorage": "i1",
    "ByteStorage": "u1", "BoolStorage": "?",
}


@dataclass(frozen=True)
class _StorageType:
    name: str


def _rebuild_tensor(storage, offset, size, stride, requires_grad=False, hooks=None, metadata=None):
    size, stride = tuple(int(s) for s in size), tuple(int(s) for s in stride)
    if len(size) != len(stride) or any(s < 0 for s in (*size, *stride)) or int(offset) < 0:
        raise ValueError(f"bad tensor layout size={size} stride={stride} offset={offset}")
    if 0 in size:
        return np.zeros(size, dtype=storage.dtype)
    last = int(offset) + sum((n - 1) * s for n, s in zip(size, stride, strict=True))
    if last >= storage.size:
        raise ValueError(f"tensor (size={size}, stride={stride}, offset={offset}) overruns its storage")
    item = storage.itemsize
    view = np.lib.stride_tricks.as_strided(storage[int(offset):], size, tuple(s * item for s in stride))
    return np.array(view, copy=True)


def _rebuild_parameter(data, requires_grad=False, hooks=None, state=None):
    return data


_ALLOWED_GLOBALS = {
    ("collections", "OrderedDict"): collections.OrderedDict,
    ("torch._utils", "_rebuild_tensor_v2"): _rebuild_tensor,
    ("torch._utils", "_rebuild_parameter"): _rebuild_parameter,
    ("torch._utils", "_rebuild_parameter_with_state"): _rebuild_parameter,
} | {("torch", name): _StorageType(name) for name in _STORAGE_DTYPES}


class _RefusedGlobal(Exception):
    pass


class _WeightsUnpickler(pickle.Unpickler):
    """Resolves only tensor-rebuild helpers, storage types and OrderedDict; storages come from the zip."""

    def __init__(self, data: bytes, archive: zipfile.ZipFile, folder: str, byteorder: str):
        super().__init__(io.BytesIO(data))
        self._archive, self._folder, self._byteorder = archive, folder, byteorder
        self._storages: dict[str, np.ndarray] = {}

    def find_class(self, module: str, name: str):
        try:
            return _ALLOWED_GLOBALS[(module, name)]
        except KeyError:
            raise _RefusedGlobal(f"{module}.{name}") from None

    def persistent_load(self, pid):
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"
                and isinstance(pid[1], _StorageType)):
            raise ValueError(f"unsupported persistent id {pid!r}")
        _, storage_type, key, _location, numel = pid
        if key not in self._storages:
            raw = self._archive.read(f"{self._folder}/data/{key}")
            code = _STORAGE_DTYPES[storage_type.name]
            if code == "bfloat16":
                bits = np.frombuffer(raw, dtype=self._byteorder + "u2").astype(np.uint32) << 16
                array = bits.view(np.float32)
            else:
                array = np.frombuffer(raw, dtype=np.dtype(code).newbyteorder(self._byteorder))
            if array.size < int(numel):
                raise ValueError(f"storage {key} holds {array.size} values, {numel} expected")
            self._storages[key] = array.astype(array.dtype.newbyteorder("="), copy=False)
        return self._storages[key]


class _Deferred:
    """A tensor of a legacy (non-zip) checkpoint, rebuilt once its storage (stored after the pickle) is read."""

    def __init__(self, storage, offset, size, stride, *_):
        self.storage, self.offset, self.size, self.stride = storage, offset, size, stride


class _LegacyUnpickler(pickle.Unpickler):
    """The object pickle of a pre-1.6 ``torch.save`` file: the same allowed globals as the zip reader, tensors
    deferred (their storages follow the pickle in the file); persistent id
    ``('storage', type, key, location, numel, view)`` with no view."""

    def find_class(self, module: str, name: str):
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _Deferred
        return _WeightsUnpickler.find_class(self, module, name)  # type: ignore[arg-type]

    def persistent_load(self, pid):
        if not (isinstance(pid, tuple) and len(pid) == 6 and pid[0] == "storage"
                and isinstance(pid[1], _StorageType) and pid[5] is None):
            raise ValueError(f"unsupported persistent id {pid!r}")
        return (pid[2], _STORAGE_DTYPES[pid[1].name], int(pid[4]))


class _PlainUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str):
        raise _RefusedGlobal(f"{module}.{name}")


def _read_legacy(stream) -> object:
    """Read a pre-1.6 (non-zip) ``torch.save`` stream: three header pickles (magic number, protocol 1001,
    system info), the object pickle, the list of storage keys, then per storage an int64 element count and
    its raw little- or big-endian bytes. Nothing but tensors and plain containers is built."""
    magic, protocol, info = (_PlainUnpickler(stream).load() for _ in range(3))
    if magic != 0x1950A86A20F9469CFC6C or protocol != 1001 or not isinstance(info, dict):
        raise ValueError("not a PyTorch checkpoint (no legacy torch.save header)")
    order = "<" if info.get("little_endian", True) else ">"
    obj = _LegacyUnpickler(stream).load()
    tensors = list(_deferred(obj))
    codes = {t.storage[0]: t.storage[1] for _, _, t in tensors}
    storages = {}
    for key in _PlainUnpickler(stream).load():
        numel = int(np.frombuffer(stream.read(8), dtype=order + "i8")[0])
        dtype = np.dtype(codes.get(key, "<f4")).newbyteorder(order)
        storages[key] = np.frombuffer(stream.read(numel * dtype.itemsize), dtype=dtype).astype(dtype.newbyteorder("="))
    for parent, name, t in tensors:
        parent[name] = _rebuild_tensor(storages[t.storage[0]], t.offset, t.size, t.stride)
    return obj


def _deferred(obj: object):
    """(dict, key, tensor) of every deferred tensor in ``obj``'s (nested) dicts."""
    if isinstance(obj, dict):
        for name, value in obj.items():
            if isinstance(value, _Deferred):
                yield obj, name, value
            else:
                yield from _deferred(value)


def _read_zip(archive: zipfile.ZipFile, path: Path) -> object:
    """The object pickled in a PyTorch zip checkpoint (storages read from the archive)."""
    with archive:
        pickles = [n for n in archive.namelist() if n.endswith("/data.pkl") and n.count("/") == 1]
        if len(pickles) != 1:
            raise SchemaError("not a PyTorch checkpoint: expected exactly one '<folder>/data.pkl' entry",
                              file=path)
        folder = pickles[0].split("/")[0]
        byteorder = "<"
        if f"{folder}/byteorder" in archive.namelist():
            byteorder = ">" if archive.read(f"{folder}/byteorder").strip() == b"big" else "<"
        unpickler = _WeightsUnpickler(archive.read(pickles[0]), archive, folder, byteorder)
        try:
            obj = unpickler.load()
        except _RefusedGlobal as exc:
            raise SchemaError(f"refusing to load: global '{exc}' is not allowed in a weights file "
                              "(only tensors and plain containers)", file=path) from None
        except Exception as exc:  # corrupt pickle / storage: one clear message, no deep traceback
            raise SchemaError(f"cannot unpickle checkpoint: {type(exc).__name__}: {exc}", file=path) from None
    return obj


def read_pth_state_dict(path: str | Path) -> dict[str, np.ndarray]:
    """Read the model weights of a PyTorch checkpoint (``torch.save``: zip, or the pre-1.6 legacy format of
    e.g. upstream's baeda_3dem) without torch.

    Accepts a ``{'model_state_dict': {...}, ...}`` checkpoint or a bare state dict. The pickle may only
    reference tensor/storage rebuild helpers and ``collections.OrderedDict``; any other global (code) is
    refused with :class:`SchemaError` before anything is executed. Returns name -> numpy array (dtype of the
    stored tensor, C-contiguous copies).
    """
    path = Path(path)
    try:
        archive = zipfile.ZipFile(path)
    except zipfile.BadZipFile:  # the pre-1.6 torch.save format
        archive = None
    except OSError as exc:
        raise SchemaError(f"cannot read as a PyTorch checkpoint ({exc})", file=path) from None
    if archive is None:
        try:
            with open(path, "rb") as stream:
                obj = _read_legacy(stream)
        except _RefusedGlobal as exc:
            raise SchemaError(f"refusing to load: global '{exc}' is not allowed in a weights file "
                              "(only tensors and plain containers)", file=path) from None
        except Exception as exc:  # neither a zip nor a legacy checkpoint, or a corrupt one
            raise SchemaError(f"cannot read as a PyTorch checkpoint (zip or legacy): {type(exc).__name__}: {exc}",
                              file=path) from None
    else:
        obj = _read_zip(archive, path)
    state = obj.get("model_state_dict", obj) if isinstance(obj, dict) else obj
    if not isinstance(state, dict) or not state:
        raise SchemaError("no state dict found (expected a dict of tensors or a 'model_state_dict' entry)",
                          file=path)
    for key, value in state.items():
        if not isinstance(key, str) or not isinstance(value, np.ndarray):
            raise SchemaError(f"state dict entry is not a tensor ({type(value).__name__})", file=path,
                              column=key)
    return dict(state)


def lstm_sizes(state_dict: Mapping[str, np.ndarray]) -> dict[str, int]:
    """``input_size``, ``hidden_size`` and ``num_layers`` of the LSTM in a state dict, read from its weight
    shapes: ``*weight_ih_l0`` is (4 hidden, inputs), one ``*weight_ih_l{k}`` per layer. Empty when the dict
    holds no LSTM of that shape (the weights' own check then names what is wrong)."""
    first = [k for k in state_dict if k.endswith("weight_ih_l0")]
    if len(first) != 1 or np.ndim(state_dict[first[0]]) != 2:
        return {}
    prefix = first[0][: -len("weight_ih_l0")]
    rows, inputs = np.shape(state_dict[first[0]])
    layers = 0
    while f"{prefix}weight_ih_l{layers}" in state_dict:
        layers += 1
    return {"input_size": int(inputs), "hidden_size": int(rows) // 4, "num_layers": layers}


# ------------------------------------------------------------------------------------------ model specs
@dataclass(frozen=True, eq=False)
class LSTMSpec:
    """One trained LSTM temperature model: its weights plus the input contract (a :class:`DynamicsBlock`).

    ``state_dict``: ``<lstm>.weight_ih_l{k}`` (4H, in), ``<lstm>.weight_hh_l{k}`` (4H, H), ``<lstm>.bias_ih_l{k}``,
    ``<lstm>.bias_hh_l{k}`` (4H) for k < num_layers, plus one linear head ``<head>.weight`` (1, H),
    ``<head>.bias`` (1,). ``block``: input names, min-max bounds (same units as the observations: W/m2, degC,
    kWh, people; ``*_sin``/``*_cos`` names are periodic encodings of hour/month/day_type), hidden size,
    layers and lookback; its fields are readable on the spec too (``spec.hidden_size``).
    """

    state_dict: Mapping[str, np.ndarray]
    block: DynamicsBlock
    source: str = "LSTM model"

    @property
    def input_observation_names(self) -> tuple[str, ...]:
        return self.block.input_observation_names

    @property
    def input_normalization_minimum(self) -> tuple[float, ...]:
        return self.block.input_normalization_minimum

    @property
    def input_normalization_maximum(self) -> tuple[float, ...]:
        return self.block.input_normalization_maximum

    @property
    def hidden_size(self) -> int:
        return int(self.block.hidden_size)

    @property
    def num_layers(self) -> int:
        return int(self.block.num_layers)

    @property
    def lookback(self) -> int:
        return int(self.block.lookback)

    def arrays(self) -> dict[str, np.ndarray]:
        """Validated float64 weights: wih (list), whh (list), bias (L, 4H: b_ih + b_hh), wlin (H,), blin."""
        self._check_contract()
        n_in, hid, n_layers, where = len(self.input_observation_names), self.hidden_size, self.num_layers, self.source
        sd = self.state_dict
        lstm = [k[: -len("weight_ih_l0")] for k in sd if k.endswith("weight_ih_l0")]
        if len(lstm) != 1:
            raise SchemaError("expected one LSTM (a single '*weight_ih_l0' key) in the state dict", file=where)
        prefix = lstm[0]
        out: dict = {"wih": [], "whh": [], "bias": []}
        for k in range(n_layers):
            out["wih"].append(_weight(sd, f"{prefix}weight_ih_l{k}", (4 * hid, n_in if k == 0 else hid), where))
            out["whh"].append(_weight(sd, f"{prefix}weight_hh_l{k}", (4 * hid, hid), where))
            out["bias"].append(_weight(sd, f"{prefix}bias_ih_l{k}", (4 * hid,), where)
                               + _weight(sd, f"{prefix}bias_hh_l{k}", (4 * hid,), where))
        if f"{prefix}weight_ih_l{n_layers}" in sd:
            raise SchemaError(f"state dict has more than num_layers={n_layers} layers", file=where)
        heads = [k[: -len("weight")] for k in sd if k.endswith("weight") and not k.startswith(prefix)]
        if len(heads) != 1:
            raise SchemaError("expected one linear head ('*.weight', '*.bias') besides the LSTM", file=where)
        out["wlin"] = _weight(sd, f"{heads[0]}weight", (1, hid), where)[0]
        out["blin"] = float(_weight(sd, f"{heads[0]}bias", (1,), where)[0])
        out["bias"] = np.array(out["bias"])
        return out

    def _check_contract(self) -> None:
        """The input contract: as many bounds as names, the indoor temperature among them, sizes >= 1 and every
        normalization span finite and non-zero."""
        names, where = self.input_observation_names, self.source
        lo, hi = self.input_normalization_minimum, self.input_normalization_maximum
        if not (len(lo) == len(hi) == len(names)):
            raise SchemaError(f"{len(names)} input names but {len(lo)} minima and {len(hi)} maxima", file=where)
        if TEMPERATURE not in names:
            raise SchemaError(f"input_observation_names must include {TEMPERATURE!r}", file=where)
        if self.hidden_size < 1 or self.num_layers < 1 or self.lookback < 1:
            raise SchemaError("hidden_size, num_layers and lookback must be >= 1", file=where)
        span = np.asarray(hi, float) - np.asarray(lo, float)
        if not np.all(np.isfinite(span)) or np.any(span == 0):
            i = int(np.flatnonzero(~np.isfinite(span) | (span == 0))[0])
            raise SchemaError("normalization maximum equals minimum", file=where, column=names[i])


#: largest |weight| a model may have: trained LSTM weights are of order 1 (CityLearn's and ours within +-10);
#: 1e4 leaves room for any plausible training and refuses a finite but absurd file (e.g. 1e30)
MAX_ABS_WEIGHT = 1e4


def _weight(state_dict: Mapping[str, np.ndarray], key: str, shape: tuple[int, ...], where: str) -> np.ndarray:
    """Weight ``key`` of ``state_dict`` as float64, checked present, floating point, of ``shape``, finite and
    within +-:data:`MAX_ABS_WEIGHT`."""
    if key not in state_dict:
        raise SchemaError("missing weight", file=where, column=key)
    stored = np.asarray(state_dict[key])
    if not np.issubdtype(stored.dtype, np.floating):
        raise SchemaError(f"weights must be floating point, found {stored.dtype}", file=where, column=key)
    value = stored.astype(np.float64)
    if value.shape != shape:
        raise SchemaError(f"shape {value.shape}, expected {shape}", file=where, column=key)
    if not np.isfinite(value).all():  # NaN/inf weights would silently poison the temperatures
        raise SchemaError("weights must be finite (found NaN or inf)", file=where, column=key)
    largest = float(np.max(np.abs(value))) if value.size else 0.0
    if largest > MAX_ABS_WEIGHT:
        raise SchemaError(f"a weight of magnitude {largest:.3g} is outside +-{MAX_ABS_WEIGHT:g} (a trained LSTM's "
                          "weights are of order 1): not a usable model", file=where, column=key)
    return value


def spec_from_model(model: DynamicsBlock, *, state_cache: dict | None = None) -> LSTMSpec:
    """An :class:`LSTMSpec` for a :class:`~citylearn_env.dataset.DynamicsBlock` whose ``filename`` is the
    resolved weights path (as :func:`citylearn_env.dataset.parse_dynamics` gives); ``state_cache`` maps
    path -> state dict so a file shared by several buildings is read once."""
    cache = {} if state_cache is None else state_cache
    path = str(model.filename)
    if path not in cache:
        cache[path] = read_pth_state_dict(path)
    return LSTMSpec(cache[path], model, source=path)


# ------------------------------------------------------------------------------------------------- bank
def _parse_input(name: str, periods: Mapping[str, float]) -> tuple[str, int, float]:
    """(raw observation name, kind 0 plain / 1 sin / 2 cos, period) of one model input name."""
    base, kind = split_periodic_name(name, periods)
    return (name, 0, 1.0) if kind is None else (base, 1 if kind == "sin" else 2, periods[base])


class _Group:
    """Stacked weights and state of all model instances that share one architecture."""

    def __init__(self, specs: list[LSTMSpec], raw_index: Mapping[str, int], periods,
                 output_uses_last_input_bounds: bool):
        arrays = [s.arrays() for s in specs]
        first = specs[0]
        n_in, hid, n_layers = len(first.input_observation_names), first.hidden_size, first.num_layers
        self.lookback = first.lookback
        self.wih0t = np.ascontiguousarray(np.stack([a["wih"][0].T for a in arrays]))
        rest = [np.stack([w.T for w in a["wih"][1:]]) if n_layers > 1 else np.zeros((1, hid, 4 * hid))
                for a in arrays]
        self.wihrt = np.ascontiguousarray(np.stack(rest))
        self.whht = np.ascontiguousarray(np.stack([np.stack([w.T for w in a["whh"]]) for a in arrays]))
        self.bias = np.stack([a["bias"] for a in arrays])
        self.wlin = np.stack([a["wlin"] for a in arrays])
        self.blin = np.array([a["blin"] for a in arrays])
        parsed = [[_parse_input(n, periods) for n in s.input_observation_names] for s in specs]
        self.src = np.array([[raw_index[p[0]] for p in row] for row in parsed], dtype=np.int64)
        self.kind = np.array([[p[1] for p in row] for row in parsed], dtype=np.int64)
        self.period = np.array([[p[2] for p in row] for row in parsed], dtype=np.float64)
        self.lo = np.array([s.input_normalization_minimum for s in specs], dtype=np.float64)
        self.span = np.array([s.input_normalization_maximum for s in specs], dtype=np.float64) - self.lo
        self.tcol = np.array([s.input_observation_names.index(TEMPERATURE) for s in specs], dtype=np.int64)
        out_col = np.full(len(specs), n_in - 1) if output_uses_last_input_bounds else self.tcol
        self.out_lo = self.lo[np.arange(len(specs)), out_col].copy()
        self.out_span = self.span[np.arange(len(specs)), out_col].copy()
        self.buf = np.zeros((len(specs), self.lookback + 1, n_in))
        self.count = np.zeros(len(specs), dtype=np.int64)
        self.h = np.zeros((len(specs), n_layers, hid))
        self.c = np.zeros_like(self.h)

    def clear(self, slots) -> None:
        self.buf[slots] = 0.0
        self.count[slots] = 0
        self.h[slots] = 0.0
        self.c[slots] = 0.0


class LSTMBank:
    """The LSTM temperature models of B buildings, advanced together once per environment step.

    ``cooling[b]`` / ``heating[b]`` are building b's models; the heating model serves hvac_mode 2, the cooling
    model every other mode (0 off, 1 cooling, 3 auto). ``heating[b] = None`` uses the cooling model for all modes
    (:func:`build_bank` gives a v2.2+ schema's one model that way with ``settings.lstm_one_model_across_modes``).
    When the selected model of a building changes between steps, the newly selected model starts again from
    an empty buffer and zero state (a new warm-up of ``lookback + 1`` steps).
    ``settings`` fields read here: ``lstm_day_type_period`` (period of day_type_sin/cos, days: 8 in CityLearn
    2.1, 7 corrected), ``lstm_output_uses_last_input_bounds`` (de-normalise the prediction with the last
    input's bounds as CityLearn 2.1, instead of the indoor temperature's own), ``lstm_float32`` (round the
    window and the output to float32 as torch does). ``backend``: "auto" (numba if installed), "numba" or
    "numpy".
    """

    def __init__(self, cooling: Sequence[LSTMSpec], heating: Sequence[LSTMSpec | None] | None = None, *,
                 settings: Behaviour = CORRECTED, backend: str = "auto"):
        if not isinstance(settings, Behaviour):
            raise TypeError(f"settings must be a Behaviour, not {type(settings).__name__}")
        n = len(cooling)
        heating = list(heating) if heating is not None else [None] * n
        if len(heating) != n or n == 0:
            raise SchemaError(f"LSTMBank needs one cooling model per building ({n}) and as many heating entries "
                              f"({len(heating)})", column="dynamics")
        instances = self._model_instances(cooling, heating)
        periods = input_periods(settings)
        names: dict[str, int] = {}
        for spec in instances:
            for name in spec.input_observation_names:
                names.setdefault(_parse_input(name, periods)[0], len(names))
        self.input_names: tuple[str, ...] = tuple(names)
        keys: dict[tuple, list[int]] = {}
        for i, spec in enumerate(instances):
            key = (len(spec.input_observation_names), spec.hidden_size, spec.num_layers, spec.lookback)
            keys.setdefault(key, []).append(i)
        self._groups = [_Group([instances[i] for i in members], names, periods,
                               settings.lstm_output_uses_last_input_bounds) for members in keys.values()]
        self._inst_group = np.zeros(len(instances), dtype=np.int64)
        self._inst_slot = np.zeros(len(instances), dtype=np.int64)
        for g, members in enumerate(keys.values()):
            self._inst_group[members] = g
            self._inst_slot[members] = np.arange(len(members))
        self.settings, self.n_buildings = settings, n
        self._f32 = bool(settings.lstm_float32)
        self._set_backend(backend)
        self._raw = np.zeros((len(names), n))
        self.reset()

    def _model_instances(self, cooling: Sequence[LSTMSpec], heating: Sequence[LSTMSpec | None]) -> list[LSTMSpec]:
        """Every model instance, building by building (cooling, then heating if any); fills ``_table``:
        (B, 2) instance index of each building's cooling and heating model (the cooling one twice without)."""
        instances: list[LSTMSpec] = []
        self._table = np.zeros((len(cooling), 2), dtype=np.int64)
        for b, (cool, heat) in enumerate(zip(cooling, heating, strict=True)):
            instances.append(cool)
            self._table[b] = len(instances) - 1
            if heat is not None:
                instances.append(heat)
                self._table[b, 1] = len(instances) - 1
        return instances

    def _set_backend(self, backend: str) -> None:
        """The group-step kernel: numba's when ``backend`` is "numba", or "auto" and numba is installed."""
        kernel = backends.compiled(backend, lstm_kernels.get_numba_kernel)
        self.backend = "numba" if kernel is not None else "numpy"
        self._kernel = kernel or lstm_kernels.NumpyGroupStep()

    def reset(self) -> None:
        """Empty every buffer and zero every hidden/cell state (episode start)."""
        for group in self._groups:
            group.clear(slice(None))
        self._current = np.full(self.n_buildings, -1, dtype=np.int64)
        self._members: list[tuple[np.ndarray, np.ndarray]] = []
        self._modes_key = b""
        self._warm_flags = np.zeros(self.n_buildings, dtype=bool)

    def load_tiled(self, src: LSTMBank, copies: int) -> None:
        """Put ``copies`` copies of ``src``'s state into this bank, which holds ``copies`` x ``src``'s buildings
        with the same models (building b of copy c is building c x B + b; slot s of copy c in a group is
        c x group size + s): input windows, window fills, hidden and cell states, the model each building ran
        last and whether it was warm. The group members are re-derived at the next step."""
        for a, b in zip(src._groups, self._groups, strict=True):
            b.buf[:] = np.tile(a.buf, (copies, 1, 1))
            b.count[:] = np.tile(a.count, copies)
            b.h[:] = np.tile(a.h, (copies, 1, 1))
            b.c[:] = np.tile(a.c, (copies, 1, 1))
        shift = (np.arange(copies) * len(src._inst_group))[:, None]
        self._current = np.where(src._current >= 0, src._current[None, :] + shift, -1).reshape(-1)
        self._warm_flags = np.tile(src._warm_flags, copies)
        self._modes_key = b""
        self._members = []

    def _instances(self, hvac_mode: ArrayLike) -> np.ndarray:
        heating = np.asarray(hvac_mode).reshape(self.n_buildings) == 2
        return np.where(heating, self._table[:, 1], self._table[:, 0])

    @property
    def is_warm(self) -> np.ndarray:
        """(B,) bool: the model used at the last step has a full buffer (it predicted at that step)."""
        return self._warm_flags.copy()

    def warm(self, hvac_mode: ArrayLike) -> np.ndarray:
        """(B,) bool: the model that ``hvac_mode`` (values at the coming step) selects has a full buffer.

        False where the coming step switches model (its buffer is cleared). CityLearn applies a device action
        to the demand only where this is True.
        """
        modes = np.asarray(hvac_mode, dtype=np.float64).reshape(self.n_buildings)
        if modes.tobytes() == self._modes_key:
            return self._warm_flags.copy()
        return self._warm_flags & (self._instances(modes) == self._current)

    def step(self, obs: Mapping[str, np.ndarray], hvac_mode: ArrayLike) -> np.ndarray:
        """Append the inputs of the current time step and predict its indoor temperature.

        ``obs`` maps every name of :attr:`input_names` to a (B,) array of raw values at t (W/m2, degC, kWh
        *delivered* cooling/heating energy, people, month 1-12, hour 1-24, day_type 1-8); the indoor
        temperature is the value the building holds at t before prediction. ``hvac_mode`` (B,) at t.
        Returns the predicted indoor dry-bulb temperature (B,) in degC, NaN where the buffer is not yet full.
        """
        raw = self._raw  # (n_raw, B): one row per raw input name
        try:
            for j, name in enumerate(self.input_names):
                raw[j] = obs[name]
        except KeyError as exc:
            raise SchemaError(f"LSTM input {exc.args[0]!r} missing from the step inputs",
                              column=exc.args[0]) from None
        return self.step_raw(raw, hvac_mode)

    def step_raw(self, raw: np.ndarray, hvac_mode: ArrayLike) -> np.ndarray:
        """:meth:`step` with the inputs already stacked: ``raw`` (len(input_names), B), rows in
        :attr:`input_names` order (the array is read, not kept)."""
        modes = np.asarray(hvac_mode, dtype=np.float64).reshape(self.n_buildings)
        key = modes.tobytes()
        if key != self._modes_key:  # model selection changes only when hvac_mode does
            inst = self._instances(modes)
            for b in np.flatnonzero(inst != self._current):
                self._groups[self._inst_group[inst[b]]].clear(self._inst_slot[inst[b]])
            self._current = inst
            self._members = []
            for g in range(len(self._groups)):
                bidx = np.flatnonzero(self._inst_group[inst] == g)
                self._members.append((bidx, self._inst_slot[inst[bidx]]))
            self._modes_key = key
            # the kernel's arguments between ``raw`` and ``out`` per group with members (the group arrays
            # change in place only, so the tuple stays valid until the members change)
            self._calls = [(bidx, slots, group.src, group.kind, group.period, group.lo, group.span, group.tcol,
                            group.out_lo, group.out_span, group.buf, group.count, group.wih0t, group.wihrt,
                            group.whht, group.bias, group.wlin, group.blin, group.h, group.c, self._f32)
                           for group, (bidx, slots) in zip(self._groups, self._members, strict=True) if len(bidx)]
        out = np.empty(self.n_buildings)  # every building is in exactly one group and gets written
        for args in self._calls:
            self._kernel(raw, *args, out, self._warm_flags)
        return out


def separate_heating_model(building: Any, settings: Behaviour) -> bool:
    """Whether ``building`` (with ``cooling_model`` / ``heating_model``) runs a heating model of its own: it has
    both, and they are not one v2.2+ ``dynamics`` model that ``settings.lstm_one_model_across_modes`` keeps as one
    (the schema loader hands that model in as the same block twice)."""
    if building.heating_model is None or building.cooling_model is None:
        return False
    return not (settings.lstm_one_model_across_modes and building.heating_model is building.cooling_model)


def build_bank(buildings: Sequence, *, settings: Behaviour = CORRECTED, backend: str = "auto") -> LSTMBank:
    """An :class:`LSTMBank` for buildings with ``cooling_model`` / ``heating_model`` config attributes, with
    the ``lstm_*`` quirks that ``settings`` selects."""
    cache: dict = {}
    cooling = [spec_from_model(b.cooling_model or b.heating_model, state_cache=cache) for b in buildings]
    heating = [spec_from_model(b.heating_model, state_cache=cache) if separate_heating_model(b, settings) else None
               for b in buildings]
    return LSTMBank(cooling, heating, settings=settings, backend=backend)

