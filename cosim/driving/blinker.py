"""A policy's blinker: set in the world (its port) only when it changes, and since when
it shows its direction, so that a change is started only once it has been shown for
the policy's notice (its V2V partners' time to hear it: cosim.run.announcements)."""

from __future__ import annotations

from collections.abc import Callable


class Blinker:
    """The blinker behind the `port` (-1 right, 0 off, +1 left); `notice` (s) how long
    it shows a direction before the policy may start a change (0: at once)."""

    def __init__(self, port: Callable[[int], None], notice: float = 0.0) -> None:
        self.port = port
        self.notice = notice
        self.direction = 0
        self.since = 0.0  # s, when the direction set with a time began

    def set(self, direction: int, t: float | None = None) -> None:
        """Show `direction`; a change given with its time `t` starts the notice."""
        if direction != self.direction:
            self.direction = direction
            if t is not None:
                self.since = t
            self.port(direction)

    def noticed(self, t: float) -> bool:
        """Whether the direction has been shown for the notice at t."""
        return self.notice <= 0.0 or t - self.since >= self.notice - 1e-9
