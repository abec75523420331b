"""The project's exception types.

Everything a user can cause (a bad scenario, a bad flag, a missing network)
raises `InputError`; the CLI prints it on one line and exits with status 2.
Faults found while running (NaN in a plant, SUMO losing a vehicle) raise
`SimulationError` with the simulation time, the state and the cause.
SIGTERM is turned into `Terminated`, a KeyboardInterrupt, so it unwinds through the same
clean-up as Ctrl-C (exit status 130 for Ctrl-C, 143 for SIGTERM).
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
    """SIGTERM, raised where Python next runs, so `finally` blocks and staged output clean
    up exactly as for Ctrl-C."""

    exit_status = EXIT_TERMINATED


_RECEIVED: list[int] = []  # exit statuses of the signals this process received, in order


def _raise_interrupted(signum: int, frame: Any) -> None:
    del signum, frame
    _RECEIVED.append(EXIT_INTERRUPTED)
    raise KeyboardInterrupt


def _raise_terminated(signum: int, frame: Any) -> None:
    del signum, frame
    _RECEIVED.append(EXIT_TERMINATED)
    raise Terminated("terminated (SIGTERM)")


class HungUp(Terminated):
    """SIGHUP (the terminal closed), unwound like SIGTERM."""

    exit_status = EXIT_HANGUP


def _raise_hangup(signum: int, frame: Any) -> None:
    del signum, frame
    _RECEIVED.append(EXIT_HANGUP)
    raise HungUp("hung up (SIGHUP)")


# What each signal's exit status is called on stderr.
SIGNAL_WORDS = {EXIT_TERMINATED: "terminated (SIGTERM)", EXIT_HANGUP: "hung up (SIGHUP)"}


def signals_as_interrupts() -> dict[int, Any]:
    """Make SIGINT raise KeyboardInterrupt, SIGTERM `Terminated` and SIGHUP `HungUp` (main
    thread only),
    each remembered (`interrupted_status`); returns the previous handlers, by signal, for
    `signal.signal` to put back (empty: nothing was changed)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}
    handlers = [(signal.SIGINT, _raise_interrupted), (signal.SIGTERM, _raise_terminated)]
    if hasattr(signal, "SIGHUP"):  # POSIX
        handlers.append((signal.SIGHUP, _raise_hangup))
    return {signum: signal.signal(signum, handler) for signum, handler in handlers}


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM for the duration of a short critical section (a folder swap
    and its clean-up) and deliver them after it, through the handlers in place before.
    Only the main thread gets Python signal handlers; elsewhere this does nothing."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: Any) -> None:
        del frame
        held.append(signum)

    signums = [signal.SIGINT, signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP")
                                                 else [])
    previous = {signum: signal.signal(signum, hold) for signum in signums}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in held[:1]:  # the first is enough: it ends the command
            handler = previous[signum]
            if callable(handler):
                handler(signum, None)  # ours raise KeyboardInterrupt / Terminated
            elif handler != signal.SIG_IGN:
                signal.raise_signal(signum)  # SIG_DFL: what the signal would have done


def interrupted_status() -> int | None:
    """The exit status of the last signal that interrupted this process (None: none).
    An interrupt raised inside a C extension's import (matplotlib's, say) reaches Python
    as an ImportError, not as KeyboardInterrupt: the caller asks this to tell."""
    return _RECEIVED[-1] if _RECEIVED else None
