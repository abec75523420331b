"""A child process (SUMO validating a demand, say) bounded in time and memory, that dies
with its parent.

`run_bounded` starts the command with its address space capped (RLIMIT_AS) and, on
Linux, asks the kernel to SIGKILL it when its parent dies (PR_SET_PDEATHSIG): a cosim
killed by SIGKILL leaves no SUMO running behind it. While it waits it acts on a signal
the parent received (`cosim.errors.check_signals`), killing the child first; a child
that outlives its time is killed too, and the caller is told (`Bounded.timed_out`).
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from cosim.errors import check_signals

PR_SET_PDEATHSIG = 1  # prctl(2): the signal a process gets when its parent thread ends
SIGNAL_POLL = 0.2  # s, how often the wait for the child looks for a signal


@dataclass(frozen=True)
class Bounded:
    """What a bounded child did: its exit status (negative: the signal that ended it),
    its output and error streams, and whether it was killed for outliving its time."""

    returncode: int
    stdout: str
    stderr: str
    timed_out: bool


def _child_setup(memory_bytes: int | None) -> Callable[[], None] | None:
    """The function the child runs between fork and exec: its memory cap, and its death
    with the parent (Linux). Everything it calls is looked up before the fork."""
    import resource

    prctl = None
    if sys.platform.startswith("linux"):
        try:
            prctl = ctypes.CDLL(None, use_errno=True).prctl
        except (OSError, AttributeError):
            prctl = None
    parent = os.getpid()
    limit = resource.RLIMIT_AS
    if prctl is None and memory_bytes is None:
        return None

    def setup() -> None:
        if prctl is not None:
            prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
            if os.getppid() != parent:  # the parent died before the request: no one waits
                os._exit(1)
        if memory_bytes is not None:
            resource.setrlimit(limit, (memory_bytes, memory_bytes))

    return setup


def run_bounded(cmd: Sequence[str], *, timeout: float, memory_bytes: int | None = None,
                cwd: str | Path | None = None) -> Bounded:
    """Run `cmd` to its end, at most `timeout` seconds (then it is killed), its address
    space at most `memory_bytes` (None: unbounded); its output captured as text. A signal
    the parent receives meanwhile kills the child, then unwinds (`check_signals`); so
    does any other exception. OSError if it cannot start."""
    proc = subprocess.Popen(list(cmd), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, text=True, errors="replace", cwd=cwd,
                            preexec_fn=_child_setup(memory_bytes))
    deadline = time.monotonic() + timeout
    try:
        while True:
            check_signals()
            try:
                out, err = proc.communicate(timeout=SIGNAL_POLL)
                return Bounded(proc.returncode, out, err, timed_out=False)
            except subprocess.TimeoutExpired:
                if time.monotonic() >= deadline:
                    proc.kill()
                    out, err = proc.communicate()
                    return Bounded(proc.returncode, out, err, timed_out=True)
    finally:
        if proc.poll() is None:  # left by a signal or an error: the child goes too
            proc.kill()
            proc.wait()
