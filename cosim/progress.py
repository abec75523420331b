"""Progress bars whose ETA comes from a warm-up rate, not from the first steps.

tqdm estimates the remaining time from its rate since the start, smoothed; the first
step of a run carries one-off costs (SUMO's first steps, loading compiled code, a
pool's workers starting), so its first ETA can read minutes for a 10 s run. Here the ETA
is `--:--` until `warm` units are done, then (units left) x (seconds per unit since
the warm-up ended).
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


class Bar:
    """A tqdm bar with the warm-up ETA (`update(n)`, `close()`, a context manager);
    extra postfix fields (`postfix(done=..., failed=...)`) are shown before it."""

    def __init__(self, total: int, *, desc: str, unit: str, warm: int | None = None,
                 initial: int = 0, disable: bool = False, leave: bool = True,
                 file: Any = None) -> None:
        from tqdm import tqdm

        self.eta = WarmEta(total - initial, warm if warm is not None else warm_units(total))
        self.fields: dict[str, Any] = {}
        self.bar = tqdm(total=total, initial=initial, desc=desc, unit=unit,
                        disable=disable, leave=leave, file=file or sys.stderr,
                        dynamic_ncols=True, bar_format=BAR_FORMAT)
        self.left: float | None = None
        try:
            self._show(refresh=True)
        except BaseException:  # Ctrl-C before the caller's `with` holds the bar: end its line
            self.bar.close()
            raise

    @property
    def n(self) -> int:
        return int(self.bar.n)

    def postfix(self, **fields: Any) -> None:
        self.fields.update(fields)
        self._show(refresh=True)

    def _show(self, refresh: bool = False) -> None:
        parts = [f"{k}={v}" for k, v in self.fields.items()] + [eta_text(self.left)]
        self.bar.set_postfix_str(", ".join(parts), refresh=refresh)

    def update(self, n: int = 1) -> None:
        self.left = self.eta.update(n)
        self._show()  # drawn by update, at tqdm's own pace
        self.bar.update(n)

    def close(self) -> None:
        self.bar.close()

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
