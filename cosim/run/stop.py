"""The stop rules: when a run ends before its last step, and with which row.

- our check's first collision onset, with `[scenario] on_collision = "stop"` (the
  default): a crash ends the ride, the SV never drives on through the TV;
- our SV (driven by moveToXY) with its front within one step of the end of a lane
  that ends: SUMO would drop a vehicle moved past the end of its lane. A policy that
  makes the mandatory lane change, or stops before the end, never meets it; SUMO's
  own driver stops there by itself, so the rule is only for an SV that tracks a
  reference.

The loop asks `StopRules.stops` once per row, after recording it; the row it stops at
is the trace's last (`last_row`), and the metrics row says why (`by_collision`,
`at_lane_end`).
"""

from __future__ import annotations

import math

from cosim.params import RoadParams
from cosim.traffic.world import SVState


class StopRules:
    """Why and at which row one run ends (see the module docstring)."""

    def __init__(self, road: RoadParams, sv_length: float, dt: float, n_steps: int, *,
                 on_collision: bool, at_lane_ends: bool) -> None:
        self.road = road
        self.sv_length = sv_length  # m
        self.dt = dt  # s, one co-simulation step
        self.on_collision = on_collision  # stop at the first collision onset
        self.at_lane_ends = at_lane_ends  # stop our SV at the end of a lane that ends
        self.last_row = n_steps  # the run's last trace row
        self.by_collision = False  # the run stopped at its first collision onset
        self.at_lane_end = False  # the run stopped: our SV reached the end of its lane

    def stops(self, k: int, sv: SVState, first_collision: tuple[float, str] | None) -> bool:
        """True if the run ends with row k: the first collision onset is recorded
        (`first_collision`, when `on_collision`), or the SV is at the end of its lane
        (when `at_lane_ends`)."""
        if self.on_collision and self.collision(k, first_collision):
            return True
        return self.at_lane_ends and self.lane_end(k, sv)

    def collision(self, k: int, first_collision: tuple[float, str] | None) -> bool:
        """True if row k holds the run's first collision onset (`first_collision`: its
        (t s, TV ids); None: none so far)."""
        if first_collision is None or self.by_collision:
            return False
        self.by_collision = True
        self.last_row = k
        return True

    def lane_end(self, k: int, sv: SVState) -> bool:
        """True if row k leaves the SV in a lane that ends with its front within one step
        of that end (`RoadParams.lane_ends`)."""
        end = self.road.lane_end(self.road.lane_of(sv.y), sv.x)
        if not math.isfinite(end) or self.by_collision or self.at_lane_end:
            return False
        if sv.x + 0.5 * self.sv_length + max(sv.vx, 0.0) * self.dt < end:
            return False
        self.at_lane_end = True
        self.last_row = k
        return True
