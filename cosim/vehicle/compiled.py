"""Compilation of the closed loop's hot functions (numba, cached on disk).

Plant derivatives, RK4, path projection, control laws and allocation run 2000
times per simulated second (200 Hz controller, 5 ms substeps); in Python they
cost more than SUMO's own stepping. They are compiled with numba in nopython
mode and work on float64 arrays in place. `cache=True` keeps the machine code
in `__pycache__`, so a fresh process loads it instead of compiling again.
No fastmath: results match the interpreted arithmetic operation by operation
(IEEE order kept), up to the last bit of libm's sin/cos/atan.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from numba import njit as _njit
from numpy.typing import NDArray

Array = NDArray[np.float64]
F = TypeVar("F", bound=Callable[..., Any])


def njit(fn: F) -> F:
    """numba.njit with the on-disk cache, no fastmath, no error model checks beyond
    Python's (division by zero gives inf/NaN as numpy does, caught by the finiteness
    checks of the closed loop)."""
    return _njit(cache=True, error_model="numpy")(fn)  # type: ignore[no-any-return]
