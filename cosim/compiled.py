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
errors) does not pay for it. Until then `njit` returns a stand-in (`_Deferred`);
the first call compiles every function declared so far. A stand-in stays where it
is (no module's names are rebound): numba compiles a copy of each function whose
globals hold the compiled callees instead of their stand-ins, so compiled code
calls compiled code directly, and Python callers go through the stand-in.
Each module with compiled functions registers its own warm-up
(`register_warm_up`); `warm_up` runs those of the modules loaded so far (import
`cosim.control.warm` to load and warm them all: a fork server does it once for
all its children).

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
import types
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

    @property
    def signatures(self) -> list[Any]:
        """The compiled signatures so far (numba's; empty before the first call)."""
        return [] if self.compiled is None else list(self.compiled.signatures)  # type: ignore[attr-defined]


_PENDING: list[_Deferred] = []
_WARM_UPS: list[Callable[[], None]] = []


def _compile_all() -> None:
    """Wrap every deferred function with numba.njit. numba resolves a callee through
    its caller's globals: each function is compiled as a copy whose globals map the
    stand-ins to their compiled functions (the modules' own names stay as they are)."""
    from numba import njit as numba_njit
    from numba.core import config

    new = [d for d in _PENDING if d.compiled is None]
    user_dir = config.CACHE_DIR
    config.CACHE_DIR = str(_cache_dir(user_dir))
    try:
        scopes: list[tuple[dict[str, Any], dict[str, Any]]] = []
        for d in new:
            fn = d.py_func
            scope: dict[str, Any] = {}
            copy = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__,
                                      fn.__closure__)
            copy.__qualname__ = fn.__qualname__
            copy.__module__ = fn.__module__
            copy.__doc__ = fn.__doc__
            # no fastmath; error_model="numpy": x / 0 gives inf or NaN as in numpy,
            # which the closed loop's finiteness checks catch
            d.compiled = numba_njit(cache=True, error_model="numpy")(copy)
            scopes.append((scope, fn.__globals__))
    finally:
        config.CACHE_DIR = user_dir  # the directory is bound to each function already
    # filled once every stand-in has its dispatcher (numba reads globals at compile time)
    for scope, module_globals in scopes:
        scope.update({name: value.compiled if isinstance(value, _Deferred) else value
                      for name, value in module_globals.items()})


def _cache_dir(user_dir: str) -> Path:
    """Where the cache goes: a directory per hash of the compiled modules' sources."""
    digest = hashlib.sha1()
    for path in sorted({inspect.getsourcefile(d.py_func) or "" for d in _PENDING}):
        digest.update(path.encode())
        digest.update(Path(path).read_bytes())
    return _cache_base(user_dir) / "numba" / digest.hexdigest()[:16]


def _cache_base(user_dir: str) -> Path:
    """NUMBA_CACHE_DIR if set; else `__pycache__` beside this package if it can be written
    (a checkout, a user's venv); else (a read-only install) the user's cache folder,
    `$XDG_CACHE_HOME/cosim` or `~/.cache/cosim`. numba itself would fall back to a folder of
    its own there, and the folder `cache_warm` looks in and `compile_first` names would be
    the wrong one."""
    if user_dir:
        return Path(user_dir)
    in_tree = Path(__file__).resolve().parent / "__pycache__"
    if _writable(in_tree):
        return in_tree
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "cosim"


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(folder, os.W_OK | os.X_OK)


def cache_folder() -> Path:
    """The folder numba's cache of the compiled functions declared so far goes to."""
    return _cache_dir(os.environ.get("NUMBA_CACHE_DIR", ""))


def njit(fn: F) -> F:
    """Mark fn for numba compilation (nopython, cached on disk, no fastmath)."""
    return _Deferred(fn)  # type: ignore[return-value]


# every module that declares compiled functions and registers a warm-up (cosim.control.warm
# loads them; their sources name the cache's folder, so a cache check needs them all)
COMPILED_MODULES = ("cosim.control.closed_loop", "cosim.control.loop_batch",
                    "cosim.planning.collision", "cosim.planning.envelope",
                    "cosim.planning.interaction",
                    "cosim.road.frame", "cosim.run.proximity")


def load_compiled_modules() -> None:
    """Import COMPILED_MODULES (declaring their functions; nothing is compiled yet)."""
    import importlib

    for name in COMPILED_MODULES:
        importlib.import_module(name)


def register_warm_up(fn: Callable[[], None]) -> Callable[[], None]:
    """Declare a module's warm-up (a call of each of its compiled functions); returns fn."""
    if fn not in _WARM_UPS:
        _WARM_UPS.append(fn)
    return fn


def warm_up() -> None:
    """Import numba and compile (or load from the cache) the compiled functions now, by
    the warm-ups registered by the modules loaded so far (`cosim.control.warm` loads
    the closed loop's and the collision check's)."""
    for fn in list(_WARM_UPS):
        fn()


def cache_warm() -> bool:
    """Whether numba's disk cache already holds (nearly) every compiled function declared
    so far, so that `warm_up` loads rather than compiles (a callee compiled only inside
    its caller has no entry of its own, hence 'nearly'). Import the compiled modules
    first: the cache's folder is named after their sources."""
    folder = cache_folder()
    if not folder.is_dir():
        return False
    return len(list(folder.rglob("*.nbi"))) >= 0.9 * len(_PENDING)
