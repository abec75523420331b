"""The road frame: arc length s along a reference line and lateral offset d from it.

The reference line is built from SUMO's lane shapes (the centre line of the route's
reference track, `cosim.road.tracks.reference_track`) and smoothed: SUMO's polylines
kink at single vertices (3-18 degrees on real motorways), where a frame's curvature
would be unbounded. The smoothed line is an *arc spline*: circular arcs of one length
`h` (0.5 m), heading continuous from one to the next (G1), each arc's curvature
constant. Its table holds, at s_k = s_min + k h, the point (x_k, y_k), the heading
theta_k and, per arc, the curvature kappa_k; it runs `extension` m straight on past
both ends of the route.

Conversions are exact (closed form, both ways, no iteration): a point (s, d) is the
point of arc k at u = s - s_k plus d along the arc's left normal there,

    x = x_k + T(theta_k) [sin(kappa u) / kappa - d sin(kappa u),
                          (1 - cos(kappa u)) / kappa + d cos(kappa u)],

and a point's (s, d) is its foot on the arc whose normals cover it (the normals at the
knots are shared by the arcs on both sides, so those regions tile the plane within
the smallest radius of the line): in the arc's local coordinates (a, b),

    u = atan2(kappa a, 1 - kappa b) / kappa,
    d = (2 b - kappa (a^2 + b^2)) / (1 + sqrt((1 - kappa b)^2 + (kappa a)^2)),

written so that nothing cancels when kappa -> 0. The heading and curvature of a path
given in (s, d) follow Werling et al. (ICRA 2010, Appendix) with the arc's constant
kappa: theta = theta_r + atan(d' / (1 - kappa d)). The frame's d is measured from the
reference track's right border (its centre lies at d = half its width), as y is
from the straight road's right border.

The search for a point's arc starts at the arc of a previous s (`s_hint`; without one,
at the nearest knot) and steps by the point's u to the arc whose normals cover it
(usually one or two arcs); failing that it scans `WINDOW` arcs either way, then all.

Smoothing (`smooth`): the reference polyline is resampled every max(h, ell / 32) and
smoothed by a discrete smoothing spline penalising third differences
(Whittaker-Henderson, order 3, smoothing length ell: straight lines and parabolas pass
unchanged, a circle of radius R shrinks by ell^6 / R^5, 3 nm for ell = 10 m and R =
800 m; a kink's heading change is spread over about ell; where curvature steps, as
from a straight into a curve, the spline overshoots by a few per cent). The least smoothing
that reaches 90 % of the largest smallest-radius any smoothing within
`target_deviation` of SUMO's polyline reaches is taken (more would bend SUMO's own
curves), lengthened to SUMO's vertex spacing (median) where that stays within the
target (shorter smoothing leaves the curvature rippling between the vertices). Where
SUMO's vertices lie far apart (an OSM import: 60 m, 3 degree kinks) that
line still bends at each vertex far tighter than the curve the vertices lie on
(`polyline_radius`: segment length over turn angle); then the least smoothing within
`max_deviation` that reaches 90 % of that radius (or of the largest reachable there) is
taken, and where that still bends at least 10 % tighter, up to `coarse_deviation`:
SUMO's chords are the curve's drawing, and within 0.2 m of a 6.6-degree kink no line
bends wider than ~R 100 m (a line that bends at R keeps about R theta^2 / 16 from a
kink of theta). The radius smoothed towards is at most what the route's speed limit
needs at `limit_lat_accel` (more would only leave SUMO's lanes further), and where
kinks sit between straights (a junction's jog) it is that radius; but a curve drawn by
its vertices wider than that is smoothed on towards the curve they lie on within
`RIPPLE_DEVIATION_SHARE` of `max_deviation`: stopped at the limit's radius the line
bends at each vertex and runs straight between them, its curvature rippling from 0 to
1/R every vertex, which the controller follows. If the smallest radius
is then below the smallest allowed (`min_radius`, the SV's turning circle, and the
lanes' reach over 1 - `min_stretch`), more smoothing is taken up to `max_deviation`; a
line that cannot reach it within `max_deviation` is refused (InputError naming the
radius and the deviation), as is a polyline that the line through its vertices,
unsmoothed, already leaves by more than `max_deviation` (a kink too sharp for the arc
spline: lanes that jump sideways at a junction; named where the line first leaves it).
The deviation is the Hausdorff distance between the smoothed line and SUMO's polyline.

Where SUMO's lanes step sideways at a junction (netconvert re-spreads them at a
lane-count change: `cosim.road.road.lateral_steps`), the line is smoothed with the steps
taken out and then shifted sideways with them (`shifted`): across each junction by a
quintic smootherstep (`LateralShift`), curvature continuous, as long as a curve of the
radius the speed limit needs, so that every lane keeps its d and lies on SUMO's lane
before and after the step, half the step off it at the junction; the lanes' deviation is
measured outside those windows.

On a one-edge straight road along +x (`StraightFrame`) the frame is the identity up to
an offset: s = x - x0 and d = y - y0, with (x0, y0) the start of the reference lane's
right border (0, 0 on networks/highway.net.xml, where s = x and d = y exactly).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit, register_warm_up
from cosim.errors import InputError

Array = NDArray[np.float64]
WINDOW = 16  # arcs searched either side of the hint (8 m at h = 0.5 m)
RADIUS_SHARE = 0.9  # smoothing stops once the radius is within 10 % of the best it can get
DEFAULT_REACH = 15.0  # m, lanes across a reference line when the caller does not say: 4 x 3.75
# -, smoothing a curve drawn by its vertices towards that curve beyond the radius the
# speed limit needs spends up to this share of max_deviation (the lanes lie a few mm
# further from SUMO's than the line: 0.194 -> 0.199 m on a R 1500 m curve drawn every 60 m)
RIPPLE_DEVIATION_SHARE = 0.9  # tuned: docs/tuned_constants.md
COARSE_BISECTIONS = 4  # halvings of the smoothing length's step (2^(1/32)) at coarse_deviation
_EPS_U = 1e-9  # m, slack on an arc's ends when deciding which arc a point projects onto


@dataclass(frozen=True)
class FrameLimits:
    """How much the reference line may deviate from SUMO's polyline and how tight it may
    bend; the frame's table step and extension."""

    target_deviation: float = 0.05  # m, smoothing spends up to this to lower curvature
    max_deviation: float = 0.20  # m, beyond this a network is refused
    # m, a curve drawn coarsely (an OSM import's node every 50-60 m, kinks of 2-7
    # degrees) may be smoothed this far from SUMO's polyline to bend as the curve its
    # vertices lie on: within 0.2 m a 6.6 degree kink keeps R ~100 m; a car 1.8 m wide
    # still keeps 0.2 m inside a 3.2 m lane
    coarse_deviation: float = 0.50  # tuned: docs/tuned_constants.md
    # m/s^2, smoothing seeks no radius beyond v^2 / this at the route's highest speed
    # limit v (the SV's default curve_lat_accel_mps2): wider only leaves SUMO's lanes
    limit_lat_accel: float = 2.0  # tuned: docs/tuned_constants.md
    # m, a reference line bending tighter is refused on any route: the SV's turning
    # circle (Table 1's wheelbase 2.51 m over tan of the 0.6 rad steering limit)
    min_radius: float = 3.7
    # -, and one bending tighter than the lanes' reach / (1 - this): the frame's
    # stretch q = 1 - kappa d across the lanes stays at least this (four lanes of
    # 3.75 m: R 100 m; one: R 25 m)
    min_stretch: float = 0.85
    spacing: float = 0.5  # m, the table step h (arc length)
    extension: float = 200.0  # m, straight continuation past both ends


DEFAULT_LIMITS = FrameLimits()


@dataclass(frozen=True)
class FrameQuality:
    """What smoothing did to SUMO's polyline (measured on the built frame)."""

    max_deviation: float  # m, Hausdorff distance between the reference line and SUMO's polyline
    min_radius: float  # m, smallest radius of the reference line (inf: straight)
    smoothing_length: float  # m, ell of the smoothing spline (0: none)
    max_kink: float  # rad, SUMO's polyline's largest turn at one vertex
    coarse: bool = False  # smoothed beyond max_deviation, up to coarse_deviation


# ---------------------------------------------------------------- compiled kernels
@njit
def _arc_point(s: float, d: float, s_min: float, h: float, x: Array, y: Array,
               theta: Array, kappa: Array) -> tuple[float, float, float, float]:
    """(x, y, heading of the reference line at s, its curvature) of the point at s, d off
    the spline (d from the spline itself, not the frame's d); see the module docstring."""
    n = kappa.shape[0]
    k = min(max(int(math.floor((s - s_min) / h)), 0), n - 1)
    u = s - (s_min + k * h)
    kk = kappa[k]
    t = kk * u
    if kk == 0.0:
        along, side = u, 0.0
    else:
        along = math.sin(t) / kk
        half = math.sin(0.5 * t)
        side = 2.0 * half * half / kk
    along -= d * math.sin(t)
    side += d * math.cos(t)
    c, sn = math.cos(theta[k]), math.sin(theta[k])  # as the table's _cos, _sin
    return x[k] + c * along - sn * side, y[k] + sn * along + c * side, theta[k] + t, kk


@njit
def _cartesian(s: Array, d: Array, s_min: float, h: float, x: Array, y: Array,
               theta: Array, kappa: Array, out_x: Array, out_y: Array,
               out_heading: Array) -> None:
    """(s, d) -> (x, y, heading of the reference line at s), `_arc_point` per point."""
    for i in range(s.shape[0]):
        out_x[i], out_y[i], out_heading[i], _ = _arc_point(s[i], d[i], s_min, h, x, y,
                                                           theta, kappa)


@njit
def _local(px: float, py: float, k: int, x: Array, y: Array, cth: Array, sth: Array,
           kappa: Array) -> tuple[float, float]:
    """(u, d) of a point against arc k: u along the arc from its start, d off it."""
    dx, dy = px - x[k], py - y[k]
    a = cth[k] * dx + sth[k] * dy
    b = -sth[k] * dx + cth[k] * dy
    kk = kappa[k]
    if kk == 0.0:
        return a, b
    u = math.atan2(kk * a, 1.0 - kk * b) / kk
    d = (2.0 * b - kk * (a * a + b * b)) / (1.0 + math.sqrt((1.0 - kk * b) ** 2 + (kk * a) ** 2))
    return u, d


@njit
def _covers(u: float, k: int, n: int, h: float) -> bool:
    """Whether u lies on arc k (the first and last arcs run on beyond the table)."""
    return (u >= -_EPS_U or k == 0) and (u <= h + _EPS_U or k == n - 1)


@njit
def _walk(px: float, py: float, k: int, h: float, x: Array, y: Array, cth: Array,
          sth: Array, kappa: Array) -> tuple[float, float, int]:
    """From arc k, step to the arc whose normals cover the point (u says how many arcs
    on); k = -1 if that takes more than 8 steps or goes back and forth."""
    n = kappa.shape[0]
    previous = -2
    for _ in range(8):
        u, d = _local(px, py, k, x, y, cth, sth, kappa)
        if _covers(u, k, n, h):
            return u, d, k
        jump = int(math.floor(u / h))
        nxt = min(max(k + (jump if jump != 0 else -1), 0), n - 1)
        if nxt == previous or nxt == k:  # noqa: SIM109 - plain compares for numba
            break
        previous, k = k, nxt
    return 0.0, 0.0, -1


@njit
def _scan(px: float, py: float, lo: int, hi: int, h: float, x: Array, y: Array,
          cth: Array, sth: Array, kappa: Array) -> tuple[float, float, int]:
    """Of arcs lo..hi-1, the one covering the point with the smallest |d| (-1: none)."""
    n = kappa.shape[0]
    best_u, best_d, best_k = 0.0, math.inf, -1
    for k in range(lo, hi):
        u, d = _local(px, py, k, x, y, cth, sth, kappa)
        if _covers(u, k, n, h) and abs(d) < abs(best_d):
            best_u, best_d, best_k = u, d, k
    return best_u, best_d, best_k


@njit
def _nearest_knot(px: float, py: float, x: Array, y: Array) -> int:
    best, k_best = math.inf, 0
    for k in range(x.shape[0] - 1):
        q = (px - x[k]) ** 2 + (py - y[k]) ** 2
        if q < best:
            best, k_best = q, k
    return k_best


@njit
def _foot(px: float, py: float, hint: float, window: int, s_min: float, h: float,
          x: Array, y: Array, cth: Array, sth: Array, kappa: Array) -> tuple[float, float, int]:
    """(u, d, k): the arc k whose normals cover the point, u along it, d off the spline.
    From the arc of the hint s (NaN: the arc of the nearest knot) walk to it; failing
    that, scan `window` arcs either way, then every arc (the smallest |d| wins); k = -1
    if no arc's normals reach the point."""
    n = kappa.shape[0]
    if math.isnan(hint):
        k0 = _nearest_knot(px, py, x, y)
    else:
        k0 = min(max(int(math.floor((hint - s_min) / h)), 0), n - 1)
    u, d, k = _walk(px, py, k0, h, x, y, cth, sth, kappa)
    if k < 0:
        u, d, k = _scan(px, py, max(k0 - window, 0), min(k0 + window + 1, n), h,
                        x, y, cth, sth, kappa)
    if k < 0:
        u, d, k = _scan(px, py, 0, n, h, x, y, cth, sth, kappa)
    return u, d, k


@njit
def _frenet(px: Array, py: Array, hint: Array, window: int, s_min: float, h: float,
            x: Array, y: Array, cth: Array, sth: Array, kappa: Array, out_s: Array,
            out_d: Array) -> None:
    """(x, y) -> (s, d) by `_foot` per point; NaN if no arc's normals reach the point
    (far inside a bend: not on this road)."""
    for i in range(px.shape[0]):
        u, d, k = _foot(px[i], py[i], hint[i], window, s_min, h, x, y, cth, sth, kappa)
        if k < 0:
            out_s[i], out_d[i] = math.nan, math.nan
        else:
            out_s[i], out_d[i] = s_min + k * h + u, d


@njit
def _view(px: Array, py: Array, heading: Array, hint: float, window: int, s_min: float,
          h: float, x: Array, y: Array, cth: Array, sth: Array, kappa: Array, theta: Array,
          d_offset: float, out_s: Array, out_d: Array, out_rel: Array, out_q: Array) -> None:
    """Cartesian poses -> (s, d, heading relative to the line, stretch q) in one pass
    (`ArcFrame.view`): `_frenet`'s s and d, then the line's heading and curvature at s
    as `ArcFrame.tangent` takes them and q as `road_view.stretch`, operation by
    operation; NaN for a point no arc's normals reach."""
    n = kappa.shape[0]
    two_pi = 2.0 * math.pi
    for i in range(px.shape[0]):
        u, d, k = _foot(px[i], py[i], hint, window, s_min, h, x, y, cth, sth, kappa)
        if k < 0:
            out_s[i] = out_d[i] = out_rel[i] = out_q[i] = math.nan
            continue
        s = s_min + k * h + u
        dd = d + d_offset
        j = min(max(int(math.floor((s - s_min) / h)), 0), n - 1)
        kap = kappa[j]
        th = theta[j] + kap * (s - (s_min + j * h))
        out_s[i], out_d[i] = s, dd
        out_rel[i] = (heading[i] - th + math.pi) % two_pi - math.pi
        out_q[i] = 1.0 - kap * (dd - d_offset)


# ---------------------------------------------------------------- one point, packed frame
# A frame packed for compiled callers (`packed`): `fp` = [curved (0/1), s_min, h, d_offset,
# x0, y0] and `fr` = rows x, y, cos theta, sin theta, kappa, theta of the arc table (one
# column of zeros for a StraightFrame).
FP_CURVED, FP_S_MIN, FP_H, FP_D_OFFSET, FP_X0, FP_Y0 = 0, 1, 2, 3, 4, 5


@njit
def pose_in_frame(fp: Array, fr: Array, px: float, py: float,
                  s_hint: float) -> tuple[float, float, float, float]:
    """(s, d, heading of the reference line at s, its curvature) of one Cartesian point;
    `s_hint` as in `ArcFrame.to_frenet` (NaN: none). A StraightFrame: s = x - x0,
    d = y - y0, 0, 0 (exactly the identity when x0 = y0 = 0)."""
    if fp[FP_CURVED] == 0.0:
        return px - fp[FP_X0], py - fp[FP_Y0], 0.0, 0.0
    s_min, h, kappa, theta = fp[FP_S_MIN], fp[FP_H], fr[4], fr[5]
    u, d, k = _foot(px, py, s_hint, WINDOW, s_min, h, fr[0], fr[1], fr[2], fr[3], kappa)
    if k < 0:
        return math.nan, math.nan, math.nan, math.nan
    return s_min + k * h + u, d + fp[FP_D_OFFSET], theta[k] + kappa[k] * u, kappa[k]


@njit
def point_of_frame(fp: Array, fr: Array, s: float, d: float) -> tuple[float, float, float,
                                                                        float]:
    """(x, y, heading of the reference line at s, its curvature) of one road point (s, d)."""
    if fp[FP_CURVED] == 0.0:
        if fp[FP_X0] == 0.0 and fp[FP_Y0] == 0.0:  # the identity (-0.0 + 0.0 would be 0.0)
            return s, d, 0.0, 0.0
        return s + fp[FP_X0], d + fp[FP_Y0], 0.0, 0.0
    return _arc_point(s, d - fp[FP_D_OFFSET], fp[FP_S_MIN], fp[FP_H], fr[0], fr[1], fr[5],
                      fr[4])


@register_warm_up
def _warm_up() -> None:
    z = np.zeros(2)
    one = np.ones(1)
    _cartesian(z[:1], z[:1], 0.0, 1.0, z, z, z, one, z[:1].copy(), z[:1].copy(), z[:1].copy())
    _frenet(z[:1], z[:1], np.full(1, np.nan), 1, 0.0, 1.0, z, z, one[:1].repeat(2), z, one,
            z[:1].copy(), z[:1].copy())
    _view(z[:1], z[:1], z[:1], math.nan, 1, 0.0, 1.0, z, z, one[:1].repeat(2), z, one, z, 0.0,
          z[:1].copy(), z[:1].copy(), z[:1].copy(), z[:1].copy())
    for curved in (0.0, 1.0):
        fp = np.array([curved, 0.0, 1.0, 0.0, 0.0, 0.0])
        fr = np.zeros((6, 2))
        fr[2] = 1.0
        pose_in_frame(fp, fr, 0.5, 0.1, 0.0)
        point_of_frame(fp, fr, 0.5, 0.1)


# ---------------------------------------------------------------- frames
def _arrays(*values: ArrayLike) -> tuple[tuple[int, ...], list[Array]]:
    arrays = np.broadcast_arrays(*[np.asarray(v, dtype=np.float64) for v in values])
    shape = arrays[0].shape
    return shape, [np.ascontiguousarray(a).ravel() for a in arrays]


def _shaped(shape: tuple[int, ...], *arrays: Array) -> tuple[Any, ...]:
    if shape == ():
        return tuple(float(a[0]) for a in arrays)
    return tuple(a.reshape(shape) for a in arrays)


class StraightFrame:
    """The frame of a straight road along +x: s = x - x0, d = y - y0 (the identity when
    x0 = y0 = 0), heading 0, curvature 0."""

    def __init__(self, x0: float, y0: float, length: float, extension: float = 200.0) -> None:
        self.x0 = float(x0)
        self.y0 = float(y0)
        self.length = float(length)  # m, of the route's reference lane
        self.s_min = -float(extension)
        self.s_max = self.length + float(extension)
        self.quality = FrameQuality(0.0, math.inf, 0.0, 0.0)

    def to_cartesian(self, s: ArrayLike, d: ArrayLike) -> tuple[Any, Any, Any]:
        """(x, y, heading of the road) of road coordinates (s, d); arrays or floats."""
        shape, (s_, d_) = _arrays(s, d)
        return _shaped(shape, s_ + self.x0, d_ + self.y0, np.zeros_like(s_))

    def to_frenet(self, x: ArrayLike, y: ArrayLike,
                  s_hint: ArrayLike | None = None) -> tuple[Any, Any]:
        """(s, d) of Cartesian points; arrays or floats (`s_hint` unused: exact)."""
        del s_hint
        if type(x) is float and type(y) is float:  # one point (the loop's SV, each step)
            return x - self.x0, y - self.y0
        shape, (x_, y_) = _arrays(x, y)
        return _shaped(shape, x_ - self.x0, y_ - self.y0)

    def heading(self, s: ArrayLike) -> Any:
        """rad, the reference line's heading at s."""
        return np.zeros_like(np.asarray(s, dtype=np.float64)) + 0.0

    def packed(self) -> tuple[Array, Array]:
        """(fp, fr) for compiled callers (`pose_in_frame`, `point_of_frame`)."""
        return np.array([0.0, self.s_min, 1.0, 0.0, self.x0, self.y0]), np.zeros((6, 1))

    def curvature(self, s: ArrayLike) -> Any:
        """1/m, the reference line's curvature at s (+: bending left)."""
        return np.zeros_like(np.asarray(s, dtype=np.float64)) + 0.0

    def tangent(self, s: ArrayLike) -> tuple[Any, Any]:
        """(heading rad, curvature 1/m) of the reference line at s: 0, 0."""
        return self.heading(s), self.curvature(s)


@dataclass(frozen=True)
class ArcTable:
    """An arc spline's table: its knots every h of arc length and the arcs between."""

    s_min: float  # m, s of the first knot
    h: float  # m, arc length from one knot to the next
    x: Array  # m, knot x
    y: Array  # m, knot y
    theta: Array  # rad, heading at the knot
    kappa: Array  # 1/m, curvature of the arc that starts at the knot


class ArcFrame:
    """The frame along an arc spline (see the module docstring). `d_offset` is added to
    the offset from the spline: d = 0 lies `d_offset` to the right of it."""

    def __init__(self, table: ArcTable, d_offset: float, length: float, extension: float,
                 quality: FrameQuality) -> None:
        self.s_min = float(table.s_min)
        self.h = float(table.h)
        self.x = np.ascontiguousarray(table.x, dtype=np.float64)
        self.y = np.ascontiguousarray(table.y, dtype=np.float64)
        self.theta = np.ascontiguousarray(table.theta, dtype=np.float64)
        self._cos = np.cos(self.theta)
        self._sin = np.sin(self.theta)
        self.kappa = np.ascontiguousarray(table.kappa, dtype=np.float64)
        self.d_offset = float(d_offset)
        self.length = float(length)  # m, s of the reference lane's end (its start: s = 0)
        self.s_max = self.s_min + self.h * len(self.kappa)
        self.extension = float(extension)
        self.quality = quality

    @property
    def s(self) -> Array:
        """m, the table's knots."""
        return self.s_min + self.h * np.arange(len(self.x))

    def to_cartesian(self, s: ArrayLike, d: ArrayLike) -> tuple[Any, Any, Any]:
        """(x, y, heading of the road) of road coordinates (s, d); arrays or floats.
        Beyond the table the end arcs go on (straight)."""
        shape, (s_, d_) = _arrays(s, d)
        n = s_.shape[0]
        ox, oy, oh = np.empty(n), np.empty(n), np.empty(n)
        _cartesian(s_, d_ - self.d_offset, self.s_min, self.h, self.x, self.y, self.theta,
                   self.kappa, ox, oy, oh)
        return _shaped(shape, ox, oy, oh)

    def to_frenet(self, x: ArrayLike, y: ArrayLike,
                  s_hint: ArrayLike | None = None) -> tuple[Any, Any]:
        """(s, d) of Cartesian points; arrays or floats. `s_hint` (m, per point or one for
        all; NaN or None: none) is where to look first, e.g. the point's s a step ago.
        A point no arc's normals reach (far inside a bend) gives NaN."""
        hint = np.nan if s_hint is None else s_hint
        shape, (x_, y_, h_) = _arrays(x, y, hint)
        n = x_.shape[0]
        os_, od = np.empty(n), np.empty(n)
        _frenet(x_, y_, h_, WINDOW, self.s_min, self.h, self.x, self.y, self._cos,
                self._sin, self.kappa, os_, od)
        return _shaped(shape, os_, od + self.d_offset)

    def view(self, x: Array, y: Array, heading: Array, s_hint: float | None
             ) -> tuple[Array, Array, Array, Array]:
        """(s, d, heading relative to the line, stretch q = 1 - kappa(s) (d - d_offset))
        of Cartesian poses (arrays), all searched from one hint (m; None: none): what
        `to_frenet`, `tangent` and `cosim.traffic.road_view.stretch` give, in one
        compiled pass (the scene's conversion every step)."""
        px = np.ascontiguousarray(x, dtype=np.float64)
        n = px.shape[0]
        out = np.empty((4, n))
        _view(px, np.ascontiguousarray(y, dtype=np.float64),
              np.ascontiguousarray(heading, dtype=np.float64),
              math.nan if s_hint is None else float(s_hint), WINDOW, self.s_min, self.h,
              self.x, self.y, self._cos, self._sin, self.kappa, self.theta, self.d_offset,
              out[0], out[1], out[2], out[3])
        return out[0], out[1], out[2], out[3]

    def packed(self) -> tuple[Array, Array]:
        """(fp, fr) for compiled callers (`pose_in_frame`, `point_of_frame`)."""
        fp = np.array([1.0, self.s_min, self.h, self.d_offset, 0.0, 0.0])
        fr = np.ascontiguousarray(np.vstack([self.x[:len(self.kappa)], self.y[:len(self.kappa)],
                                             self._cos[:len(self.kappa)],
                                             self._sin[:len(self.kappa)], self.kappa,
                                             self.theta[:len(self.kappa)]]))
        return fp, fr

    def _arc(self, s: ArrayLike) -> tuple[Any, Any]:
        if isinstance(s, float) and not math.isnan(s):  # one point (the SV's, each step)
            k = min(max(int(math.floor((s - self.s_min) / self.h)), 0), len(self.kappa) - 1)
            return k, s - (self.s_min + k * self.h)
        s_ = np.asarray(s, dtype=np.float64)
        k = np.clip(np.floor((s_ - self.s_min) / self.h).astype(np.int64), 0,
                    len(self.kappa) - 1)
        return k, s_ - (self.s_min + k * self.h)

    def heading(self, s: ArrayLike) -> Any:
        """rad, the reference line's heading at s."""
        k, u = self._arc(s)
        return self.theta[k] + self.kappa[k] * u

    def curvature(self, s: ArrayLike) -> Any:
        """1/m, the reference line's curvature at s (+: bending left; constant per arc)."""
        k, _ = self._arc(s)
        return self.kappa[k]

    def tangent(self, s: ArrayLike) -> tuple[Any, Any]:
        """(heading rad, curvature 1/m) of the reference line at s, in one lookup."""
        k, u = self._arc(s)
        kappa = self.kappa[k]
        return self.theta[k] + kappa * u, kappa


Frame = StraightFrame | ArcFrame


# ---------------------------------------------------------------- smoothing
def _resample(points: Array, h: float) -> tuple[Array, float]:
    """The polyline resampled every ~h (an integer number of equal steps); its length."""
    seg = np.hypot(*np.diff(points, axis=0).T)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    total = float(cum[-1])
    n = max(2, int(math.ceil(total / h)))
    t = np.linspace(0.0, total, n + 1)
    return np.column_stack((np.interp(t, cum, points[:, 0]),
                            np.interp(t, cum, points[:, 1]))), total


def _whittaker(points: Array, ell: float) -> Array:
    """Smoothing spline of order 3 over equally spaced points (rows), smoothing length
    ell (m): minimise |p - r|^2 + (ell/step)^6 |D3 p|^2, a banded system. The caller
    spaces the points at ell / 32 or closer, so that (ell/step)^6 stays near 1e9 and the
    system well conditioned."""
    from scipy.linalg import solveh_banded

    n = points.shape[0]
    if ell <= 0.0 or n < 8:
        return points.copy()
    step = float(np.hypot(*(points[1] - points[0])))
    lam = (ell / step) ** 6
    w = np.array([-1.0, 3.0, -3.0, 1.0])  # a row of D3
    m = n - 3
    bands = np.zeros((4, n))  # D3^T D3, upper banded form (row 3 the diagonal)
    for off in range(4):
        for a in range(4 - off):
            np.add.at(bands[3 - off], np.arange(m) + a + off, w[a] * w[a + off])
    bands *= lam
    bands[3] += 1.0
    centre = points.mean(axis=0)
    return solveh_banded(bands, points - centre) + centre


def _max_kink(points: Array) -> float:
    """rad, a polyline's largest turn at one vertex."""
    v = np.diff(points, axis=0)
    ang = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    return float(np.abs(np.diff(ang)).max(initial=0.0))


def _arc_spline(points: Array, h: float, extension: float) -> tuple[Array, ...]:
    """Knots every h of the G1 arc spline whose headings follow the smoothed points'
    (the mean of the two chords at each point, interpolated in arc length), positions
    integrated arc by arc from the first point; `extension` straight at both ends."""
    v = np.diff(points, axis=0)
    chord = np.hypot(v[:, 0], v[:, 1])
    phi = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    theta_pts = np.concatenate(([phi[0]], 0.5 * (phi[:-1] + phi[1:]), [phi[-1]]))
    cum = np.concatenate(([0.0], np.cumsum(chord)))
    total = float(cum[-1])
    n = max(1, int(math.ceil(total / h)))
    n_ext = int(math.ceil(extension / h))
    s_core = h * np.arange(n + 1)
    th_core = np.interp(s_core, cum, theta_pts)
    theta = np.concatenate((np.full(n_ext, th_core[0]), th_core, np.full(n_ext, th_core[-1])))
    dth = np.diff(theta)
    kappa = dth / h
    mid = theta[:-1] + 0.5 * dth
    step = h * np.sinc(dth / (2.0 * np.pi))  # chord of an arc: h sin(dth/2) / (dth/2)
    dx = np.concatenate(([0.0], np.cumsum(step * np.cos(mid))))
    dy = np.concatenate(([0.0], np.cumsum(step * np.sin(mid))))
    # place the knot of s = 0 on the first smoothed point
    x = points[0, 0] + dx - dx[n_ext]
    y = points[0, 1] + dy - dy[n_ext]
    return x, y, theta, kappa, n_ext


def deviation(frame: StraightFrame | ArcFrame, polyline: ArrayLike,
              centre: Callable[[Array], Array] | None = None,
              skip: Sequence[tuple[float, float]] = ()) -> float:
    """m, Hausdorff distance between a SUMO polyline (rows x, y) and the frame's line
    d = centre(s) (default: the reference line) over the polyline's extent: each of the
    polyline's points (every <= 0.5 m, its vertices included) against the line (|d -
    centre(s)|, exact where centre is constant), each of the line's points (every 0.5 m)
    against the polyline's nearby segments; none of them within a `skip` range of s (m:
    where the line shifts sideways as SUMO's lanes step, `LateralShift.window`)."""
    return _distances(frame, polyline, centre, skip)[0]


def departure(frame: StraightFrame | ArcFrame, polyline: ArrayLike, bound: float
              ) -> tuple[float, float, float]:
    """(m, m, m): the deviation of the frame's reference line from a SUMO polyline
    (`deviation`) and the first place (x, y) along the polyline where the two lie more
    than `bound` apart (nan, nan: nowhere). Past that place the line may stay off by
    about as much (its positions are integrated), so the worst place can lie far
    downstream of the cause."""
    dev, one, other = _distances(frame, polyline, None)
    for points, off in (one, other):
        over = np.flatnonzero(~(off <= bound))  # nan (off the line's reach) counts as over
        if over.size:
            return dev, float(points[over[0], 0]), float(points[over[0], 1])
    return dev, math.nan, math.nan


def _distances(frame: StraightFrame | ArcFrame, polyline: ArrayLike,
               centre: Callable[[Array], Array] | None,
               skip: Sequence[tuple[float, float]] = ()
               ) -> tuple[float, tuple[Array, Array], tuple[Array, Array]]:
    """`deviation` and, each in order along its line, the polyline's points with their
    distances from the frame's line and the line's points with their distances from
    the polyline (none where a point of the polyline lies beyond the line's reach)."""
    ref = float(getattr(frame, "d_offset", 0.0))
    line_d = centre if centre is not None else (lambda s: np.full(np.shape(s), ref))
    dense = _with_vertices(np.asarray(polyline, dtype=np.float64), 0.5)
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(dense, axis=0).T))))
    s0, _ = frame.to_frenet(dense[0, 0], dense[0, 1])
    s_raw, d_raw = frame.to_frenet(dense[:, 0], dense[:, 1], s_hint=s0 + along)
    off_line = np.abs(d_raw - line_d(s_raw))
    for lo, hi in skip:
        off_line[(s_raw >= lo) & (s_raw <= hi)] = 0.0
    if np.isnan(s_raw).any():
        return math.inf, (dense, off_line), (np.empty((0, 2)), np.empty(0))
    one = float(off_line.max())
    knots = np.arange(s_raw[0], s_raw[-1], 0.5)
    kx, ky, _ = frame.to_cartesian(knots, line_d(knots))
    order = np.argsort(s_raw, kind="stable")
    near = np.clip(np.searchsorted(s_raw[order], knots)[:, None] + np.arange(-4, 4)[None, :],
                   0, len(s_raw) - 2)
    near = np.minimum(order[near], len(s_raw) - 2)
    q0, q1 = dense[near], dense[near + 1]
    v = q1 - q0
    w = np.stack((kx, ky), axis=-1)[:, None, :] - q0
    t = np.clip(np.einsum("ijk,ijk->ij", w, v) / np.maximum(np.einsum("ijk,ijk->ij", v, v),
                                                              1e-300), 0.0, 1.0)
    off_poly = np.hypot(*(w - t[..., None] * v).transpose(2, 0, 1)).min(axis=1)
    for lo, hi in skip:
        off_poly[(knots >= lo) & (knots <= hi)] = 0.0
    other = float(off_poly.max(initial=0.0))
    return max(one, other), (dense, off_line), (np.stack((kx, ky), axis=-1), off_poly)


SMOOTHERSTEP_PEAK = 10.0 / math.sqrt(3.0)  # largest |S''| of S(u) = 6u^5 - 15u^4 + 10u^3


@dataclass(frozen=True)
class LateralShift:
    """Where the reference lane steps sideways at a junction (lanes re-spread at a
    lane-count change) and how the reference line shifts with it: by `jump` m to the
    left, along a quintic smootherstep over `length` m centred on the junction (its
    curvature continuous, zero at both ends, at most SMOOTHERSTEP_PEAK jump / length^2)."""

    s: float  # m, the junction's middle along the frame
    jump: float  # m, + to the left
    length: float  # m, over which the line shifts

    @property
    def window(self) -> tuple[float, float]:
        """m, the s range over which the line shifts."""
        return self.s - 0.5 * self.length, self.s + 0.5 * self.length

    def offset(self, s: ArrayLike) -> Any:
        """m, how far the line has shifted at s (0 before the window, `jump` after)."""
        u = np.clip((np.asarray(s, dtype=np.float64) - self.s) / self.length + 0.5, 0.0, 1.0)
        return self.jump * u * u * u * (10.0 + u * (6.0 * u - 15.0))


def shifted(frame: ArcFrame, steps: Sequence[tuple[float, float, float]], raw: Array,
            radius: float, limits: FrameLimits = DEFAULT_LIMITS
            ) -> tuple[ArcFrame, tuple[LateralShift, ...]]:
    """The frame of a line that follows `frame`'s reference line but shifts sideways at
    each step (x, y of a junction's middle on that line, jump m to the left) as a
    `LateralShift` long enough that the shift alone bends no tighter than `radius` m
    (lengthened, up to 4 times, where it would bring the line's smallest radius below
    90 % of the least of `radius` and the unshifted line's); s = 0 at `raw`'s first
    point (SUMO's polyline with its steps) and the route's end at its last. The shifts
    come back with their s in the new frame."""
    h = limits.spacing
    s_of = [float(frame.to_frenet(x, y)[0]) for x, y, _ in steps]
    core = np.arange(0.0, frame.length + 0.5 * h, h)
    goal = RADIUS_SHARE * min(frame.quality.min_radius, radius)
    built: tuple[ArcFrame, list[LateralShift]] | None = None
    for longer in (1.0, 2.0, 4.0, 8.0):
        shifts = [LateralShift(s, jump, math.sqrt(SMOOTHERSTEP_PEAK * abs(jump) * radius
                                                  * longer))
                  for s, (_, _, jump) in zip(s_of, steps, strict=True)]
        offset = sum((sh.offset(core) for sh in shifts), np.zeros_like(core))
        x, y, _ = frame.to_cartesian(core, frame.d_offset + offset)
        moved = _frame_of(np.column_stack((x, y)), raw, limits, frame.d_offset,
                          frame.quality.smoothing_length)
        built = moved, shifts
        if moved.quality.min_radius >= goal:
            break
    assert built is not None
    moved, shifts = built
    quality = FrameQuality(frame.quality.max_deviation, moved.quality.min_radius,
                           frame.quality.smoothing_length, frame.quality.max_kink,
                           frame.quality.coarse)
    out = ArcFrame(ArcTable(moved.s_min, h, moved.x, moved.y, moved.theta, moved.kappa),
                   frame.d_offset, moved.length, limits.extension, quality)
    # each shift's middle and length as the new frame measures them
    placed = []
    for sh in shifts:
        ends = np.array([*sh.window, sh.s])
        px, py, _ = frame.to_cartesian(ends, frame.d_offset
                                       + sum((o.offset(ends) for o in shifts), np.zeros(3)))
        (a, b, mid), _ = out.to_frenet(px, py, s_hint=ends)
        placed.append(LateralShift(float(mid), sh.jump, float(b - a)))
    return out, tuple(placed)


def _frame_of(points: Array, raw: Array, limits: FrameLimits, d_offset: float,
              ell: float) -> ArcFrame:
    """The arc-spline frame through smoothed points, s = 0 at SUMO's first point."""
    h = limits.spacing
    x, y, theta, kappa, n_ext = _arc_spline(points, h, limits.extension)
    kmax = float(np.abs(kappa).max())
    quality = FrameQuality(math.nan, math.inf if kmax == 0.0 else 1.0 / kmax, ell,
                           _max_kink(raw))
    frame = ArcFrame(ArcTable(-n_ext * h, h, x, y, theta, kappa), d_offset, 0.0,
                     limits.extension, quality)
    s0, _ = frame.to_frenet(raw[0, 0], raw[0, 1], s_hint=0.0)
    end_hint = h * (len(x) - 1 - 2 * n_ext)
    s1, _ = frame.to_frenet(raw[-1, 0], raw[-1, 1], s_hint=end_hint)
    return ArcFrame(ArcTable(-n_ext * h - s0, h, x, y, theta, kappa), d_offset, s1 - s0,
                    limits.extension, quality)


Attempt = tuple[float, ArcFrame, float, float]  # (ell m, frame, deviation m, min radius m)
Where = Callable[[float, float], str]  # a point (x, y) in the network's words ("on edge e1")


def _choose(tried: list[Attempt], wider: Callable[[], list[Attempt]], raw: Array,
            wanted: float, reach: float, limits: FrameLimits, source: str,
            where: Where | None) -> Attempt:
    """The smoothing to keep among those tried (by growing ell, the first within
    max_deviation): the least that reaches the radius the target deviation allows, at
    least SUMO's vertex spacing, more for coarse vertices (up to coarse_deviation,
    `wider`, where max_deviation leaves the line far tighter than the curve its
    vertices lie on), and at least the smallest radius the limits allow for lanes
    `reach` m across (InputError if none)."""
    # the least smoothing that gets within RADIUS_SHARE of the largest smallest-radius
    # reachable within the target deviation: more would only bend SUMO's curves
    within = [t for t in tried if t[2] <= limits.target_deviation] or tried[:1]
    reachable = max(t[3] for t in within)
    chosen = next(t for t in within if t[3] >= RADIUS_SHARE * reachable)
    # and at least SUMO's vertex spacing where the target deviation allows: shorter
    # smoothing leaves the curvature rippling between the vertices (+-10 % at 10 m
    # spacing and ell = 2.8 m on the curved motorway), which the smallest radius does not
    # show but the controller follows
    spacing = float(np.median(np.hypot(*np.diff(raw, axis=0).T)))
    smoother = [t for t in within if t[0] >= max(spacing, chosen[0])]
    if smoother:
        chosen = smoother[0]
    # the radius worth smoothing towards: the curve SUMO's vertices lie on (none where
    # kinks sit between straights: a junction's jog), at most what the speed limit needs
    implied = min(polyline_radius(raw), wanted)
    if math.isfinite(implied) and chosen[3] < RADIUS_SHARE * implied:
        # coarse vertices (an OSM import: 60 m apart, 3 degree kinks) or a jog: within
        # the target the line still bends far tighter at each vertex than the curve the
        # vertices lie on, so spend up to max_deviation to come nearer that radius
        near = [t for t in tried if t[2] <= limits.max_deviation]
        goal = RADIUS_SHARE * min(implied, max(t[3] for t in near))
        chosen = next(t for t in near if t[3] >= goal)
        if chosen[3] < RADIUS_SHARE * implied:
            # still kinked at the vertices (a 6.6 degree kink keeps R ~100 m within 0.2
            # m): the road bends as the curve they lie on, SUMO's chords are its drawing
            near += wider()
            goal = RADIUS_SHARE * min(implied, max(t[3] for t in near))
            chosen = next(t for t in near if t[3] >= goal)
    curve = polyline_radius(raw)
    if math.isfinite(curve) and curve > implied and chosen[3] < RADIUS_SHARE * curve:
        # a curve drawn by its vertices wider than the speed limit needs: a line stopped
        # at the limit's radius bends at each vertex and runs straight between them (its
        # curvature rippling from 0 to 1/R every vertex, which the controller follows),
        # so smooth on towards the curve, only so far from SUMO's polyline that the
        # lanes, offset from the line, stay within max_deviation too
        wide = [t for t in tried if t[2] <= RIPPLE_DEVIATION_SHARE * limits.max_deviation]
        goal = RADIUS_SHARE * min(curve, max((t[3] for t in wide), default=0.0))
        wider_line = next((t for t in wide if t[3] >= goal), chosen)
        if wider_line[3] > chosen[3]:
            chosen = wider_line
    floor = max(limits.min_radius, reach / (1.0 - limits.min_stretch))
    if chosen[3] < floor:
        better = [t for t in tried if t[2] <= limits.max_deviation and t[3] >= floor]
        if not better:
            best = max((t for t in tried if t[2] <= limits.max_deviation),
                       key=lambda t: t[3], default=tried[0])
            k = int(np.argmax(np.abs(best[1].kappa)))
            raise InputError(source, "reference line radius", f"{best[3]:.1f} m",
                             f"a route whose lanes can be smoothed to a radius of at least "
                             f"{floor:.3g} m within {limits.max_deviation:g} m of "
                             f"SUMO's lane shape (where the frame's stretch across its "
                             f"lanes' {reach:g} m stays >= {limits.min_stretch:g}, above the "
                             f"SV's turning circle of {limits.min_radius:g} m; its tightest "
                             f"bend, near "
                             f"{_place(best[1].x[k], best[1].y[k], where)}, keeps a radius of "
                             f"{best[3]:.1f} m at a deviation of {best[2]:.3f} m)")
        chosen = min(better, key=lambda t: t[0])
    return chosen


def smooth(polyline: ArrayLike, limits: FrameLimits = DEFAULT_LIMITS, *,
           d_offset: float = 0.0, source: str = "network",
           where: Where | None = None, speed_limit: float = math.inf,
           reach: float = DEFAULT_REACH,
           corners: Sequence[tuple[ArrayLike, ArrayLike]] = ()) -> ArcFrame:
    """The arc-spline frame of a polyline (rows x, y; SUMO's lane shape), smoothed as
    the module docstring says; `d_offset` (m) places d = 0 that far right of it;
    `speed_limit` (m/s) the route's highest: a radius over speed_limit^2 /
    limits.limit_lat_accel is all smoothing needs to reach; `reach` (m) how far the
    route's lanes lie across from the line at most (the smallest radius allowed, with
    `limits.min_stretch`); `corners`: each corner's fillet (its two tangent points,
    cosim.road.corners), whose radius is chosen there: the radii smoothing seeks and
    the limits check are the line's outside them (the fillets' ends spread by the
    smoothing length twice and CORNER_SPREAD).
    Raises InputError(source, ...) if it cannot be smoothed within the limits, naming
    the place (x, y and what `where` says of it)."""
    raw = np.asarray(polyline, dtype=np.float64)
    keep = np.concatenate(([True], np.hypot(*np.diff(raw, axis=0).T) > 1e-9))
    raw = raw[keep]
    if raw.shape[0] < 2:
        raise InputError(source, "reference lane", raw.tolist(),
                         "a lane shape of two or more distinct points")
    h = limits.spacing
    line = _forward(raw)

    def attempt(ell: float) -> Attempt:
        points = _whittaker(_resample(line, max(h, ell / 32.0))[0], ell)
        frame = _frame_of(points, raw, limits, d_offset, ell)
        return ell, frame, deviation(frame, raw), _radius_outside(frame, corners, ell)

    lengths = [0.0] + [h * 2.0 ** (k / 2.0) for k in range(0, 15)]  # 0, 0.5 m .. 64 m
    tried = []
    for ell in lengths:  # deviation grows with ell: stop once past the largest bound
        tried.append(attempt(ell))
        if tried[-1][2] > limits.max_deviation:
            break
    if tried[0][2] > limits.max_deviation:  # more smoothing only departs further
        raise _too_far(tried[0], raw, limits, source, where)

    def wider() -> list[Attempt]:
        """More smoothing, up to coarse_deviation: the ladder on from where it stopped,
        then halving the step between the last ell within the bound and the first
        beyond (deviation grows with ell)."""
        if limits.coarse_deviation <= limits.max_deviation:
            return []
        more = [t for t in tried if limits.max_deviation < t[2] <= limits.coarse_deviation]
        last = tried[-1]
        for ell in lengths[len(tried):]:
            if last[2] > limits.coarse_deviation:
                break
            last = attempt(ell)
            if last[2] <= limits.coarse_deviation:
                more.append(last)
        below = max((t[0] for t in tried + more if t[2] <= limits.coarse_deviation),
                    default=0.0)
        if last[2] > limits.coarse_deviation and below > 0.0:
            lo, hi = below, last[0]
            for _ in range(COARSE_BISECTIONS):
                mid = attempt(math.sqrt(lo * hi))
                if mid[2] <= limits.coarse_deviation:
                    more.append(mid)
                    lo = mid[0]
                else:
                    hi = mid[0]
        return sorted(more, key=lambda t: t[0])

    wanted = speed_limit**2 / limits.limit_lat_accel
    chosen = _choose(tried, wider, raw, wanted, reach, limits, source, where)
    ell, frame, dev, _ = chosen
    return ArcFrame(ArcTable(frame.s_min, h, frame.x, frame.y, frame.theta, frame.kappa),
                    d_offset, frame.length, limits.extension,
                    FrameQuality(dev, frame.quality.min_radius, ell,
                                 frame.quality.max_kink, dev > limits.max_deviation))


# m, how far past twice the smoothing length the smoothed line still bends with a
# corner's fillet (the spline overshoots past its ends: game/ramp's R 330 m at 3 m)
CORNER_SPREAD = 5.0  # tuned: docs/tuned_constants.md


def _radius_outside(frame: ArcFrame, corners: Sequence[tuple[ArrayLike, ArrayLike]],
                    ell: float) -> float:
    """m, the line's smallest radius outside its corners' fillets (each from its first
    tangent point to its second, spread by 2 ell + CORNER_SPREAD either way)."""
    if not corners:
        return frame.quality.min_radius
    keep = np.ones(len(frame.kappa), dtype=bool)
    knots = frame.s_min + frame.h * np.arange(len(frame.kappa))
    pad = 2.0 * ell + CORNER_SPREAD
    for t1, t2 in corners:
        (lo, hi), _ = frame.to_frenet(np.array([t1[0], t2[0]]), np.array([t1[1], t2[1]]))
        keep &= (knots < lo - pad) | (knots > hi + pad)
    kmax = float(np.abs(frame.kappa[keep]).max(initial=0.0))
    return math.inf if kmax == 0.0 else 1.0 / kmax


def _too_far(attempt: Attempt, raw: Array, limits: FrameLimits, source: str,
             where: Where | None) -> InputError:
    """The refusal of a lane shape that even the unsmoothed line (`attempt`, ell = 0)
    does not follow within max_deviation: a kink too sharp for the arc spline through
    its vertices (a road whose lanes jump sideways at a junction). It names where the
    line first leaves SUMO's shape, not where it lies furthest off."""
    _, frame, dev, _ = attempt
    _, x, y = departure(frame, raw, limits.max_deviation)
    turn = math.degrees(_turn_near(raw, x, y))
    return InputError(source, "reference line deviation", f"{dev:.3f} m",
                      f"a route whose lanes can be smoothed within {limits.max_deviation:g} m "
                      f"of SUMO's lane shape (even the line through SUMO's vertices, "
                      f"unsmoothed, is {dev:.3f} m off it, leaving it where SUMO's lane turns "
                      f"by {turn:.0f} degrees, near {_place(x, y, where)})")


def _place(x: float, y: float, where: Where | None) -> str:
    """A point in words: its coordinates and what `where` says of it."""
    said = f", {where(x, y)}" if where is not None else ""
    return f"x = {x:.1f}, y = {y:.1f}{said}"


def _turn_near(points: Array, x: float, y: float) -> float:
    """rad, how far a polyline turns at its inner vertex nearest (x, y) (0: none)."""
    if len(points) < 3:
        return 0.0
    i = 1 + int(np.argmin(np.hypot(points[1:-1, 0] - x, points[1:-1, 1] - y)))
    a, b = points[i] - points[i - 1], points[i + 1] - points[i]
    return abs(math.atan2(a[0] * b[1] - a[1] * b[0], a[0] * b[0] + a[1] * b[1]))


def polyline_radius(points: Array) -> float:
    """m, the radius of the curve a polyline's vertices lie on, as its turns imply: at a
    vertex inside a run of turns one way (its neighbours turn the same way: a curve
    drawn as a polyline, not one kink between straights), the mean length of its two
    segments over its turn angle; the 10th percentile over those vertices (inf: none).
    A percentile, not the minimum, so that one short segment does not speak for the
    route."""
    seg = np.diff(points, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    turn = np.angle(np.exp(1j * np.diff(np.arctan2(seg[:, 1], seg[:, 0]))))
    way = np.where(np.abs(turn) > 1e-4, np.sign(turn), 0.0)
    inside = np.zeros(turn.size, dtype=bool)
    inside[1:-1] = (way[1:-1] != 0.0) & (way[:-2] == way[1:-1]) & (way[2:] == way[1:-1])
    if not inside.any():
        return math.inf
    radius = 0.5 * (length[:-1] + length[1:])[inside] / np.abs(turn[inside])
    return float(np.percentile(radius, 10.0))


def _forward(points: Array) -> Array:
    """The polyline with each place where it turns back on itself (a lane that starts a
    little behind the end of the one before it) replaced by the middle of the two
    vertices: a smoothing spline through a reversal would loop. The deviation is still
    measured against every vertex of SUMO's polyline."""
    p = points.copy()
    for _ in range(len(points)):
        v = np.diff(p, axis=0)
        back = np.flatnonzero(np.einsum("ij,ij->i", v[:-1], v[1:]) < 0.0)  # > 90 degrees
        if back.size == 0 or len(p) <= 2:
            break
        i = back[0] + 1  # the vertex where it turns back; merged with the next one
        j = min(i + 1, len(p) - 1)
        p = np.concatenate((p[:i], 0.5 * (p[i] + p[j])[None, :], p[j + 1:]))
    return p


def _with_vertices(raw: Array, h: float) -> Array:
    """The polyline with points added every <= h along each segment (vertices kept)."""
    out = [raw[:1]]
    for a, b in zip(raw[:-1], raw[1:], strict=True):
        n = max(1, int(math.ceil(math.dist(a, b) / h)))
        t = (np.arange(1, n + 1) / n)[:, None]
        out.append(a + t * (b - a))
    return np.concatenate(out)


# ---------------------------------------------------------------- path states (Werling)
def cartesian_state(frame: StraightFrame | ArcFrame, s: ArrayLike, d: ArrayLike,
                    s_dot: ArrayLike, d1: ArrayLike, d2: ArrayLike) -> tuple[Any, ...]:
    """(x, y, theta, kappa, v) of a path point given in the frame: s, d (m), s_dot =
    ds/dt (m/s), d1 = dd/ds (-), d2 = d^2d/ds^2 (1/m). Werling et al. 2010, Appendix,
    with the arc's curvature kappa_r constant (kappa_r' = 0):

        1 - kappa_r d = q,  dtheta = atan(d1 / q),  theta = theta_r + dtheta,
        kappa = ((d2 + kappa_r d1 tan dtheta) cos^2 dtheta / q + kappa_r) cos dtheta / q,
        v = s_dot q / cos dtheta.
    """
    x, y, theta_r = frame.to_cartesian(s, d)
    s_, d_, sd, p1, p2 = (np.asarray(v, dtype=np.float64) for v in (s, d, s_dot, d1, d2))
    kr = np.asarray(frame.curvature(s_), dtype=np.float64)
    q = 1.0 - kr * (d_ - getattr(frame, "d_offset", 0.0))
    dth = np.arctan2(p1, q)
    c = np.cos(dth)
    kappa = ((p2 + kr * p1 * np.tan(dth)) * c * c / q + kr) * c / q
    return x, y, theta_r + dth, kappa, sd * q / c


def frenet_state(frame: StraightFrame | ArcFrame, x: ArrayLike, y: ArrayLike,
                 theta: ArrayLike, kappa: ArrayLike, v: ArrayLike,
                 s_hint: ArrayLike | None = None) -> tuple[Any, ...]:
    """(s, d, s_dot, d1, d2) of a Cartesian path point (x, y, heading theta, curvature
    kappa, speed v): the inverse of `cartesian_state` (Werling et al. 2010, Appendix):

        d1 = q tan dtheta,  d2 = -kappa_r d1 tan dtheta
                                 + q / cos^2 dtheta (kappa q / cos dtheta - kappa_r),
        s_dot = v cos dtheta / q.
    """
    s, d = frame.to_frenet(x, y, s_hint)
    th, kx, vv = (np.asarray(a, dtype=np.float64) for a in (theta, kappa, v))
    kr = np.asarray(frame.curvature(s), dtype=np.float64)
    q = 1.0 - kr * (np.asarray(d) - getattr(frame, "d_offset", 0.0))
    dth = np.angle(np.exp(1j * (th - np.asarray(frame.heading(s)))))
    c = np.cos(dth)
    t = np.tan(dth)
    d1 = q * t
    d2 = -kr * d1 * t + q / (c * c) * (kx * q / c - kr)
    return s, d, vv * c / q, d1, d2


# ---------------------------------------------------------------- distortion over a body
def kappa_max(frame: StraightFrame | ArcFrame, s_lo: float, s_hi: float) -> float:
    """1/m, the largest |curvature| of the reference line over [s_lo, s_hi]."""
    if isinstance(frame, StraightFrame):
        return 0.0
    n = len(frame.kappa)
    k0 = min(max(int(math.floor((s_lo - frame.s_min) / frame.h)), 0), n - 1)
    k1 = min(max(int(math.floor((s_hi - frame.s_min) / frame.h)), k0), n - 1)
    return float(np.abs(frame.kappa[k0:k1 + 1]).max())


def distortion_margin(kappa: float, d_abs: ArrayLike, half_diagonal: float) -> Any:
    """m, how far the (s, d) image of a rigid body's points can lie from the same body
    drawn as a rectangle in (s, d) (its offsets from the centre taken as (s, d) offsets):
    for a body of half-diagonal r centred at |d| <= d_abs from the reference line itself
    (the frame's d minus its `d_offset`), on a reference line of
    |curvature| <= kappa over the body's reach. About a circle of radius 1/kappa, with
    q = 1 - kappa (|d| + r) > 0, a point at offsets (a, b), |(a, b)| <= r, lands at

        along s:  |s - s0 - a| <= kappa r (|d| + r) / q + kappa^2 r^3 / (3 q^3),
        across:   |d - d0 - b| <= kappa r^2 / (2 q),

    and the margin is the length of that error vector (DESIGN: kappa_max (|d| r + r^2)).
    Growing both rectangles of a pair by it keeps an (s, d) test sound in the Cartesian
    plane. inf where q <= 0 (the body reaches the centre of curvature)."""
    d = np.abs(np.asarray(d_abs, dtype=np.float64))
    r = float(half_diagonal)
    q = 1.0 - kappa * (d + r)
    with np.errstate(divide="ignore", invalid="ignore"):
        along = kappa * r * (d + r) / q + kappa**2 * r**3 / (3.0 * q**3)
        across = kappa * r * r / (2.0 * q)
        out = np.where(q > 0.0, np.hypot(along, across), np.inf)
    return float(out) if out.ndim == 0 else out
