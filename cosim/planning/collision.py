"""Rectangle overlap tests and the vectorised collision check (Section 3.2, eq. 9-11).

Vehicles are rectangles centred on the trajectory point and turned by the
heading phi: vertices = centre + R(phi) (+-l/2, +-w/2) (eq. 9, with the printed
rotation block corrected).

Two tests:
- `overlap_sat`: exact, by separating axes (two rectangles are disjoint iff their
  projections on one of the four edge normals are disjoint). Optional margin.
- `overlap_col`: the paper's CoL (Appendix 9.2): a vertex of the SV is inside a TV
  rectangle when the four triangles it spans with the TV's edges add up to the
  TV's area. It misses two rectangles that cross without a vertex inside.

`check_cluster` runs one of them over candidates x time x TV hypotheses with a
two-stage distance pre-filter, and grows every rectangle by the most the
relative pose can change in half a sample step, so no overlap can pass between
two samples (beyond the paper).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

COLLISION_TESTS = ("exact", "col")


def corners(x: ArrayLike, y: ArrayLike, heading: ArrayLike, length: ArrayLike,
            width: ArrayLike) -> Array:
    """m, the four vertices (eq. 9) shaped (..., 4, 2), counter-clockwise from rear right."""
    x, y, h = (np.asarray(a, dtype=float) for a in (x, y, heading))
    hl = 0.5 * np.asarray(length, dtype=float)
    hw = 0.5 * np.asarray(width, dtype=float)
    c, s = np.cos(h), np.sin(h)
    out = []
    for sl, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        lx, ly = sl * hl, sw * hw
        out.append(np.stack(np.broadcast_arrays(x + c * lx - s * ly, y + s * lx + c * ly), -1))
    return np.stack(out, axis=-2)


def overlap_sat(
    ax: ArrayLike, ay: ArrayLike, ah: ArrayLike, al: ArrayLike, aw: ArrayLike,
    bx: ArrayLike, by: ArrayLike, bh: ArrayLike, bl: ArrayLike, bw: ArrayLike,
    margin: ArrayLike = 0.0,
) -> NDArray[np.bool_]:
    """Exact overlap of rectangles A and B (centre, heading, length, width; broadcast),
    each grown by `margin` on every side. Touching counts as overlap."""
    m = np.asarray(margin, dtype=float)
    hla, hwa = 0.5 * np.asarray(al) + m, 0.5 * np.asarray(aw) + m
    hlb, hwb = 0.5 * np.asarray(bl) + m, 0.5 * np.asarray(bw) + m
    ah = np.asarray(ah, dtype=float)
    bh = np.asarray(bh, dtype=float)
    ca, sa = np.cos(ah), np.sin(ah)
    cb, sb = np.cos(bh), np.sin(bh)
    # |cos| and |sin| of the relative heading bh - ah, without more trigonometry
    C, S = np.abs(ca * cb + sa * sb), np.abs(sa * cb - ca * sb)
    dx = np.asarray(bx, dtype=float) - ax
    dy = np.asarray(by, dtype=float) - ay
    # centre offset in A's frame and in B's frame (axes ua, va of A; ub, vb of B)
    da_u = dx * ca + dy * sa
    da_v = -dx * sa + dy * ca
    db_u = dx * cb + dy * sb
    db_v = -dx * sb + dy * cb
    sep = np.abs(da_u) > hla + C * hlb + S * hwb
    sep |= np.abs(da_v) > hwa + S * hlb + C * hwb
    sep |= np.abs(db_u) > hlb + C * hla + S * hwa
    sep |= np.abs(db_v) > hwb + S * hla + C * hwa
    return ~sep


def overlap_col(
    ax: ArrayLike, ay: ArrayLike, ah: ArrayLike, al: ArrayLike, aw: ArrayLike,
    bx: ArrayLike, by: ArrayLike, bh: ArrayLike, bl: ArrayLike, bw: ArrayLike,
) -> NDArray[np.bool_]:
    """The paper's CoL (Appendix 9.2): True when a vertex of A (the SV) lies inside B
    (a TV), judged by triangle areas: inside iff the four triangles (vertex, edge of B)
    add up to B's area (s_a - s_i > 0 for every vertex means no collision)."""
    va = corners(ax, ay, ah, al, aw)  # (..., 4, 2)
    vb = corners(bx, by, bh, bl, bw)
    area_b = np.asarray(bl, dtype=float) * np.asarray(bw, dtype=float)
    p = va[..., :, None, :]  # (..., 4 vertices of A, 1, 2)
    e0 = vb[..., None, :, :]  # (..., 1, 4 edges' start, 2)
    e1 = np.roll(vb, -1, axis=-2)[..., None, :, :]
    cross = (e0[..., 0] - p[..., 0]) * (e1[..., 1] - p[..., 1]) - (
        e0[..., 1] - p[..., 1]
    ) * (e1[..., 0] - p[..., 0])
    s_vertex = 0.5 * np.abs(cross).sum(axis=-1)  # (..., 4)
    inside = s_vertex - np.asarray(area_b)[..., None] <= 1e-9 * np.maximum(area_b, 1.0)[..., None]
    return inside.any(axis=-1)


@dataclass(frozen=True)
class ClusterHits:
    """Each SV candidate's first overlap with any TV hypothesis."""

    collides: NDArray[np.bool_]  # (n_c,)
    first_index: IntArray  # (n_c,) time index of the first overlap (-1: none)
    first_hypothesis: IntArray  # (n_c,) the TV hypothesis it overlaps first (-1: none)
    triplets_checked: int  # -, (candidate, hypothesis, time) triplets given to the exact test


@dataclass(frozen=True)
class ClusterMotion:
    """Bounds on how the SV cluster moves between two samples (from its positions)."""

    dx_min: float  # m, least x travel of any candidate in one step
    dx_max: float  # m, most x travel in one step
    dy_max: float  # m, most |y| travel in one step
    turn: float  # rad, most heading change in one step
    max_heading: float  # rad, most |heading| anywhere


def cluster_motion(sv_x: Array, sv_y: Array) -> ClusterMotion:
    """Step bounds of a cluster (n_c, n_t) from its chords: the heading is within one
    chord-angle change of the chord's direction (the path turns by less than twice that
    per step; |d atan(s)| <= |ds| bounds the chord-angle change by the slope change)."""
    if sv_x.shape[1] < 3:
        return ClusterMotion(0.0, 0.0, 0.0, 0.0, 0.5 * np.pi)
    ddx = np.diff(sv_x, axis=1)
    ddy = np.diff(sv_y, axis=1)
    slope = ddy / np.maximum(ddx, 1e-9)  # the SV drives forwards
    turn = 2.0 * float(np.abs(np.diff(slope, axis=1)).max())
    return ClusterMotion(
        dx_min=float(ddx.min()), dx_max=float(ddx.max()), dy_max=float(np.abs(ddy).max()),
        turn=turn, max_heading=float(np.arctan(np.abs(slope).max())) + turn,
    )


def standard_cluster_motion(
    vx0: float, vxf: float, width: float, tau_shortest: float, dt: float
) -> ClusterMotion:
    """The same bounds in closed form for a cluster of eq. 2 / eq. 4 lane changes
    (no initial lateral motion or acceleration), from its shortest candidate:
    x' stays between vx0 and vxf; |y'| <= 1.875 |W| / tau; |y''| <= 5.7736 |W| / tau^2;
    |x''| <= 1.5 |vxf - vx0| / tau; heading rate <= |y''| / x' + |y'| |x''| / x'^2."""
    v_lo, v_hi = min(vx0, vxf), max(vx0, vxf)
    w = abs(width)
    yd = 1.875 * w / tau_shortest
    ydd = 5.7736 * w / tau_shortest**2
    xdd = 1.5 * abs(vxf - vx0) / tau_shortest
    v_lo = max(v_lo, 1e-3)
    rate = ydd / v_lo + yd * xdd / v_lo**2
    return ClusterMotion(
        dx_min=v_lo * dt, dx_max=v_hi * dt, dy_max=yd * dt, turn=rate * dt,
        max_heading=float(np.arctan(yd / v_lo)),
    )


def sampling_pad(
    sv: ClusterMotion, tv_x: Array, tv_y: Array, tv_h: Array, sv_radius: float,
    tv_radius: Array,
) -> Array:
    """m, per TV hypothesis (n_h,): how much each rectangle must grow so that an
    overlap at any time between two samples shows at the nearest sample.

    Between samples the relative pose changes by at most D (relative centre travel
    plus each body's radius times its heading change, per step); at the nearest
    sample (<= half a step away) the bodies are apart by at most D/2, so growing
    each by D/4 keeps the overlap.
    """
    ddx_tv = np.diff(tv_x, axis=1)  # (n_h, n_t-1)
    rel_x = np.maximum(ddx_tv.max(axis=1) - sv.dx_min, sv.dx_max - ddx_tv.min(axis=1))
    rel_y = np.abs(np.diff(tv_y, axis=1)).max(axis=1) + sv.dy_max
    rot = sv_radius * sv.turn + tv_radius * np.abs(np.diff(tv_h, axis=1)).max(axis=1)
    return 0.25 * (np.hypot(rel_x, rel_y) + rot)


HeadingFn = Callable[[IntArray, IntArray], Array]
# (candidate indices (m,), times (m, n)) -> SV (x, y, heading), each (m, n)
PoseFn = Callable[[IntArray, Array], tuple[Array, Array, Array]]
REFINE_SUBSTEPS = 8  # -, instants per sample step where a padded overlap is looked at again


@dataclass(frozen=True)
class _Ordered:
    """One coordinate of the SV cluster (n_c, n_t), if it is monotone along the
    candidates at every time, as one sorted array (each time's column shifted past
    the previous one), so that windows are binary searches."""

    flat: Array  # (n_t * n_c,)
    span: float
    flip: bool  # the column falls along the candidates
    n_r: int


ORDER_TOLERANCE = 1e-9  # m, rounding that does not break the order (windows are widened by it)


def _ordered(values: Array, slack: float) -> _Ordered | None:
    n_r = values.shape[0]
    steps = np.diff(values, axis=0)
    rising = bool((steps >= -ORDER_TOLERANCE).all())
    if n_r > 1 and not rising and not (steps <= ORDER_TOLERANCE).all():
        return None
    flip = n_r > 1 and not rising
    ys = values[::-1] if flip else values
    span = float(ys.max() - ys.min()) + 2.0 * slack + 1.0
    flat = (ys + span * np.arange(values.shape[1])[None, :]).T.ravel()
    return _Ordered(flat, span, flip, n_r)


def _run(o: _Ordered, col: IntArray, value: Array, half: Array) -> tuple[IntArray, IntArray]:
    """Candidate rows [lo, hi) with |value at (row, col[q]) - value[q]| <= half[q]."""
    base = col * o.span
    wide = half + 1e3 * ORDER_TOLERANCE  # rounding wobble stays inside the window
    lo = np.searchsorted(o.flat, base + value - wide, side="left") - col * o.n_r
    hi = np.searchsorted(o.flat, base + value + wide, side="right") - col * o.n_r
    lo, hi = np.clip(lo, 0, o.n_r), np.clip(hi, 0, o.n_r)
    if o.flip:
        lo, hi = o.n_r - hi, o.n_r - lo
    return lo, hi


def _expand(lo: IntArray, hi: IntArray) -> tuple[IntArray, IntArray]:
    """(row, query) for every row in [lo[q], hi[q])."""
    counts = np.maximum(hi - lo, 0)
    q = np.repeat(np.arange(lo.size), counts)
    starts = np.cumsum(counts) - counts
    return lo[q] + (np.arange(q.size) - starts[q]), q


class ArrayCluster:
    """An SV cluster given as (n_c, n_t) arrays of x and y (any cluster)."""

    def __init__(self, x: Array, y: Array, heading: Array | HeadingFn) -> None:
        self.x, self.y = x, y
        self.n_c, self.n_t = x.shape
        self._heading = heading
        self._ord: tuple[_Ordered | None, _Ordered | None] | None = None

    def bbox(self) -> tuple[Array, Array, Array, Array]:
        """m, per time (n_t,): x min, x max, y min, y max over the candidates."""
        return self.x.min(axis=0), self.x.max(axis=0), self.y.min(axis=0), self.y.max(axis=0)

    def xy(self, c: IntArray, k: IntArray) -> tuple[Array, Array]:
        return self.x[c, k], self.y[c, k]

    def heading(self, c: IntArray, k: IntArray) -> Array:
        h = self._heading
        return h(c, k) if callable(h) else h[c, k]

    def windows(self, k: IntArray, x: Array, hx: Array, y: Array, hy: Array,
                slack: float) -> tuple[IntArray, IntArray] | None:
        """Candidate rows [lo, hi) that may lie within (hx, hy) of (x, y) at time index k
        (a superset), or None when the cluster is not ordered (every row may)."""
        if self._ord is None:
            # a lane-change cluster is ordered by tau at every time (|y| falls, and x
            # moves one way, as tau grows): each window condition holds on one run of rows
            self._ord = (_ordered(self.x, slack), _ordered(self.y, slack))
        runs = [_run(o, k, v, lim) for o, v, lim in zip(self._ord, (x, y), (hx, hy), strict=True)
                if o is not None]
        if not runs:
            return None
        return np.maximum.reduce([r[0] for r in runs]), np.minimum.reduce([r[1] for r in runs])


INVERSE_NODES = 16384  # -, value steps of the inverse tables of eq. 2 and eq. 4 below


def _falling_inverse(f: Callable[[Array], Array], values: Array) -> Array:
    """Roots u in [0, 1] of f(u) = values for a falling f (bisection to the last bit)."""
    lo, hi = np.zeros(values.size), np.ones(values.size)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = f(mid) > values
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return 0.5 * (lo + hi)


@functools.cache
def _inverse_tables() -> tuple[Array, Array]:
    """Inverses on even value steps j / INVERSE_NODES, j = 0 .. INVERSE_NODES:
    of P(s) = 10 s^3 - 15 s^4 + 6 s^5 (eq. 4 normalised: rising from 0 to 1) at the
    values j / n, and of H(u) = 1 - u^2 + u^3 / 2 (eq. 2: x = x0 + vxf t + (vx0 - vxf)
    t H(t / tau), falling from 1 to 1/2 on [0, 1], 1 / (2 u) past it) at 1 - j / (2 n).
    Both inverses rise with j, so entries j and j + 1 bracket any value between."""
    n = INVERSE_NODES
    v = np.arange(n + 1) / n
    s_of_p = _falling_inverse(lambda s: -(s**3 * (10.0 - 15.0 * s + 6.0 * s * s)), -v)
    u_of_h = _falling_inverse(lambda u: 1.0 - u * u + 0.5 * u**3, 1.0 - 0.5 * v)
    s_of_p[0], s_of_p[-1], u_of_h[0], u_of_h[-1] = 0.0, 1.0, 0.0, 1.0
    return s_of_p, u_of_h


_WINDOW_TOLERANCE = 1e-6  # m, the windows' boxes are grown by this (rounding)


class StandardCluster:
    """The SV cluster of eq. 2 / eq. 4 from rest (no initial lateral motion or
    acceleration), never stored as (n_c, n_t) arrays: positions are computed where
    they are asked for (`standard_positions_at`, the same numbers as
    `standard_positions`), the per-time bounding box from the two extreme candidates
    and the candidate windows by inverting eq. 2 and eq. 4 in tau (both are monotone
    in tau at any fixed time)."""

    def __init__(self, t: Array, taus: Array, x0: float, y0: float, vx0: float, vxf: float,
                 width: float, heading: HeadingFn) -> None:
        self.t, self.taus = t, taus  # taus sorted ascending
        self.x0, self.y0, self.vx0, self.vxf, self.width = x0, y0, vx0, vxf, width
        self.n_c, self.n_t = taus.size, t.size
        self._heading = heading
        # evenly spaced from the second candidate on (the first may be tau_min itself):
        # index ranges by arithmetic instead of a binary search per query
        steps = np.diff(taus[1:])
        self._step = float(steps.mean()) if steps.size else 0.0
        self._even = steps.size > 0 and self._step > 0.0 and bool(
            np.all(np.abs(steps - self._step) <= 1e-9 * self._step))

    def _index_range(self, tau_lo: Array, tau_hi: Array) -> tuple[IntArray, IntArray]:
        """Candidates [lo, hi) holding every tau in [tau_lo, tau_hi], and one more on
        each side (rounding)."""
        n_c = self.n_c
        if not self._even:
            lo = np.searchsorted(self.taus, tau_lo, side="left") - 1
            hi = np.searchsorted(self.taus, tau_hi, side="right") + 1
        else:  # taus[j] = taus[1] + (j - 1) step for j >= 1, taus[0] <= taus[1]
            t1, d = self.taus[1], self._step
            lo = np.floor(np.minimum(np.maximum((tau_lo - t1) / d, -2.0), n_c)) - 1.0
            hi = np.ceil(np.minimum(np.maximum((tau_hi - t1) / d, -2.0), n_c)) + 3.0
            with np.errstate(invalid="ignore"):  # nan at t = 0 (handled by the caller)
                lo, hi = lo.astype(np.int64), hi.astype(np.int64)
        return np.maximum(lo, 0), np.minimum(hi, n_c)

    def xy(self, c: IntArray, k: IntArray) -> tuple[Array, Array]:
        from cosim.planning.trajectory import standard_positions_at

        x, y = standard_positions_at(self.vx0, self.vxf, self.width, self.taus[c], self.t[k])
        x += self.x0
        y += self.y0
        return x, y

    def heading(self, c: IntArray, k: IntArray) -> Array:
        return self._heading(c, k)

    def bbox(self) -> tuple[Array, Array, Array, Array]:
        ends = np.array([0, self.n_c - 1])
        x, y = self.xy(np.repeat(ends, self.n_t), np.tile(np.arange(self.n_t), 2))
        x, y = x.reshape(2, self.n_t), y.reshape(2, self.n_t)
        tol = _WINDOW_TOLERANCE
        return x.min(axis=0) - tol, x.max(axis=0) + tol, y.min(axis=0) - tol, y.max(axis=0) + tol

    def windows(self, k: IntArray, x: Array, hx: Array, y: Array, hy: Array,
                slack: float) -> tuple[IntArray, IntArray]:
        """Candidates [lo, hi) whose centre may be within (hx, hy) of (x, y) at time
        index k: a superset (table brackets, grown boxes, one more candidate each side)."""
        tol = _WINDOW_TOLERANCE
        n = INVERSE_NODES
        s_of_p, u_of_h = _inverse_tables()
        t = self.t[k]
        tau_lo = np.zeros(k.size)
        tau_hi = np.full(k.size, np.inf)
        empty = np.zeros(k.size, dtype=bool)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.width != 0.0:  # y = y0 + W P(s), s = min(t / tau, 1)
                a = (y - hy - tol - self.y0) * (n / self.width)  # in table steps
                b = (y + hy + tol - self.y0) * (n / self.width)
                if self.width < 0:
                    a, b = b, a
                empty |= (a > n) | (b < 0.0)
                # s >= s_lo (a table entry at or below the root): tau <= t / s_lo;
                # s <= s_hi < 1 (at or above): tau >= t / s_hi
                s_lo = s_of_p[np.minimum(np.maximum(a, 0.0), n).astype(np.int64)]
                s_hi = s_of_p[np.minimum(np.maximum(np.ceil(b), 0.0), n).astype(np.int64)]
                tau_hi = t / s_lo  # s_lo = 0: inf
                tau_lo = np.where(s_hi < 1.0, t / s_hi, 0.0)
            dv = self.vx0 - self.vxf
            if dv != 0.0:  # x = x0 + vxf t + dv t H(t / tau)
                base = self.x0 + self.vxf * t
                d = dv * t
                ha = (x - hx - tol - base) / d
                hb = (x + hx + tol - base) / d
                ha, hb = np.minimum(ha, hb), np.maximum(ha, hb)
                empty |= (ha > 1.0) | (hb <= 0.0)
                # H(u) <= hb: u >= u_lo; H(u) >= ha: u <= u_hi (H falls); table step
                # j holds the root of H = 1 - j / (2 n)
                ja = (1.0 - ha) * (2 * n)
                jb = (1.0 - hb) * (2 * n)
                u_lo = np.where(
                    hb >= 0.5, u_of_h[np.minimum(np.maximum(jb, 0.0), n).astype(np.int64)],
                    0.5 / hb * (1.0 - 1e-9))
                u_hi = np.where(
                    ha >= 0.5,
                    u_of_h[np.minimum(np.maximum(np.ceil(ja), 0.0), n).astype(np.int64)],
                    np.where(ha > 0.0, 0.5 / ha * (1.0 + 1e-9), np.inf))
                tau_lo = np.maximum(tau_lo, t / u_hi)
                tau_hi = np.minimum(tau_hi, t / u_lo)  # u_lo = 0: inf
        lo, hi = self._index_range(tau_lo, tau_hi)
        hi = np.maximum(np.where(empty, lo, hi), lo)
        at_start = t <= 0.0
        if at_start.any():  # every candidate is at the start point: all or none
            inside = ((np.abs(x - self.x0) <= hx + tol) & (np.abs(y - self.y0) <= hy + tol))
            lo = np.where(at_start, 0, lo)
            hi = np.where(at_start, np.where(inside, self.n_c, 0), hi)
        return lo, hi


SVCluster = ArrayCluster | StandardCluster


def _sat_parts(
    ax: Array, ay: Array, ah: Array, al: float, aw: float, bx: Array, by: Array, bh: Array,
    bl: Array, bw: Array,
) -> tuple[Array, ...]:
    """The margin-free parts of `overlap_sat` (same operations), to test several margins."""
    ca, sa = np.cos(ah), np.sin(ah)
    cb, sb = np.cos(bh), np.sin(bh)
    C, S = np.abs(ca * cb + sa * sb), np.abs(sa * cb - ca * sb)
    dx = bx - ax
    dy = by - ay
    return (np.abs(dx * ca + dy * sa), np.abs(-dx * sa + dy * ca), np.abs(dx * cb + dy * sb),
            np.abs(-dx * sb + dy * cb), C, S, np.broadcast_to(0.5 * al, C.shape),
            np.broadcast_to(0.5 * aw, C.shape), 0.5 * bl, 0.5 * bw)


def _sat_overlap(parts: tuple[Array, ...], margin: ArrayLike) -> NDArray[np.bool_]:
    """`overlap_sat` from `_sat_parts`, bit for bit."""
    au, av, bu, bv, C, S, hal, haw, hbl, hbw = parts
    hla, hwa, hlb, hwb = hal + margin, haw + margin, hbl + margin, hbw + margin
    sep = au > hla + C * hlb + S * hwb
    sep |= av > hwa + S * hlb + C * hwb
    sep |= bu > hlb + C * hla + S * hwa
    sep |= bv > hwb + S * hla + C * hwa
    return ~sep


class TVArrays:
    """TV hypotheses given as (n_h, n_t) arrays, with their sampling pads (n_h,)."""

    def __init__(self, x: Array, y: Array, heading: Array, length: Array, width: Array,
                 pad: Array | None) -> None:
        self.x, self.y, self.h = x, y, heading
        self.n_h = x.shape[0]
        self.length, self.width = length, width
        self.pad_bound = np.zeros(self.n_h) if pad is None else np.asarray(pad, dtype=float)

    def pad(self, h: IntArray) -> Array:
        """m, the exact sampling pad of hypotheses h (`pad_bound` is at least that)."""
        return self.pad_bound[h]

    def xy(self, h: IntArray, k: IntArray) -> tuple[Array, Array]:
        return self.x[h, k], self.y[h, k]

    def heading(self, h: IntArray, k: IntArray) -> Array:
        return self.h[h, k]

    def near(self, box: tuple[Array, Array, Array, Array], reach: Array,
             last_k: IntArray) -> tuple[IntArray, IntArray]:
        """(h, k) with k < last_k[h] and the TV within reach[h] of the box at t_k, in
        time order (then h)."""
        return _near_rows(self.x, self.y, box, reach, last_k)


def _near_rows(x: Array, y: Array, box: tuple[Array, Array, Array, Array], reach: Array,
               last_k: IntArray) -> tuple[IntArray, IntArray]:
    bx0, bx1, by0, by1 = box
    r = reach[:, None]
    near = ((np.arange(x.shape[1])[None, :] < last_k[:, None])
            & (x >= bx0 - r) & (x <= bx1 + r) & (y >= by0 - r) & (y <= by1 + r))
    pk, ph = np.nonzero(near.T)
    return ph, pk


class TVClosedForm:
    """TV hypotheses of `prediction.LazyFutures`: stored rows plus C2 clusters from rest
    in closed form, evaluated only where the check asks (each cluster is ordered by tau
    at every time, like the SV's, so it is searched through `StandardCluster`). The
    sampling pad of a closed-form hypothesis is exact (`sampling_pad` over its whole
    row) where the exact test needs it; the filters before use a closed-form bound."""

    def __init__(self, futures: Any, sv_motion: ClusterMotion, sv_radius: float) -> None:
        f = self.f = futures
        self.n_h = f.n_hypotheses
        self.length, self.width = f.length, f.width
        self._motion, self._r_sv = sv_motion, sv_radius
        self._r_tv = 0.5 * np.hypot(f.length, f.width)
        self._pad = np.full(self.n_h, np.nan)
        if f.stored.size:
            self._pad[f.stored] = sampling_pad(sv_motion, f.sx, f.sy, f.sh, sv_radius,
                                               self._r_tv[f.stored])
        self.pad_bound = self._pad.copy()
        closed = np.flatnonzero(f.row_of < 0)
        if closed.size:
            self.pad_bound[closed] = self._closed_pad_bound(closed)
        self._clusters = [
            StandardCluster(f.rel, f.tau[h0:h1], float(f.x0[h0]), float(f.y0[h0]),
                            float(f.v0[h0]), float(f.vxf[h0]), float(f.dy[h0]), _no_heading)
            for h0, h1 in f.blocks
        ]

    def _closed_pad_bound(self, h: IntArray) -> Array:
        """m, at least `sampling_pad` of closed-form hypotheses h, from the bounds of
        `standard_cluster_motion` (x' between v0 and vxf, |y'|, heading rate)."""
        f, sv = self.f, self._motion
        dt = float(f.rel[1] - f.rel[0]) if f.rel.size > 1 else 0.0
        v0, vxf, tau, w = f.v0[h], f.vxf[h], f.tau[h], np.abs(f.dy[h])
        v_min, v_max = np.minimum(v0, vxf), np.maximum(v0, vxf)
        v_lo = np.maximum(v_min, 1e-3)
        yd = 1.875 * w / tau
        rate = 5.7736 * w / tau**2 / v_lo + yd * (1.5 * np.abs(vxf - v0) / tau) / v_lo**2
        rel_x = np.maximum(v_max * dt - sv.dx_min, sv.dx_max - v_min * dt)
        rel_y = yd * dt + sv.dy_max
        rot = self._r_sv * sv.turn + self._r_tv[h] * rate * dt
        return 0.25 * (np.hypot(rel_x, rel_y) + rot) * (1.0 + 1e-6) + 1e-9

    def pad(self, h: IntArray) -> Array:
        todo = np.unique(h[np.isnan(self._pad[h])])
        if todo.size:
            x, y, hd = self.f.rows(todo)
            self._pad[todo] = sampling_pad(self._motion, x, y, hd, self._r_sv,
                                           self._r_tv[todo])
        return self._pad[h]

    def xy(self, h: IntArray, k: IntArray) -> tuple[Array, Array]:
        return self.f.xy(h, k)

    def heading(self, h: IntArray, k: IntArray) -> Array:
        return self.f.heading_at(h, k)

    def near(self, box: tuple[Array, Array, Array, Array], reach: Array,
             last_k: IntArray) -> tuple[IntArray, IntArray]:
        f = self.f
        n_t = f.rel.size
        hs: list[IntArray] = []
        ks: list[IntArray] = []
        if f.stored.size:
            ph, pk = _near_rows(f.sx, f.sy, box, reach[f.stored], last_k[f.stored])
            hs.append(f.stored[ph])
            ks.append(pk)
        bx0, bx1, by0, by1 = box
        for (h0, h1), cl in zip(f.blocks, self._clusters, strict=True):
            # the cluster's box at each time against the SV's, then its hypotheses
            # near the SV's box (a window of them), then each (h, k) as for rows
            r = float(reach[h0:h1].max())
            cx0, cx1, cy0, cy1 = cl.bbox()
            k = np.flatnonzero((np.arange(n_t) < last_k[h0:h1].max())
                               & (cx1 >= bx0 - r) & (cx0 <= bx1 + r)
                               & (cy1 >= by0 - r) & (cy0 <= by1 + r))
            if k.size == 0:
                continue
            lo, hi = cl.windows(k, 0.5 * (bx0[k] + bx1[k]), 0.5 * (bx1[k] - bx0[k]) + r,
                                0.5 * (by0[k] + by1[k]), 0.5 * (by1[k] - by0[k]) + r, 0.0)
            hh, q = _expand(lo, hi)
            hh += h0
            kk = k[q]
            x, y = f.xy(hh, kk)
            rr = reach[hh]
            keep = ((kk < last_k[hh]) & (x >= bx0[kk] - rr) & (x <= bx1[kk] + rr)
                    & (y >= by0[kk] - rr) & (y <= by1[kk] + rr))
            hs.append(hh[keep])
            ks.append(kk[keep])
        if not hs:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        ph, pk = np.concatenate(hs), np.concatenate(ks)
        order = np.lexsort((ph, pk))
        return ph[order], pk[order]


def _no_heading(c: IntArray, k: IntArray) -> Array:
    raise NotImplementedError  # a TV cluster is searched, its headings come from the futures


TVSource = TVArrays | TVClosedForm


def _refine(c: IntArray, h: IntArray, k: IntArray, pad_h: Array, t: Array, tv: TVSource,
            sv_pose: PoseFn, sv_length: float, sv_width: float,
            margin: float) -> NDArray[np.bool_]:
    """Overlap of candidate c and hypothesis h anywhere in [t_k - dt/2, t_k + dt/2], at
    REFINE_SUBSTEPS + 1 instants: the SV exactly (`sv_pose`), the TV interpolated
    linearly between its samples (its interpolation error bounded from the second
    differences and added to the margin with the pad `pad_h` / REFINE_SUBSTEPS)."""
    n_t = t.size
    dt = float(t[1] - t[0]) if n_t > 1 else 0.0
    n_sub = REFINE_SUBSTEPS
    frac = np.arange(n_sub + 1) / n_sub - 0.5  # (n_s,), in steps
    kp, km = np.minimum(k + 1, n_t - 1), np.maximum(k - 1, 0)
    pos = frac[None, :] > 0
    # second differences around k (at the ends of the grid, around its neighbour)
    kc = np.minimum(np.maximum(k, 1), max(n_t - 2, 1))
    k2p, k2m = np.minimum(kc + 1, n_t - 1), kc - 1
    m = k.size
    hh = np.tile(h, 6)
    kk = np.concatenate((k, kp, km, k2p, kc, k2m))
    vx, vy = tv.xy(hh, kk)
    vh = tv.heading(hh, kk)

    def interp(a: Array) -> Array:
        """Linear between the samples: towards k + 1 after t_k, from k - 1 before."""
        ak, ap, am = a[:m, None], a[m:2 * m, None], a[2 * m:3 * m, None]
        slope = np.where(pos, ap - ak, ak - am)  # (m, n_s)
        slope *= frac
        slope += ak
        return slope

    def second_diff(a: Array) -> Array:
        return np.abs(a[3 * m:4 * m] - 2 * a[4 * m:5 * m] + a[5 * m:])

    r_tv = 0.5 * np.hypot(tv.length[h], tv.width[h])
    second = second_diff(vx) + second_diff(vy) + r_tv * second_diff(vh)
    fine_pad = margin + pad_h / n_sub + 0.25 * second  # >= 2x the (dt^2/8) a bound
    sx, sy, sh = sv_pose(c, t[k][:, None] + frac[None, :] * dt)
    hit = overlap_sat(sx, sy, sh, sv_length, sv_width, interp(vx), interp(vy), interp(vh),
                      tv.length[h][:, None], tv.width[h][:, None], margin=fine_pad[:, None])
    return hit.any(axis=1)


def check_cluster(
    t: Array, sv_x: Array, sv_y: Array, sv_heading: Array | HeadingFn, sv_length: float,
    sv_width: float, sv_horizon: Array, tv_x: Array, tv_y: Array, tv_h: Array,
    tv_length: Array, tv_width: Array, tv_horizon: Array, *, margin: float = 0.0,
    test: str = "exact", pad: Array | None = None, chunk: int = 40,
    sv_max_heading: float = 0.5 * np.pi, split_above: int = 10_000,
    sv_pose: PoseFn | None = None,
) -> ClusterHits:
    """First overlap of every SV candidate (n_c, n_t) with any TV hypothesis (n_h, n_t),
    all given as arrays; see `check_sv_cluster`. `pad` (n_h,) grows the rectangles of
    the exact test (see `sampling_pad`)."""
    return check_sv_cluster(
        t, ArrayCluster(sv_x, sv_y, sv_heading), sv_length, sv_width, sv_horizon,
        TVArrays(tv_x, tv_y, tv_h, tv_length, tv_width, pad), tv_horizon, margin=margin,
        test=test, chunk=chunk, sv_max_heading=sv_max_heading, split_above=split_above,
        sv_pose=sv_pose, padded=pad is not None,
    )


def check_sv_cluster(
    t: Array, sv: SVCluster, sv_length: float, sv_width: float, sv_horizon: Array,
    tv: TVSource, tv_horizon: Array, *, margin: float = 0.0, test: str = "exact",
    chunk: int = 40, sv_max_heading: float = 0.5 * np.pi, split_above: int = 10_000,
    sv_pose: PoseFn | None = None, padded: bool = True,
) -> ClusterHits:
    """First overlap of every SV candidate (n_c of them, on the n_t times t) with any
    TV hypothesis (n_h).

    A pair (candidate c, hypothesis h) is checked at the times t_k <=
    max(sv_horizon[c], tv_horizon[h]) (eq. 10's horizon, extended by the caller).
    Stage 1 keeps the (h, k) whose TV is near the bounding box of the SV cluster at
    t_k (`tv.near`). Time is then taken in chunks (growing up to `chunk` samples;
    halved while more than `split_above` (candidate, h, k) triplets are near), in
    order, and a candidate leaves the check at its first overlap (its earliest one:
    nothing earlier can follow). Per chunk, stage 2 keeps the triplets whose centres
    are within the sum of the circumradii and whose axis-aligned boxes overlap (the
    SV's box from `sv_max_heading`, a bound on |heading| over the cluster), among
    the candidates of each (h, k)'s window (`sv.windows`); stage 3 runs the exact
    (or CoL) test on those only. Positions and headings are computed where asked.
    The exact test grows every rectangle by the hypothesis' sampling pad
    (`tv.pad`; with `padded`). With `sv_pose` (the SV's exact pose at any time), an
    overlap that exists only thanks to the pad is looked at again at
    REFINE_SUBSTEPS instants around its sample with a pad that many times smaller:
    the verdict stays conservative but nearly exact. Ties (two hypotheses first hit
    at the same sample) go to the lower hypothesis index.
    """
    n_c, n_t = sv.n_c, sv.n_t
    n_h = tv.n_h
    collides = np.zeros(n_c, dtype=bool)
    first_k = np.full(n_c, -1, dtype=np.int64)
    first_h = np.full(n_c, -1, dtype=np.int64)
    if n_h == 0 or n_c == 0:
        return ClusterHits(collides, first_k, first_h, 0)
    if test not in COLLISION_TESTS:
        raise ValueError(f"collision test {test!r}: one of {COLLISION_TESTS}")
    exact = test == "exact"
    use_pad = padded and exact
    base = margin if exact else 0.0
    grow_b = base + (tv.pad_bound if use_pad else 0.0) * np.ones(n_h)  # (n_h,) for filters
    tv_length, tv_width = tv.length, tv.width
    r_sv = 0.5 * np.hypot(sv_length, sv_width)
    r_tv = 0.5 * np.hypot(tv_length, tv_width)
    reach = r_sv + r_tv + 2.0 * np.sqrt(2.0) * grow_b  # (n_h,); growth lengthens the diagonals
    reach2 = reach**2
    # half extents of the SV's axis-aligned box for any heading within +-sv_max_heading
    sin_max = np.sin(min(abs(sv_max_heading), 0.5 * np.pi))
    sv_hx = 0.5 * sv_length + 0.5 * sv_width * sin_max
    sv_hy = 0.5 * sv_length * sin_max + 0.5 * sv_width
    last_k = np.searchsorted(t, np.maximum(sv_horizon.max(), tv_horizon), side="right")  # (n_h,)
    checked = 0

    k_end = int(last_k.max(initial=0))
    bounds = [0]
    size = max(1, chunk // 8)  # short chunks first: most overlaps, if any, come early
    while bounds[-1] < k_end:
        bounds.append(min(bounds[-1] + size, k_end))
        size = min(2 * size, chunk)
    # stage 1, once for all times: hypothesis vs the bounding box of the whole cluster
    ph_all, pk_all = tv.near(sv.bbox(), reach, last_k)  # in time order
    at = np.searchsorted(pk_all, np.arange(n_t + 1))  # pairs of time k: at[k] .. at[k + 1]
    # stage 2's boxes of every pair, and the window of candidates each may meet
    tx_all, ty_all = tv.xy(ph_all, pk_all)
    th_all = tv.heading(ph_all, pk_all)
    ct, st = np.abs(np.cos(th_all)), np.abs(np.sin(th_all))
    g2 = 2.0 * grow_b[ph_all]  # each box grows by at most 2 g (g on each of two sides' projections)
    hl, hw = 0.5 * tv_length[ph_all], 0.5 * tv_width[ph_all]
    lim_x_all = sv_hx + hl * ct + hw * st + g2
    lim_y_all = sv_hy + hl * st + hw * ct + g2
    slack = float(reach.max()) + 8.0
    win_all = sv.windows(pk_all, tx_all, lim_x_all, ty_all, lim_y_all, slack)
    todo = list(zip(bounds[:-1], bounds[1:], strict=True))[::-1]  # a stack, earliest on top
    while todo:  # chunks of time, in order
        k0, k1 = todo.pop()
        a, b = int(at[k0]), int(at[k1])
        if a == b:
            continue
        alive = np.flatnonzero(~collides)
        if alive.size == 0:
            break
        ph, pk = ph_all[a:b], pk_all[a:b]
        # stage 2: remaining candidates x surviving (h, k): boxes, centre distance, horizon
        tx, ty, th = tx_all[a:b], ty_all[a:b], th_all[a:b]
        lim_x, lim_y = lim_x_all[a:b], lim_y_all[a:b]
        if win_all is not None:  # triplets of the candidates still in the check
            win = win_all[0][a:b], win_all[1][a:b]
            alive_upto = np.concatenate(([0], np.cumsum(~collides)))
            n_near = int((alive_upto[win[1]] - alive_upto[np.minimum(win[0], win[1])]).sum())
        else:
            n_near = ph.size * alive.size
        if k1 - k0 > 1 and n_near > split_above:
            # crowded: the earlier half may settle most candidates before the later one
            mid = (k0 + k1) // 2
            todo += [(mid, k1), (k0, mid)]
            continue
        if n_near == 0:
            continue
        if win_all is not None:
            qc, qp = _expand(*win)
            keep = ~collides[qc]
            qc, qp = qc[keep], qp[keep]
        else:
            qa, qp = np.nonzero(np.ones((alive.size, pk.size), dtype=bool))
            qc = alive[qa]  # unordered cluster: every remaining candidate
        qh, qk = ph[qp], pk[qp]
        sx, sy = sv.xy(qc, qk)
        dx = sx - tx[qp]
        dy = sy - ty[qp]
        close = (
            (np.abs(dx) <= lim_x[qp]) & (np.abs(dy) <= lim_y[qp])
            & (dx * dx + dy * dy <= reach2[qh])
            & (t[qk] <= np.maximum(sv_horizon[qc], tv_horizon[qh]))
        )
        qc, qh, qk, qp = qc[close], qh[close], qk[close], qp[close]
        if qc.size == 0:
            continue
        sx, sy = sx[close], sy[close]
        if exact and margin >= 0.0:
            # a candidate's triplets after its first sure overlap cannot come first:
            # centres closer than the two inscribed radii overlap whatever the headings
            r_in = 0.5 * min(sv_length, sv_width) + 0.5 * np.minimum(tv_length[qh], tv_width[qh])
            sure = dx[close] ** 2 + dy[close] ** 2 <= (0.999 * r_in) ** 2
            if sure.any():
                first_sure = np.full(n_c, n_t)
                np.minimum.at(first_sure, qc[sure], qk[sure])
                keep = qk <= first_sure[qc]
                qc, qh, qk, qp, sx, sy = (a[keep] for a in (qc, qh, qk, qp, sx, sy))
        checked += int(qc.size)
        # stage 3: the exact test on the survivors
        args = (sx, sy, sv.heading(qc, qk), sv_length, sv_width,
                tx[qp], ty[qp], th[qp], tv_length[qh], tv_width[qh])
        if test == "col":
            ov = overlap_col(*args)
        else:
            parts = _sat_parts(*args)
            ov = _sat_overlap(parts, margin)  # at the sample itself
            if use_pad or sv_pose is None:
                # padded overlaps (at k no later than the candidate's first overlap at its
                # sample) that are not overlaps at the sample itself
                first_raw = np.full(n_c, n_t)
                np.minimum.at(first_raw, qc[ov], qk[ov])
                maybe = np.flatnonzero(~ov & (qk <= first_raw[qc]))
                pad_q = tv.pad(qh[maybe]) if use_pad else np.zeros(maybe.size)
                padded_hit = _sat_overlap(tuple(a[maybe] for a in parts), margin + pad_q)
                maybe, pad_q = maybe[padded_hit], pad_q[padded_hit]
                if maybe.size and sv_pose is not None:
                    # look between the samples, where the pad needed is n_sub times smaller
                    ov[maybe] = _refine(qc[maybe], qh[maybe], qk[maybe], pad_q, t, tv, sv_pose,
                                        sv_length, sv_width, margin)
                elif maybe.size:
                    ov[maybe] = True
        if not ov.any():
            continue
        oc, oh, ok = qc[ov], qh[ov], qk[ov]
        order = np.lexsort((oh, ok, oc))  # by candidate, then time, then hypothesis
        cs, first = np.unique(oc[order], return_index=True)
        collides[cs] = True
        first_k[cs] = ok[order][first]
        first_h[cs] = oh[order][first]
    return ClusterHits(collides, first_k, first_h, checked)
