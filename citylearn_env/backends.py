"""Which implementation steps the physics: numba's compiled kernels or the numpy reference functions (the
numbers are the same; the kernels are faster where numba is installed)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

K = TypeVar("K")

#: "auto": the compiled kernels when numba is installed, else numpy; "numba": the kernels or ImportError
BACKENDS = ("auto", "numba", "numpy")


def compiled(backend: str, load: Callable[[], K | None]) -> K | None:
    """The compiled kernels ``load()`` gives for ``backend`` (None: step with numpy). ``load`` returns None
    when numba is not installed."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be 'auto', 'numba' or 'numpy', not {backend!r}")
    kernels = load() if backend != "numpy" else None
    if backend == "numba" and kernels is None:
        raise ImportError("backend='numba' needs the numba package")
    return kernels
