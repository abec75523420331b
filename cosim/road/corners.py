"""Corners: junctions drawn as a corner (a ramp's lane meeting the next edge's at 40
degrees within a few metres, SUMO's game/ramp), and the road the frame makes of them.

SUMO moves its vehicles along a junction's lane shape at any speed; no car can take a
43-degree turn within 4 m at 50 km/h, and a road is not built that way: the corner is
its drawing. The reference line replaces each corner by a circular fillet tangent to
the two edges' straight ends: its radius is the one a driver takes at the slower
edge's speed limit with a comfortable lateral acceleration (v^2 / a_lat, as the kinks
are smoothed), at most what keeps the corner's lane within half a lane width of SUMO's
corner (the SV's centre stays inside SUMO's lane) and what the edges' straight ends
hold, and at least what keeps the frame's stretch across the lanes on the inside of the
turn at `CORNER_STRETCH`. A corner that cannot be rounded within its straight ends at
that smallest radius is refused (by the frame, naming it).

Where a route cannot be smoothed otherwise, so are the vertices inside an edge's lane
that turn by CORNER_TURN_REFUSED or more, on a lane one of whose vertices turns by
CORNER_TURN or more (cosim.road.road.load_road): a ramp drawn as chords 40-86 m long
turning 6-18 degrees at each (SUMO's game/highway ramp), whose curve no line within half
a metre of the chords follows, is rounded vertex by vertex.

The lanes keep their d through a corner (the planner's lanes are unchanged); SUMO's
lane there lies off the line by up to the fillet's distance from SUMO's corner
(`Corner.deviation`), measured outside the corner's window as at a lateral shift.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

CORNER_TURN = math.radians(15.0)  # rad, a turn across one junction that makes it a corner
# rad, a gentler turn across one junction (or at a vertex inside an edge's lane) made a
# corner where the line cannot be smoothed otherwise (cosim.road.road.load_road): a ramp
# drawn straight up to its gore, or drawn as coarse chords
CORNER_TURN_REFUSED = math.radians(5.0)
# -, the frame's stretch 1 - kappa d across the lanes on a corner's inside stays at least
# this (a corner's lanes are the ramp's one lane: a smaller stretch than the route's
# FrameLimits.min_stretch keeps the fillet nearer SUMO's corner)
CORNER_STRETCH = 0.5  # tuned: docs/tuned_constants.md
ARC_STEP = 0.5  # m, the fillet's vertices
# rad, a turn across one junction that is a U-turn (onto the opposite carriageway), not a
# corner: no fillet within the edges' straight ends
U_TURN = math.radians(150.0)


@dataclass(frozen=True)
class CornerSite:
    """A corner of the reference line's polyline, before it is rounded: the last
    segment before the junction (p0 -> p1) and the first after it (q0 -> q1), in the
    line's coordinates (a lead-in's shift included)."""

    p0: tuple[float, float]
    p1: tuple[float, float]
    q0: tuple[float, float]
    q1: tuple[float, float]
    junction: str  # SUMO's junction id ("EDGE vertex i": a vertex inside an edge's lane)
    speed: float  # m/s, the slower of the two edges' speed limits
    width: float  # m, the corner's lane's width
    lane_right: float  # m, how far the SV's lane lies right of the line (a lead-in's shift)
    inside_reach: float  # m, the lanes' farthest border on the turn's inside, from the line


@dataclass(frozen=True)
class Corner:
    """A corner as the frame rounds it: a fillet of `radius` (the reference line's)
    from s_lo to s_hi."""

    s_lo: float  # m, where the fillet begins along the frame
    s_hi: float  # m, where it ends
    turn: float  # rad, + to the left
    radius: float  # m, the reference line's fillet
    lane_radius: float  # m, the corner's lane's fillet (the SV's lane)
    deviation: float  # m, the lane's fillet from SUMO's corner at its vertex
    junction: str

    @property
    def window(self) -> tuple[float, float]:
        """m, the s range over which the line leaves SUMO's corner."""
        return self.s_lo, self.s_hi


def _unit(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    v = b - a
    return v / max(float(np.hypot(*v)), 1e-12)


def _turn(u: np.ndarray, w: np.ndarray) -> float:
    return math.atan2(u[0] * w[1] - u[1] * w[0], u[0] * w[0] + u[1] * w[1])


def corner_vertex(site: CornerSite) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(V, u, w, turn): where the two straight ends' lines meet, their directions, the
    signed turn (rad, + left)."""
    p0, p1, q0, q1 = (np.asarray(p, dtype=np.float64) for p in
                      (site.p0, site.p1, site.q0, site.q1))
    u, w = _unit(p0, p1), _unit(q0, q1)
    turn = _turn(u, w)
    if abs(turn) >= U_TURN:  # the lines meet far off or never: no vertex to round
        return 0.5 * (p1 + q0), u, w, turn
    # p1 + a u = q0 + b w, solved for a (the lines are not parallel: turn >= CORNER_TURN)
    cross = u[0] * w[1] - u[1] * w[0]
    dq = q0 - p1
    a = (dq[0] * w[1] - dq[1] * w[0]) / cross
    return p1 + a * u, u, w, turn


def rounding(sites: Sequence[CornerSite], lat_accel: float, min_radius: float
             ) -> list[tuple[float, float, float, float]]:
    """Each corner's (reference radius, lane radius, lane deviation at the vertex,
    tangent length), all m, as the module docstring chooses them; a corner whose
    straight ends cannot hold the smallest radius allowed gets nan."""
    out = []
    vertices = [corner_vertex(s) for s in sites]
    for k, (site, (v, _, _, turn)) in enumerate(zip(sites, vertices, strict=True)):
        if abs(turn) >= U_TURN:
            out.append((math.nan, math.nan, math.nan, math.nan))
            continue
        half = 0.5 * abs(turn)
        # the straight ends' room, halved where a neighbouring corner shares the segment
        room_in = float(np.hypot(*(v - np.asarray(site.p0))))
        room_out = float(np.hypot(*(np.asarray(site.q1) - v)))
        if k > 0 and sites[k - 1].q0 == site.p0:
            room_in = 0.5 * float(np.hypot(*(v - vertices[k - 1][0])))
        if k + 1 < len(sites) and sites[k + 1].p0 == site.q0:
            room_out = 0.5 * float(np.hypot(*(vertices[k + 1][0] - v)))
        # the lane's radius from the reference line's: the lane lies on the turn's inside
        # (a right turn, the lane right of the line) or outside
        inward = site.lane_right if turn < 0.0 else -site.lane_right
        sec = 1.0 / math.cos(half) - 1.0
        wanted = site.speed**2 / lat_accel  # lane radius a driver takes at the limit
        within = 0.5 * site.width / sec  # the lane's fillet within half a lane of SUMO's
        floor = max(min_radius + 0.5 * site.width + max(inward, 0.0),
                    site.inside_reach / (1.0 - CORNER_STRETCH))  # reference radius
        fits = min(room_in, room_out) / math.tan(half)  # reference radius
        ref = min(wanted, within) + inward
        ref = min(max(ref, floor), fits)
        if ref < floor - 1e-9:
            out.append((math.nan, math.nan, math.nan, math.nan))
            continue
        lane = ref - inward
        out.append((ref, lane, lane * sec, ref * math.tan(half)))
    return out


def filleted(points: np.ndarray, sites: Sequence[CornerSite],
             rounded: Sequence[tuple[float, float, float, float]]
             ) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """The polyline with each corner's vertices from p1 to q0 (the junction's lane
    between) replaced by its fillet (drawn every ARC_STEP), and each fillet's two
    tangent points (on the segments p0 -> p1 and q0 -> q1)."""
    parts, ends = [], []
    start = 0
    for site, (radius, _, _, tangent) in zip(sites, rounded, strict=True):
        v, u, w, turn = corner_vertex(site)
        t1, t2 = v - tangent * u, v + tangent * w
        normal = np.array([-u[1], u[0]]) * (1.0 if turn > 0.0 else -1.0)
        centre = t1 + radius * normal
        a0 = math.atan2(t1[1] - centre[1], t1[0] - centre[0])
        n = max(2, int(math.ceil(radius * abs(turn) / ARC_STEP)))
        ang = a0 + np.linspace(0.0, turn, n + 1)
        arc = centre + radius * np.column_stack((np.cos(ang), np.sin(ang)))
        i1, i2 = _index(points, site.p1), _index(points, site.q0)
        parts += [points[start:i1], arc]
        start = i2 + 1
        ends.append((t1, t2))
    parts.append(points[start:])
    return np.vstack(parts), ends


def _index(points: np.ndarray, p: tuple[float, float]) -> int:
    """The polyline's vertex nearest p (the line shifts a lead-in's vertices along their
    bisectors, so a junction's end lies a little off where its edge's parallel puts it)."""
    return int(np.argmin(np.hypot(points[:, 0] - p[0], points[:, 1] - p[1])))
