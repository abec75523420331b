"""The end speed of a change under way, re-targeted to its new leader (the gap policy,
beyond the paper).

A change is planned to end at its new leader's speed as it was at the plan (the gap's
speed, `GapDecision.vxf`). When that leader slows during the change, a 3.5 s manoeuvre
ends well above its speed and close behind it, and the car following that takes over
at the end brakes hard at once (a merge's later change by choice: 27.9 m/s at the end,
41 m behind a leader at 20 m/s, 3.6 m/s^2). Each step of the change the SV therefore
looks at the TV ahead of it in the target lane; when the plan's end speed is more
than RETARGET_DV above that TV's speed and the car following could not settle the
difference gently after the end (matching its speed at RETARGET_DECEL at most, its
time gap kept), the rest of the change is re-planned from the reference's state to
end at that speed (the same lateral path: the quintic refit from the reference's state
over the time left is the one under way), no faster than the mean braking
RETARGET_MEAN_DECEL over the time left allows. The lateral path and the end time stay;
only the speed profile changes, so it is no replan of the change.
"""

from __future__ import annotations

import math

RETARGET_DV = 0.5  # m/s, the plan's end speed above the new leader's by more than this
# is looked at (a leader's dawdling is below it)
RETARGET_DECEL = 1.0  # m/s^2, the constant braking after the change's end that matches
# the new leader's speed within the gap left (its time gap kept) at most: the car
# following settles that gently, more is re-targeted during the change
# tuned: docs/tuned_constants.md
RETARGET_MEAN_DECEL = 1.5  # m/s^2, the re-targeted profile's mean braking over the time
# left at most (the quartic's peak is about 1.5x its mean: within the 2 m/s^2
# comfortable deceleration, GapConfig.comfort_decel, plus the controller's lag)
RETARGET_MIN_TIME = 0.5  # s, with less of the change left the car following takes over


def end_speed(vxf: float, vx: float, ax: float, left: float, gap: float,
              leader_speed: float, time_gap: float, min_gap: float) -> float | None:
    """m/s, the re-targeted end speed of a change under way (None: keep `vxf`): the plan
    ends at `vxf` (m/s) `left` s from now; the SV's reference is at `vx` (m/s) and `ax`
    (m/s^2) now, its bumper gap to the new leader `gap` (m), the leader at
    `leader_speed` (m/s, kept); after the change the car following keeps `time_gap` (s)
    and `min_gap` (m) behind it. The highest end speed from which the car following
    matches the leader's speed within the gap left braking at most RETARGET_DECEL (the
    plan's x(tau) = x0 + (vx0 + vxf) tau / 2 + ax0 tau^2 / 12, eq. 2), no lower than
    the mean braking RETARGET_MEAN_DECEL over the time left allows."""
    if left < RETARGET_MIN_TIME or vxf - leader_speed <= RETARGET_DV:
        return None
    v_l = max(leader_speed, 0.0)
    # room at the end for an end speed v: r0 - left v / 2; braking (v - v_l)^2 / (2 room)
    # <= D for u = v - v_l: u^2 + D left u - 2 D (r0 - left v_l / 2) <= 0
    r0 = gap + v_l * left - 0.5 * vx * left - ax * left * left / 12.0 - (min_gap + time_gap * v_l)
    d = RETARGET_DECEL
    c = 2.0 * d * (r0 - 0.5 * left * v_l)
    u = 0.5 * (-d * left + math.sqrt((d * left) ** 2 + 4.0 * c)) if c > 0.0 else 0.0
    if v_l + u >= vxf - RETARGET_DV:
        return None  # the car following settles it gently
    target = max(v_l + u, vx - RETARGET_MEAN_DECEL * left, 0.0)
    return target if target < vxf - 1e-6 else None
