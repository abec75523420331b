"""Compilation of the hot loops (numba, cached on disk).

Plant derivatives, RK4, path projection, control laws and allocation run 2000
times per simulated second (200 Hz controller, 5 ms substeps); in Python they
cost more than SUMO's own stepping. The planner's collision check loops over
candidates x samples x TV hypotheses with early exits. Both are compiled with
numba in nopython mode and work on float64 arrays. `cache=True` keeps the machine code
in `__pycache__`, so a fresh process loads it instead of compiling again.
No fastmath: results match the interpreted arithmetic operation by operation
(IEEE order kept), up to the last bit of libm's sin/cos/atan.

numba itself is imported only when a compiled function is first called (about
0.4 s to import, 0.7 s to set up its compiler on the first call, then a few ms
per cached function): what neither plans nor steps a vehicle (`--help`, input
errors) does not pay for it. Until then `njit` returns a stand-in; the first call
compiles every function declared so far and puts the compiled functions
in place of the stand-ins in every loaded `cosim` module, so compiled code
calling compiled code finds compiled functions. `warm_up` does all of this
ahead of time (a fork server calls it once for all its children).

Cache invalidation: numba checks only the timestamp of a cached function's own
file, so a caller cached before its callee (in another file) changed would keep
the old callee's code. The cache therefore lives in a directory named after a
hash of the sources of every module that defines compiled functions
(`__pycache__/numba/<hash>` beside this package, or under NUMBA_CACHE_DIR):
any change to one of them starts a fresh cache (about 10 s of compiling once for
the closed loop, 12 s for the collision check).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
F = TypeVar("F", bound=Callable[..., Any])


class _Deferred:
    """A function to be compiled with numba on first use (see the module docstring)."""

    def __init__(self, fn: Callable[..., Any]) -> None:
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self.compiled: Callable[..., Any] | None = None
        _PENDING.append(self)

    def __call__(self, *args: Any) -> Any:
        if self.compiled is None:
            _compile_all()
        assert self.compiled is not None
        return self.compiled(*args)


_PENDING: list[_Deferred] = []


def _compile_all() -> None:
    """Wrap every deferred function with numba.njit and rebind the stand-ins in the
    loaded cosim modules (numba resolves a callee through its caller's globals)."""
    from numba import njit as numba_njit
    from numba.core import config

    user_dir = config.CACHE_DIR
    config.CACHE_DIR = str(_cache_dir(user_dir))
    try:
        for d in _PENDING:
            if d.compiled is None:
                # no fastmath; error_model="numpy": x / 0 gives inf or NaN as in numpy,
                # which the closed loop's finiteness checks catch
                d.compiled = numba_njit(cache=True, error_model="numpy")(d.py_func)
    finally:
        config.CACHE_DIR = user_dir  # the directory is bound to each function already
    for name, module in list(sys.modules.items()):
        if name == "cosim" or name.startswith("cosim."):
            for attr, value in list(vars(module).items()):
                if isinstance(value, _Deferred) and value.compiled is not None:
                    setattr(module, attr, value.compiled)


def _cache_dir(user_dir: str) -> Path:
    """Where the cache goes: a directory per hash of the compiled modules' sources."""
    digest = hashlib.sha1()
    for path in sorted({inspect.getsourcefile(d.py_func) or "" for d in _PENDING}):
        digest.update(path.encode())
        digest.update(Path(path).read_bytes())
    base = Path(user_dir) if user_dir else Path(__file__).resolve().parent / "__pycache__"
    return base / "numba" / digest.hexdigest()[:16]


def njit(fn: F) -> F:
    """Mark fn for numba compilation (nopython, cached on disk, no fastmath)."""
    return _Deferred(fn)  # type: ignore[return-value]


def warm_up() -> None:
    """Import numba and compile (or load from the cache) every compiled function now:
    one step of every plant and controller, one collision check of each kind."""
    from cosim.control.closed_loop import warm_up as loop_warm_up
    from cosim.planning.collision import warm_up as check_warm_up

    loop_warm_up()
    check_warm_up()


def cache_warm() -> bool:
    """Whether numba's disk cache already holds (nearly) every compiled function of
    the current sources, so that `warm_up` loads rather than compiles (a callee
    compiled only inside its caller has no entry of its own, hence 'nearly')."""
    import cosim.control.closed_loop  # noqa: F401  (declares the closed loop's functions)
    import cosim.planning.collision  # noqa: F401  (... and the collision check's)

    user_dir = os.environ.get("NUMBA_CACHE_DIR", "")
    folder = _cache_dir(user_dir)
    if not folder.is_dir():
        return False
    return len(list(folder.rglob("*.nbi"))) >= 0.9 * len(_PENDING)
