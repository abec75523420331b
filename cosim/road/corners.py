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

The fillet's curvature is continuous: a clothoid (Euler spiral, curvature linear in arc
length) of length L leads from each straight into the circular arc, so that at the
corner's speed v (sqrt(a R) of the lane's arc, at most the limit) the lateral
acceleration ramps at `LAT_JERK`: L = v^3 / (R J) (the lane's curvature rate over the
reference line's, R_ref / R_lane, included). Where the two spirals turn by the whole
corner (L >= R turn) there is no arc: a symmetric pair meeting at 1/R. A spiral moves
the arc inwards (by about L^2 / 24 R) and its ends outwards along the straights, so the
radius is the largest (up to the one above) whose fillet, spirals included, keeps the
half-lane bound and the straight ends, down to `RADIUS_SHARE` of the circular
fillet's (the corner's speed to 89 % of it); below that the spirals are shortened
instead (to none: the circular fillet).

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
from scipy.special import fresnel

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
# m/s^3, the lateral jerk of the fillet's spirals at the corner's speed (the rate at
# which its lateral acceleration builds up from the straight's zero)
LAT_JERK = 1.0  # tuned: docs/tuned_constants.md
# -, the spirals take the arc's radius down to this share of the circular fillet's (its
# speed to sqrt of it); shorter spirals beyond
RADIUS_SHARE = 0.8  # tuned: docs/tuned_constants.md
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
    radius: float  # m, the reference line's fillet (its circular arc)
    lane_radius: float  # m, the corner's lane's fillet (the SV's lane; its arc)
    deviation: float  # m, the lane's fillet from SUMO's corner at its vertex
    junction: str
    spiral: float = 0.0  # m, the reference line's clothoid at each end of the arc

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


def spiral_end(length: float, radius: float) -> tuple[float, float]:
    """m, (along, across) the end of a clothoid of `length` whose curvature grows from 0
    to 1 / `radius`, from its start along its initial heading (across: towards the
    turn): A sqrt(pi) (C(z), S(z)), z = length / (A sqrt(pi)), A^2 = radius length."""
    if length <= 0.0:
        return 0.0, 0.0
    scale = math.sqrt(math.pi * radius * length)
    s_, c_ = fresnel(length / scale)
    return scale * float(c_), scale * float(s_)


def fillet_shape(radius: float, spiral: float, turn: float) -> tuple[float, float]:
    """m, (tangent length, distance at the bisector): how far from the vertex along each
    straight the fillet of arc `radius` with spirals of length `spiral` begins, and how
    far its middle lies from the vertex, for a corner of `turn` (rad, |turn| < pi); the
    spirals turn by at most half the corner each."""
    half = 0.5 * abs(turn)
    tau = spiral / (2.0 * radius)  # rad, each spiral's turn
    xs, ys = spiral_end(spiral, radius)
    shift = ys - radius * (1.0 - math.cos(tau))  # the arc's offset inwards
    ahead = xs - radius * math.sin(tau)  # the arc's centre along the straight
    return ((radius + shift) * math.tan(half) + ahead,
            (radius + shift) / math.cos(half) - radius)


def rounding(sites: Sequence[CornerSite], lat_accel: float, min_radius: float
             ) -> list[tuple[float, float, float, float, float]]:
    """Each corner's (reference radius, lane radius, lane deviation at the vertex,
    tangent length, spiral length), all m, as the module docstring chooses them; a
    corner whose straight ends cannot hold the smallest radius allowed gets nan."""
    out = []
    vertices = [corner_vertex(s) for s in sites]
    for k, (site, (v, _, _, turn)) in enumerate(zip(sites, vertices, strict=True)):
        if abs(turn) >= U_TURN:
            out.append((math.nan,) * 5)
            continue
        # the straight ends' room, halved where a neighbouring corner shares the segment
        room_in = float(np.hypot(*(v - np.asarray(site.p0))))
        room_out = float(np.hypot(*(np.asarray(site.q1) - v)))
        if k > 0 and sites[k - 1].q0 == site.p0:
            room_in = 0.5 * float(np.hypot(*(v - vertices[k - 1][0])))
        if k + 1 < len(sites) and sites[k + 1].p0 == site.q0:
            room_out = 0.5 * float(np.hypot(*(vertices[k + 1][0] - v)))
        out.append(_round(site, turn, min(room_in, room_out), lat_accel, min_radius))
    return out


def _round(site: CornerSite, turn: float, room: float, lat_accel: float,
           min_radius: float) -> tuple[float, float, float, float, float]:
    """One corner's `rounding`, its straight ends holding `room` m each."""
    half = 0.5 * abs(turn)
    # the lane's radius from the reference line's: the lane lies on the turn's inside
    # (a right turn, the lane right of the line) or outside
    inward = site.lane_right if turn < 0.0 else -site.lane_right
    sec = 1.0 / math.cos(half) - 1.0
    wanted = site.speed**2 / lat_accel  # lane radius a driver takes at the limit
    floor = max(min_radius + 0.5 * site.width + max(inward, 0.0),
                site.inside_reach / (1.0 - CORNER_STRETCH))  # reference radius

    def spiral(ref: float) -> float:
        """m, the spirals' length the lateral jerk asks at the lane's arc's speed,
        at most a symmetric pair (no arc)."""
        lane = ref - inward
        speed = min(site.speed, math.sqrt(lat_accel * lane))
        return min(speed**3 * ref / (lane * lane * LAT_JERK), ref * abs(turn))

    def deviation(ref: float, length: float) -> float:
        """m, the lane's fillet from SUMO's corner (the lane's vertex lies inward
        sec(half) further than its fillet's middle moves)."""
        return fillet_shape(ref, length, turn)[1] - inward * sec

    def fits(ref: float, length: float, bound: float) -> bool:
        tangent, _ = fillet_shape(ref, length, turn)
        return tangent <= room and deviation(ref, length) <= bound

    # the circular fillet: the radius wanted, within half a lane of SUMO's corner,
    # at least the floor, and within the straight ends
    circular = min(wanted, 0.5 * site.width / sec) + inward
    circular = min(max(circular, floor), room / math.tan(half))
    if circular < floor - 1e-9:
        return (math.nan,) * 5
    # (a circular fillet at the floor may pass the half-lane bound: so may its spirals)
    bound = max(0.5 * site.width, deviation(circular, 0.0))
    ref, least = max(wanted + inward, floor), max(floor, RADIUS_SHARE * circular)
    if fits(ref, spiral(ref), bound):
        length = spiral(ref)
    elif fits(least, spiral(least), bound):
        lo, hi = least, ref  # the largest radius whose spirals fit (both grow with it)
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fits(mid, spiral(mid), bound) else (lo, mid)
        ref, length = lo, spiral(lo)
    else:  # the spirals shortened to fit at the least radius
        ref, lo, hi = least, 0.0, spiral(least)
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fits(ref, mid, bound) else (lo, mid)
        length = lo
    tangent, _ = fillet_shape(ref, length, turn)
    return ref, ref - inward, deviation(ref, length), tangent, length


def fillet(site: CornerSite, radius: float, spiral: float, tangent: float, step: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """The fillet's points every <= `step` m of its length (both tangent points
    included) and its curvature there (1/m, + left): a clothoid of length `spiral` from
    the straight p0 -> p1, the arc of `radius`, a clothoid onto q0 -> q1, each spiral
    drawn from its own straight (its tangent point exact)."""
    v, u, w, turn = corner_vertex(site)
    sign = 1.0 if turn > 0.0 else -1.0
    left_u = sign * np.array([-u[1], u[0]])
    left_w = sign * np.array([-w[1], w[0]])
    t1, t2 = v - tangent * u, v + tangent * w
    arc = radius * abs(turn) - spiral  # m, the arc's length (2 spirals of turn L / 2R)
    arc = max(arc, 0.0)
    total = 2.0 * spiral + arc
    n = max(2, int(math.ceil(total / step)))
    s = np.linspace(0.0, total, n + 1)
    points = np.empty((n + 1, 2))
    kappa = np.empty(n + 1)
    scale = math.sqrt(math.pi * radius * spiral) if spiral > 0.0 else 1.0

    def on_spiral(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        sf, cf = fresnel(m / scale)
        return scale * cf, scale * sf

    first, last = s <= spiral, s >= spiral + arc
    if spiral > 0.0:
        a, b = on_spiral(s[first])
        points[first] = t1 + a[:, None] * u + b[:, None] * left_u
        kappa[first] = s[first] / (radius * spiral)
        m = total - s[last]
        a, b = on_spiral(m)
        points[last] = t2 - a[:, None] * w + b[:, None] * left_w
        kappa[last] = m / (radius * spiral)
    middle = ~(first | last) if spiral > 0.0 else np.ones(n + 1, dtype=bool)
    # the arc from the first spiral's end (its heading turned by L / 2R)
    xs, ys = spiral_end(spiral, radius)
    start = t1 + xs * u + ys * left_u
    tau = spiral / (2.0 * radius)
    heading = math.cos(tau) * u + math.sin(tau) * left_u
    centre = start + radius * np.array([-heading[1], heading[0]]) * sign
    ang = (s[middle] - spiral) / radius
    rel = start - centre
    c, sn = np.cos(sign * ang), np.sin(sign * ang)
    points[middle] = centre + np.column_stack((c * rel[0] - sn * rel[1],
                                               sn * rel[0] + c * rel[1]))
    kappa[middle] = 1.0 / radius
    if spiral == 0.0:  # the circular fillet: its ends exact, as the spirals'
        points[0], points[-1] = t1, t2
    return points, sign * kappa


def filleted(points: np.ndarray, sites: Sequence[CornerSite],
             rounded: Sequence[tuple[float, float, float, float, float]]
             ) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """The polyline with each corner's vertices from p1 to q0 (the junction's lane
    between) replaced by its fillet (`fillet`, drawn every ARC_STEP), and each fillet's
    two tangent points (on the segments p0 -> p1 and q0 -> q1)."""
    parts, ends = [], []
    start = 0
    for site, (radius, _, _, tangent, spiral) in zip(sites, rounded, strict=True):
        arc, _ = fillet(site, radius, spiral, tangent, ARC_STEP)
        i1, i2 = _index(points, site.p1), _index(points, site.q0)
        parts += [points[start:i1], arc]
        start = i2 + 1
        ends.append((arc[0], arc[-1]))
    parts.append(points[start:])
    return np.vstack(parts), ends


def _index(points: np.ndarray, p: tuple[float, float]) -> int:
    """The polyline's vertex nearest p (the line shifts a lead-in's vertices along their
    bisectors, so a junction's end lies a little off where its edge's parallel puts it)."""
    return int(np.argmin(np.hypot(points[:, 0] - p[0], points[:, 1] - p[1])))
