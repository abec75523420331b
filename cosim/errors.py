"""The project's exception types.

Everything a user can cause (a bad scenario, a bad flag, a missing network)
raises `InputError`; the CLI prints it on one line and exits with status 2.
Faults found while running (NaN in a plant, SUMO losing a vehicle) raise
`SimulationError` with the simulation time, the state and the cause.
A signal (SIGINT, SIGTERM, SIGHUP) is only noted when it comes; `check_signals`, called
where unwinding is safe (each step of a run, a batch's wait for its runs), raises it as
KeyboardInterrupt (`Terminated`, `HungUp` for the others), which unwinds through the same
clean-up as Ctrl-C (exit status 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP).
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator
from typing import Any

EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT)
EXIT_TERMINATED = 143  # SIGTERM (128 + SIGTERM)
EXIT_HANGUP = 129  # SIGHUP (128 + SIGHUP): the terminal went away


class CosimError(Exception):
    """Base of every error cosim raises on purpose."""


class InputError(CosimError):
    """Bad user input: one line naming the file, the key, the value and what is allowed."""

    def __init__(self, source: str, key: str, value: Any, allowed: str) -> None:
        self.source = str(source)
        self.key = key
        self.value = value
        self.allowed = allowed
        shown = repr(value)
        if len(shown) > 240:
            shown = shown[:237] + "..."
        message = f"{self.source}: {key} = {shown}: {allowed}"
        super().__init__(" ".join(message.split()))


class OutputError(CosimError):
    """A result could not be written (a full disk, a read-only or vanished folder, a full
    standard output): one line naming where and why; exit status 2, as for bad input,
    since the fix is the user's (another --out, free space). What was there before stays."""

    def __init__(self, where: str, exc: BaseException | str, note: str = "") -> None:
        self.where = str(where)
        reason = exc if isinstance(exc, str) else (
            getattr(exc, "strerror", None) or f"{type(exc).__name__}: {exc}")
        self.reason = reason
        text = f"cannot write {self.where}: {reason}" + (f"; {note}" if note else "")
        super().__init__(" ".join(text.split()))


class SimulationError(CosimError):
    """A run stopped because something went wrong inside it (numerics, SUMO)."""

    def __init__(self, time_s: float, cause: str, state: str = "") -> None:
        self.time_s = time_s
        self.cause = cause
        self.state = state
        text = f"at t = {time_s:.3f} s: {cause}"
        if state:
            text += f" (state: {state})"
        super().__init__(" ".join(text.split()))


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised at the next signal check (`check_signals`), so `finally` blocks and
    staged output clean up exactly as for Ctrl-C."""

    exit_status = EXIT_TERMINATED


class HungUp(Terminated):
    """SIGHUP (the terminal closed), unwound like SIGTERM."""

    exit_status = EXIT_HANGUP


_RECEIVED: list[int] = []  # exit statuses of the signals this process received, in order
_PENDING: list[int] = []  # those received and not yet acted on by `check_signals`
# What each signal's exit status is called on stderr.
SIGNAL_WORDS = {EXIT_TERMINATED: "terminated (SIGTERM)", EXIT_HANGUP: "hung up (SIGHUP)"}


def _note_signal(signum: int, frame: Any) -> None:
    """The handler of SIGINT, SIGTERM and SIGHUP: it only notes the signal. Raising here
    would raise wherever Python happens to be, and inside a weakref callback (the import
    machinery's module locks) or a `__del__` the exception is printed and dropped: the run
    would go on as if nothing came."""
    del frame
    status = _STATUS[signum]
    _RECEIVED.append(status)
    _PENDING.append(status)


def _unwinding(status: int) -> KeyboardInterrupt:
    """The exception a signal's exit status unwinds as."""
    if status == EXIT_TERMINATED:
        return Terminated(SIGNAL_WORDS[status])
    if status == EXIT_HANGUP:
        return HungUp(SIGNAL_WORDS[status])
    return KeyboardInterrupt()


_STATUS = {signal.SIGINT: EXIT_INTERRUPTED, signal.SIGTERM: EXIT_TERMINATED}
if hasattr(signal, "SIGHUP"):  # POSIX
    _STATUS[signal.SIGHUP] = EXIT_HANGUP


def signals_as_interrupts() -> dict[int, Any]:
    """Note SIGINT, SIGTERM and SIGHUP as they come (main thread only); `check_signals`
    then raises KeyboardInterrupt, `Terminated` or `HungUp` at a point where unwinding is
    safe. Returns the previous handlers, by signal, for `signal.signal` to put back
    (empty: nothing was changed)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}
    _PENDING.clear()
    return {signum: signal.signal(signum, _note_signal) for signum in _STATUS}


def signals_noted() -> bool:
    """True when this process's signal handlers note signals for `check_signals`."""
    return signal.getsignal(signal.SIGINT) is _note_signal


def signal_pending() -> bool:
    """True when a signal came that no `check_signals` has acted on yet."""
    return bool(_PENDING)


def check_signals() -> None:
    """Act on a signal received since the last check: raise KeyboardInterrupt (SIGINT),
    `Terminated` (SIGTERM) or `HungUp` (SIGHUP); the first signal decides, the others
    that came with it are spent. The run's loop calls this once per step, the batch while
    it waits for its runs, and whatever waits long elsewhere (SUMO's start, the demand's
    validation, the warm-up) as it waits."""
    if _PENDING:
        status = _PENDING[0]
        _PENDING.clear()
        raise _unwinding(status)


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """A short critical section (a folder swap and its clean-up) that a signal does not
    cut: one that comes during it is acted on at its end. With `signals_as_interrupts`'
    handlers in place signals only ever are noted, so the end is a `check_signals`; under
    other handlers (Python's own, a library caller's), SIGINT, SIGTERM and SIGHUP are held
    and the first is delivered at the end through the handler in place before. Only the
    main thread gets Python signal handlers; elsewhere this does nothing."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if signals_noted():
        try:
            yield
        finally:
            check_signals()
        return
    held: list[int] = []

    def hold(signum: int, frame: Any) -> None:
        del frame
        held.append(signum)

    previous = {signum: signal.signal(signum, hold) for signum in _STATUS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in held[:1]:  # the first is enough: it ends the command
            handler = previous[signum]
            if callable(handler):
                handler(signum, None)
            elif handler != signal.SIG_IGN:
                signal.raise_signal(signum)  # SIG_DFL: what the signal would have done


def interrupted_status() -> int | None:
    """The exit status of the last signal that interrupted this process (None: none).
    An interrupt raised inside a C extension's import (matplotlib's, say) reaches Python
    as an ImportError, not as KeyboardInterrupt: the caller asks this to tell."""
    return _RECEIVED[-1] if _RECEIVED else None
