"""Progress bars whose ETA comes from a warm-up rate, not from the first steps.

tqdm estimates the remaining time from its rate since the start, smoothed; the first
step of a run carries one-off costs (SUMO's first steps, loading compiled code, a
pool's workers starting), so its first ETA can read minutes for a 10 s run. Here the ETA
is `--:--` until `warm` units are done, then (units left) x (seconds per unit since
the warm-up ended). The bar is drawn on a terminal only: in a log or a pipe the progress is
a plain line every few seconds (`PlainProgress`).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

# What the bar shows: tqdm's own remaining-time field replaced by ours in the postfix
# (the rate keeps the unit in the line: "12.3 step/s").
BAR_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}, {rate_fmt}{postfix}]"


def warm_units(total: int, share: float = 0.05, least: int = 1, most: int = 50) -> int:
    """The units counted as warm-up: a share of the total, within [least, most]."""
    return max(least, min(most, int(total * share)))


class WarmEta:
    """The ETA from the rate after the warm-up (s per unit), or None before."""

    def __init__(self, total: int, warm: int, clock: Callable[[], float] = time.perf_counter):
        self.total, self.warm, self.clock = total, warm, clock
        self.n = 0
        self.warm_at: tuple[int, float] | None = None  # (units, time) when warm-up ended

    def update(self, n: int = 1) -> float | None:
        """Count n more units done; return the seconds left (None: still warming up)."""
        self.n += n
        now = self.clock()
        if self.warm_at is None:
            if self.n >= self.warm:
                self.warm_at = (self.n, now)
            return None
        done, since = self.n - self.warm_at[0], now - self.warm_at[1]
        if done <= 0:
            return None
        return max(self.total - self.n, 0) * since / done


def eta_text(seconds: float | None) -> str:
    """'ETA mm:ss' (or h:mm:ss), '--:--' while unknown."""
    if seconds is None:
        return "ETA --:--"
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    return f"ETA {h}:{rest // 60:02d}:{rest % 60:02d}" if h else f"ETA {s // 60:02d}:{s % 60:02d}"


PLAIN_EVERY = 5.0  # s between two plain progress lines (a log, a pipe)


def is_terminal(stream: Any) -> bool:
    """True when `stream` is a terminal (a bar redraws in place there, not in a log)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # no isatty, or closed
        return False


class Bar:
    """A progress bar with the warm-up ETA (`update(n)`, `close()`, a context manager);
    extra postfix fields (`postfix(done=..., failed=...)`) are shown before it.

    On a terminal it is a tqdm bar redrawn in place; anywhere else (a log file, a pipe)
    it writes a plain line when it starts, then at most one every PLAIN_EVERY seconds,
    and, with `leave`, one when it closes."""

    def __init__(self, total: int, *, desc: str, unit: str, warm: int | None = None,
                 initial: int = 0, disable: bool = False, leave: bool = True,
                 file: Any = None, clock: Callable[[], float] = time.perf_counter) -> None:
        self.eta = WarmEta(total - initial, warm if warm is not None else warm_units(total),
                           clock)
        self.fields: dict[str, Any] = {}
        self.left: float | None = None
        self.file = file or sys.stderr
        self.plain = not disable and not is_terminal(self.file)
        self.bar: Any = None
        if self.plain:
            self._plain = PlainProgress(total, initial, desc, unit, leave, self.file, clock)
            self._plain.line(self._postfix_text())
            return
        from tqdm import tqdm

        self.bar = tqdm(total=total, initial=initial, desc=desc, unit=unit,
                        disable=disable, leave=leave, file=self.file,
                        dynamic_ncols=True, bar_format=BAR_FORMAT)
        try:
            self._show(refresh=True)
        except BaseException:  # Ctrl-C before the caller's `with` holds the bar: end its line
            self.bar.close()
            raise

    @property
    def n(self) -> int:
        return self._plain.n if self.plain else int(self.bar.n)

    def postfix(self, **fields: Any) -> None:
        self.fields.update(fields)
        if not self.plain:
            self._show(refresh=True)

    def _postfix_text(self) -> str:
        return ", ".join([f"{k}={v}" for k, v in self.fields.items()] + [eta_text(self.left)])

    def _show(self, refresh: bool = False) -> None:
        self.bar.set_postfix_str(self._postfix_text(), refresh=refresh)

    def update(self, n: int = 1) -> None:
        self.left = self.eta.update(n)
        if self.plain:
            self._plain.update(n, self._postfix_text())
            return
        self._show()  # drawn by update, at tqdm's own pace
        self.bar.update(n)

    def close(self) -> None:
        if self.plain:
            self._plain.close(self._postfix_text())
        else:
            self.bar.close()

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class PlainProgress:
    """Progress as whole lines, for a stream that is not a terminal: `desc: n/total unit
    [elapsed, rate, fields]`, one at most every PLAIN_EVERY seconds."""

    def __init__(self, total: int, initial: int, desc: str, unit: str, leave: bool,
                 file: Any, clock: Callable[[], float]) -> None:
        self.total, self.n, self.desc, self.unit = total, initial, desc, unit
        self.leave, self.file, self.clock = leave, file, clock
        self.start = self.last = clock()
        self.initial = initial
        self.closed = False

    def line(self, postfix: str) -> None:
        now = self.last = self.clock()
        elapsed = now - self.start
        done = self.n - self.initial
        rate = f"{done / elapsed:.2f} {self.unit}/s" if done and elapsed > 0 else \
            f"? {self.unit}/s"
        minutes, seconds = divmod(int(elapsed), 60)
        print(f"{self.desc}: {self.n}/{self.total} {self.unit} [{minutes:02d}:{seconds:02d}, "
              f"{rate}, {postfix}]", file=self.file, flush=True)

    def update(self, n: int, postfix: str) -> None:
        self.n += n
        if self.clock() - self.last >= PLAIN_EVERY:
            self.line(postfix)

    def close(self, postfix: str) -> None:
        if self.closed:
            return
        self.closed = True
        if self.leave:
            self.line(postfix)
