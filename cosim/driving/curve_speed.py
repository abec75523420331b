"""The SV's curve speed: the fastest it drives a route so that its tightest curve takes
no more than a comfortable lateral acceleration, as a driver slows for a bend instead of
refusing the road.

One speed per run (the planner's friction and tau_min maps are built once per run for
one friction, `cosim.planning.planner.RoadCurve`): v = sqrt(a / kappa) at the route's
largest curvature on its innermost lane, kappa / (1 - kappa d) at |d| = the lanes'
largest offset from the reference line, with a the smaller of the scenario's
`sv.curve_lat_accel_mps2` and CURVE_FRICTION_SHARE of the road's friction (so that a
lane change in the curve keeps sqrt(1 - 0.5^2) = 87 % of the friction circle).
A junction drawn as a corner (cosim.road.corners) is not part of that curve: the SV
slows for each corner alone, to the corner's own speed (`CornerSpeeds`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from cosim.params import G, RoadParams

if TYPE_CHECKING:
    from cosim.scenario import Scenario

CURVE_FRICTION_SHARE = 0.5  # -, the share of mu g the curve itself may take


def curve_speed(kappa: float, d_abs: float, mu: float, lat_accel: float) -> float:
    """m/s, the SV's curve speed on a route whose reference line bends at most `kappa`
    (1/m) with lanes up to `d_abs` (m) from it, friction `mu`, a comfortable lateral
    acceleration `lat_accel` (m/s^2); inf on a straight route."""
    if kappa <= 0.0:
        return math.inf
    inner = kappa / max(1.0 - kappa * d_abs, 1e-9)  # 1/m, the innermost lane's curvature
    return math.sqrt(min(lat_accel, CURVE_FRICTION_SHARE * mu * G) / inner)


def keep_to(sc: Scenario, road: RoadParams, speed: float) -> tuple[Scenario, RoadParams]:
    """The scenario and road as the SV drives them at most at `speed` (m/s): its start
    and desired speeds and every lane's speed band capped there (the traffic keeps its
    own bands: SUMO's drivers do not slow for curves)."""
    bands = tuple((min(lo, speed), min(hi, speed)) for lo, hi in road.speed_bands)
    road = replace(road, speed_bands=bands)
    desired = sc.sv.desired_speed
    sv = replace(sc.sv, speed=min(sc.sv.speed, speed),
                 desired_speed=None if desired is None else min(desired, speed))
    return replace(sc, sv=sv, road=road), road


CORNER_SETTLE_S = 1.0  # s, inside a corner the SV's speed closes on the corner's over this


class CornerSpeeds:
    """The SV's speed at the corners of its route (cosim.road.corners: junctions drawn
    as corners, rounded by the frame): before each it brakes so as to reach the
    corner's curve speed sqrt(a R) (R its lane's fillet, a as `curve_speed`'s) where the
    corner begins, uniformly ((v_c^2 - v^2) / 2 x), and holds it until its rear has left
    the corner; elsewhere the route's own curve speed holds (`curve_speed`)."""

    def __init__(self, zones: tuple[tuple[float, float, float], ...], mu: float,
                 lat_accel: float) -> None:
        a = min(lat_accel, CURVE_FRICTION_SHARE * mu * G)
        self.zones = tuple((lo, hi, math.sqrt(a * r)) for lo, hi, r in zones)

    def accel_cap(self, s_front: float, s_rear: float, speed: float) -> float:
        """m/s^2, the most the SV may accelerate at `speed` (m/s) with its front and rear
        at s_front, s_rear (m) (inf: no corner ahead)."""
        cap = math.inf
        for lo, hi, v_c in self.zones:
            if s_rear > hi:
                continue
            if s_front >= lo:
                cap = min(cap, (v_c - speed) / CORNER_SETTLE_S)
            elif speed > v_c:
                cap = min(cap, (v_c * v_c - speed * speed) / (2.0 * (lo - s_front)))
        return cap
