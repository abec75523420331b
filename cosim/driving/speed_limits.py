"""The SV's speed limits along its route: where an edge's limit is below the SV's lane
band, the SV's desired speed there is the limit (never above it), reached by a
comfortable braking before the drop, as SUMO's drivers slow to each edge's limit and
accelerate again after it. The limit holds while the SV's front is on the edge (SUMO
takes the limit of the lane its front is on)."""

from __future__ import annotations

import math

from cosim.driving.curve_speed import CORNER_SETTLE_S

CHANGE_REACH = 5.0  # s, a lane change's end speed keeps the limits its target lane has
# within this time at the SV's speed (longer than most changes: 2-4 s)
LIMIT_DECEL = 1.0  # m/s^2, the braking that brings the SV down to a lower limit ahead;
# tuned: docs/tuned_constants.md


class SpeedLimits:
    """Per SV lane, the stretches (s_lo m, s_hi m, v m/s) of the route whose limit v is
    below the lane's band (RoadParams.speed_limits)."""

    def __init__(self, zones: tuple[tuple[tuple[float, float, float], ...], ...]) -> None:
        self.zones = zones

    def _lane(self, lane: int) -> tuple[tuple[float, float, float], ...]:
        return self.zones[lane] if 0 <= lane < len(self.zones) else ()

    def at(self, lane: int, s_front: float) -> float:
        """m/s, the limit in `lane` with the SV's front at s_front (inf: its band's)."""
        return min((v for lo, hi, v in self._lane(lane) if lo <= s_front < hi),
                   default=math.inf)

    def lowest(self, lane: int, s_lo: float, s_hi: float) -> float:
        """m/s, the lowest limit in `lane` on [s_lo, s_hi] (m; inf: none)."""
        return min((v for lo, hi, v in self._lane(lane) if lo <= s_hi and s_lo < hi),
                   default=math.inf)

    def change_end_speed(self, target: int, s_front: float, speed: float,
                         wanted: float) -> float:
        """m/s, the end speed of a lane change to `target` that begins at `speed` (m/s)
        with the SV's front at s_front (m) and would end at `wanted`: at most the lowest
        limit of the target lane within CHANGE_REACH at that speed (a change flown at the
        band's speed would run over a lower limit until it ends)."""
        return min(wanted, self.lowest(target, s_front,
                                       s_front + max(speed, 0.0) * CHANGE_REACH))

    def accel_cap(self, lane: int, s_front: float, speed: float) -> float:
        """m/s^2, the most the SV may accelerate at `speed` (m/s) in `lane` with its front
        at s_front (m): inside a stretch it closes on the limit over CORNER_SETTLE_S;
        before one it keeps under the speed from which braking at LIMIT_DECEL reaches
        the limit where the stretch begins (that speed less the lag of closing on it,
        LIMIT_DECEL CORNER_SETTLE_S, so that the SV itself is at the limit there)
        (inf: no lower limit ahead)."""
        cap = math.inf
        for lo, hi, v in self._lane(lane):
            if s_front >= hi:
                continue
            if s_front >= lo:
                target = v
            elif speed > v:
                target = (math.sqrt(v * v + 2.0 * LIMIT_DECEL * (lo - s_front))
                          - LIMIT_DECEL * CORNER_SETTLE_S)
            else:
                continue
            cap = min(cap, (target - speed) / CORNER_SETTLE_S)
        return cap
