"""Rectangle overlap tests and the collision check of a cluster (Section 3.2, eq. 9-11).

Vehicles are rectangles centred on the trajectory point and turned by the
heading phi: vertices = centre + R(phi) (+-l/2, +-w/2) (eq. 9, with the printed
rotation block corrected).

Two tests:
- `overlap_sat`: exact, by separating axes (two rectangles are disjoint iff their
  projections on one of the four edge normals are disjoint). Optional margin.
- `overlap_col`: the paper's CoL (Appendix 9.2): a vertex of the SV is inside a TV
  rectangle when the four triangles it spans with the TV's edges add up to the
  TV's area. It misses two rectangles that cross without a vertex inside.

`check_candidates` runs one of them over SV candidates x time x TV hypotheses:
compiled loops (numba) that evaluate the trajectories where they are needed,
skip what cheap boxes and distances rule out, and stop a candidate at its first
overlap. Every rectangle is grown by the most the relative pose can change in
half a sample step, so no overlap can pass between two samples (beyond the
paper); an overlap found only thanks to that growth is looked at again between
the samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit, register_warm_up
from cosim.planning.trajectory import (
    polynomial_coefficients,
    standard_bounds,
    standard_velocity,
    standard_xy,
)

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
    (no initial lateral motion or acceleration), from its shortest candidate
    (`trajectory.standard_bounds`)."""
    v_min, v_max, yd, rate, heading = standard_bounds(vx0, vxf, width, tau_shortest)
    return ClusterMotion(dx_min=max(v_min, 1e-3) * dt, dx_max=v_max * dt, dy_max=yd * dt,
                         turn=rate * dt, max_heading=heading)


def sampling_pad(
    sv: ClusterMotion, tv_x: Array, tv_y: Array, tv_h: Array, sv_radius: float,
    tv_radius: Array,
) -> Array:
    """m, per TV trajectory (n_h,) given as rows (n_h, n_t): how much each rectangle must
    grow so that an overlap at any time between two samples shows at the nearest sample.

    Between samples the relative pose changes by at most D (relative centre travel
    plus each body's radius times its heading change, per step); at the nearest
    sample (<= half a step away) the bodies are apart by at most D/2, so growing
    each by D/4 keeps the overlap.
    """
    n_h = tv_x.shape[0]
    return _hypothesis_bounds(
        sv.dx_min, sv.dx_max, sv.dy_max, sv.turn, float(sv_radius), 0.0,
        *(np.ascontiguousarray(a, dtype=float) for a in (tv_x, tv_y, tv_h)),
        np.arange(n_h), np.full((7, n_h), np.nan),
        np.ascontiguousarray(np.broadcast_to(tv_radius, (n_h,)), dtype=float))[0]


REFINE_SUBSTEPS = 8  # -, instants per sample step where a padded overlap is looked at again
_BOX_TOLERANCE = 1e-6  # m, a closed-form cluster's box from its two extreme trajectories


@dataclass(frozen=True)
class SVCandidates:
    """The SV's candidate lane changes, one per tau (eq. 2 and eq. 4; with an initial
    longitudinal acceleration, lateral speed or acceleration: the general start of
    `trajectory.cluster_derivatives`), evaluated exactly wherever the check asks, at
    manoeuvre time t + t_shift for grid time t."""

    taus: Array  # s, (n_c,)
    vx0: float  # m/s
    vxf: float  # m/s
    width: float  # m, signed lateral displacement
    x0: float  # m, global start of the CG
    y0: float  # m
    ax0: float = 0.0  # m/s^2
    vy0: float = 0.0  # m/s
    ay0: float = 0.0  # m/s^2
    t_shift: float = 0.0  # s, manoeuvre time at t = 0 of the grid

    @property
    def n_c(self) -> int:
        return int(self.taus.size)

    @property
    def standard(self) -> bool:
        """From rest laterally and with no longitudinal acceleration: eq. 2 / eq. 4 in
        closed form (`trajectory.standard_xy`)."""
        return self.ax0 == 0.0 and self.vy0 == 0.0 and self.ay0 == 0.0

    def _args(self) -> tuple[Array, Array, Array, Array]:
        """(parameters, x and y polynomial coefficients (none when standard), taus)."""
        par = np.array([self.vx0, self.vxf, self.width, self.x0, self.y0, self.t_shift])
        tau = np.ascontiguousarray(self.taus, dtype=float).reshape(-1)
        if self.standard:
            return par, np.zeros((0, 5)), np.zeros((0, 6)), tau
        cx, cy = polynomial_coefficients(self.vx0, self.vxf, self.width, tau, self.ax0,
                                         self.vy0, self.ay0)
        return par, np.stack(cx, axis=1), np.stack(cy, axis=1), tau


@dataclass(frozen=True)
class TVHypotheses:
    """TV hypotheses as the check reads them: stored rows (n_s, n_t) or lane changes from
    rest in closed form (eq. 2 / eq. 4, `trajectory.standard_xy`, parameters per
    hypothesis), grouped by vehicle (contiguous; a closed-form
    group ordered by tau), each with its sampling pad."""

    rows_x: Array  # m, (n_s, n_t)
    rows_y: Array  # m
    rows_h: Array  # rad
    row_of: IntArray  # (n_h,) stored row of each hypothesis (-1: closed form)
    closed: Array  # (7, n_h): v0 m/s, vxf m/s, W m, tau s, x0 m, y0 m, start s (nan: row)
    length: Array  # m, (n_h,)
    width: Array  # m, (n_h,)
    pad: Array  # m, (n_h,) growth that keeps overlaps between samples (`sampling_pad`)
    max_heading: Array  # rad, (n_h,) a bound on |heading|
    groups: IntArray  # (n_g + 1,) hypotheses of vehicle g: groups[g] .. groups[g + 1]

    @property
    def n_h(self) -> int:
        return int(self.row_of.size)

    @classmethod
    def from_rows(cls, x: Array, y: Array, heading: Array, length: ArrayLike,
                  width: ArrayLike, pad: ArrayLike | None = None) -> TVHypotheses:
        """Hypotheses given as (n_h, n_t) arrays, each its own group; no pad: none."""
        n_h = x.shape[0]
        return cls(
            x, y, heading, np.arange(n_h), np.full((7, n_h), np.nan),
            np.broadcast_to(np.asarray(length, dtype=float), (n_h,)),
            np.broadcast_to(np.asarray(width, dtype=float), (n_h,)),
            np.zeros(n_h) if pad is None else np.asarray(pad, dtype=float),
            np.abs(heading).max(axis=1, initial=0.0), np.arange(n_h + 1),
        )

    @classmethod
    def from_futures(cls, futures: Any, sv: ClusterMotion, sv_radius: float) -> TVHypotheses:
        """The hypotheses of `prediction.LazyFutures`, with their pads against an SV
        cluster moving within `sv`: exact (`sampling_pad`) for stored rows, a closed-form
        bound of it for lane changes from rest (no need to evaluate them whole)."""
        f = futures
        closed = np.stack([f.v0, f.vxf, f.dy, f.tau, f.x0, f.y0, f.t_start])
        r_tv = 0.5 * np.hypot(f.length, f.width)
        dt = float(f.rel[1] - f.rel[0]) if f.rel.size > 1 else 0.0
        pad, max_heading = _hypothesis_bounds(
            sv.dx_min, sv.dx_max, sv.dy_max, sv.turn, float(sv_radius), dt, f.sx, f.sy, f.sh,
            f.row_of, closed, r_tv)
        n_h = f.owner.size
        starts = np.flatnonzero(f.owner[1:] != f.owner[:-1]) + 1
        return cls(f.sx, f.sy, f.sh, f.row_of, closed, f.length, f.width, pad, max_heading,
                   np.concatenate(([0], starts, [n_h])))


def check_candidates(
    t: Array, sv: SVCandidates, sv_length: float, sv_width: float, sv_horizon: Array,
    tv: TVHypotheses, tv_horizon: Array, *, margin: float = 0.0, test: str = "exact",
    sv_max_heading: float = 0.5 * np.pi,
) -> ClusterHits:
    """First overlap of every SV candidate (n_c) with any TV hypothesis (n_h) on the
    time grid t (eq. 10-11).

    A pair (candidate c, hypothesis h) is tested at the times t_k <=
    max(sv_horizon[c], tv_horizon[h]). Time runs forwards and a candidate leaves at its
    first overlap (ties at one sample go to the lowest hypothesis). At each sample a
    vehicle's hypotheses are skipped when their box is far from the candidates' box;
    the candidates near the vehicle's box, and for each the hypotheses whose y is near
    its own, come from binary searches (a closed-form cluster, the SV's from rest and
    a C2 TV's, is ordered by tau in x and y at every sample, so its box is that of its
    two extreme trajectories); then axis-aligned boxes (from bounds on the headings)
    and centre distances; the exact test (or CoL) runs on what is left. The exact
    test grows both rectangles by the hypothesis' sampling pad, so that no overlap
    passes between samples; an overlap that exists only thanks to the pad is looked
    at again at REFINE_SUBSTEPS + 1 instants of [t_k - dt/2, t_k + dt/2] with the SV
    exact, the TV linear between samples (its error bounded by its second
    differences) and a pad that many times smaller: still conservative, nearly
    exact. The loops run compiled (numba); trajectories are evaluated where needed.
    """
    if test not in COLLISION_TESTS:
        raise ValueError(f"collision test {test!r}: one of {COLLISION_TESTS}")
    n_c = sv.n_c
    if tv.n_h == 0 or n_c == 0:
        none = np.full(n_c, -1, dtype=np.int64)
        return ClusterHits(np.zeros(n_c, dtype=bool), none, none.copy())
    sin_sv = math.sin(min(abs(sv_max_heading), 0.5 * math.pi))
    par, cx, cy, tau = sv._args()
    flt = (lambda a: np.ascontiguousarray(a, dtype=float))  # noqa: E731
    first_k, first_h = _first_overlaps(
        flt(t), par, cx, cy, tau, flt(sv_horizon), float(sv_length), float(sv_width), sin_sv,
        flt(tv.rows_x), flt(tv.rows_y), flt(tv.rows_h), tv.row_of.astype(np.int64),
        flt(tv.closed), flt(tv.length), flt(tv.width), flt(tv_horizon), flt(tv.pad),
        np.sin(np.minimum(tv.max_heading, 0.5 * np.pi)), tv.groups.astype(np.int64),
        float(margin), test == "col",
    )
    return ClusterHits(first_k >= 0, first_k, first_h)


# -- the compiled loops (numba; no fastmath: IEEE order as in numpy) ------------------------
# Helpers called in the hot loops take scalars, or one array at most: a compiled call
# that passes several arrays costs reference counting (about 100 ns with four, measured).


@njit
def _standard_heading(v0: float, vxf: float, w: float, tau: float, t: float) -> float:
    """Heading of eq. 2 / eq. 4 from rest at time t."""
    xd, yd = standard_velocity(v0, vxf, w, tau, t)
    return math.atan2(yd, xd)


@njit
def _closed_xy(closed: Array, h: int, t: float) -> tuple[float, float]:
    """Centre of closed-form hypothesis h at grid time t."""
    x, y = standard_xy(closed[0, h], closed[1, h], closed[2, h], closed[3, h],
                        t - closed[6, h])
    return x + closed[4, h], y + closed[5, h]


@njit
def _sorted_range(values: Array, a: int, b: int, lo: float, hi: float) -> tuple[int, int]:
    """[i, j) within [a, b) of the entries in [lo, hi] of values, monotone on [a, b)
    (rising or falling; binary searches; bounds widened by _BOX_TOLERANCE for rounding)."""
    lo, hi = lo - _BOX_TOLERANCE, hi + _BOX_TOLERANCE
    rising = values[a] <= values[b - 1]
    i, j = a, b
    while i < j:  # the first entry past lo (rising) / at or below hi (falling)
        mid = (i + j) // 2
        if (values[mid] < lo) if rising else (values[mid] > hi):
            i = mid + 1
        else:
            j = mid
    start, j = i, b
    while i < j:  # the first entry past hi (rising) / below lo (falling)
        mid = (i + j) // 2
        if (values[mid] <= hi) if rising else (values[mid] >= lo):
            i = mid + 1
        else:
            j = mid
    return start, i


@njit
def _general_pose(cx: Array, cy: Array, c: int, tau: float, vxf: float,
                  s: float) -> tuple[float, float, float]:
    """Relative (x, y, heading) of a general-start candidate c at manoeuvre time s (the
    Horner sums of `trajectory.cluster_derivatives`; straight at vxf after tau)."""
    ts = min(max(s, 0.0), tau)
    x = cx[c, 4]
    for j in range(3, -1, -1):
        x = x * ts + cx[c, j]
    y = cy[c, 5]
    for j in range(4, -1, -1):
        y = y * ts + cy[c, j]
    if s > tau:
        return x + vxf * (s - ts), y, math.atan2(0.0, vxf)
    xd = 4.0 * cx[c, 4]
    for j in range(3, 0, -1):
        xd = xd * ts + j * cx[c, j]
    yd = 5.0 * cy[c, 5]
    for j in range(4, 0, -1):
        yd = yd * ts + j * cy[c, j]
    return x, y, math.atan2(yd, xd)


@njit
def _sat(ax: float, ay: float, ca: float, sa: float, hla: float, hwa: float, bx: float,
         by: float, cb: float, sb: float, hlb: float, hwb: float, m: float) -> bool:
    """`overlap_sat` for one pair (cosines and sines given), both grown by m."""
    cc, ss = abs(ca * cb + sa * sb), abs(sa * cb - ca * sb)
    hla, hwa, hlb, hwb = hla + m, hwa + m, hlb + m, hwb + m
    dx, dy = bx - ax, by - ay
    return not (abs(dx * ca + dy * sa) > hla + cc * hlb + ss * hwb
                or abs(-dx * sa + dy * ca) > hwa + ss * hlb + cc * hwb
                or abs(dx * cb + dy * sb) > hlb + cc * hla + ss * hwa
                or abs(-dx * sb + dy * cb) > hwb + ss * hla + cc * hwa)


@njit
def _col(ax: float, ay: float, ah: float, al: float, aw: float, bx: float, by: float,
         bh: float, bl: float, bw: float) -> bool:
    """`overlap_col` for one pair: a vertex of A inside B by the triangle areas."""
    ca, sa, cb, sb = math.cos(ah), math.sin(ah), math.cos(bh), math.sin(bh)
    hla, hwa, hlb, hwb = 0.5 * al, 0.5 * aw, 0.5 * bl, 0.5 * bw
    area = bl * bw
    tol = 1e-9 * max(area, 1.0)
    sl = (-1.0, 1.0, 1.0, -1.0, -1.0)  # the vertices of `corners`, the first again
    sw = (-1.0, -1.0, 1.0, 1.0, -1.0)
    ex = np.empty(5)
    ey = np.empty(5)
    for i in range(5):
        ex[i] = bx + cb * (sl[i] * hlb) - sb * (sw[i] * hwb)
        ey[i] = by + sb * (sl[i] * hlb) + cb * (sw[i] * hwb)
    for i in range(4):
        px = ax + ca * (sl[i] * hla) - sa * (sw[i] * hwa)
        py = ay + sa * (sl[i] * hla) + ca * (sw[i] * hwa)
        total = 0.0
        for j in range(4):
            total += abs((ex[j] - px) * (ey[j + 1] - py) - (ey[j] - py) * (ex[j + 1] - px))
        if 0.5 * total - area <= tol:
            return True
    return False


@njit
def _refined(par: Array, cx: Array, cy: Array, tau_c: float, c: int, hla: float, hwa: float,
             rows_x: Array, rows_y: Array, rows_h: Array, row_of: IntArray, closed: Array,
             h: int, hlb: float, hwb: float, k: int, t: Array, pad_h: float,
             margin: float) -> bool:
    """Overlap of candidate c and hypothesis h anywhere in [t_k - dt/2, t_k + dt/2], at
    REFINE_SUBSTEPS + 1 instants: the SV exact, the TV linear between its samples (its
    interpolation error bounded from the second differences, added to the margin with
    the pad / REFINE_SUBSTEPS)."""
    n_t = t.size
    last = n_t - 1
    dt = t[1] - t[0] if n_t > 1 else 0.0
    kc = min(max(k, 1), max(n_t - 2, 1), last)
    # the TV at k, k + 1, k - 1 and around kc (for its second differences)
    idx = (k, min(k + 1, last), max(k - 1, 0), min(kc + 1, last), kc, max(kc - 1, 0))
    tx, ty, th = np.empty(6), np.empty(6), np.empty(6)
    r = row_of[h]
    for i in range(6):
        if r >= 0:
            tx[i], ty[i], th[i] = rows_x[r, idx[i]], rows_y[r, idx[i]], rows_h[r, idx[i]]
        else:
            v0, vxf, w, tau = closed[0, h], closed[1, h], closed[2, h], closed[3, h]
            x, y = standard_xy(v0, vxf, w, tau, t[idx[i]] - closed[6, h])
            tx[i], ty[i] = x + closed[4, h], y + closed[5, h]
            th[i] = _standard_heading(v0, vxf, w, tau, t[idx[i]] - closed[6, h])
    second = (abs(tx[3] - 2 * tx[4] + tx[5]) + abs(ty[3] - 2 * ty[4] + ty[5])
              + math.hypot(hlb, hwb) * abs(th[3] - 2 * th[4] + th[5]))
    fine = margin + pad_h / REFINE_SUBSTEPS + 0.25 * second  # >= 2x the dt^2 a / 8 bound
    last_bh, cb, sb = np.nan, 0.0, 0.0
    for j in range(REFINE_SUBSTEPS + 1):
        frac = j / REFINE_SUBSTEPS - 0.5  # in steps
        o = 1 if frac > 0 else 2  # linear towards k + 1 after t_k, from k - 1 before
        sgn = 1.0 if frac > 0 else -1.0
        bx = tx[0] + frac * (sgn * (tx[o] - tx[0]))
        by = ty[0] + frac * (sgn * (ty[o] - ty[0]))
        bh = th[0] + frac * (sgn * (th[o] - th[0]))
        sv_t = t[k] + frac * dt + par[5]
        if cx.shape[0]:  # a general start
            ax, ay, ah = _general_pose(cx, cy, c, tau_c, par[1], sv_t)
        else:
            ax, ay = standard_xy(par[0], par[1], par[2], tau_c, sv_t)
            ah = _standard_heading(par[0], par[1], par[2], tau_c, sv_t)
        ax, ay = ax + par[3], ay + par[4]
        if bh != last_bh:  # (a TV keeping its lane keeps its heading)
            last_bh, cb, sb = bh, math.cos(bh), math.sin(bh)
        if _sat(ax, ay, math.cos(ah), math.sin(ah), hla, hwa, bx, by, cb, sb, hlb, hwb, fine):
            return True
    return False


@njit
def _hypothesis_bounds(dx_min: float, dx_max: float, dy_max: float, turn: float,
                       r_sv: float, dt: float, rows_x: Array, rows_y: Array, rows_h: Array,
                       row_of: IntArray, closed: Array, r_tv: Array) -> tuple[Array, Array]:
    """(sampling pad m, bound on |heading| rad) per hypothesis: from its row (exact), or
    for a closed-form lane change from rest from `trajectory.standard_bounds`, a little
    above."""
    n_h = row_of.size
    pad = np.empty(n_h)
    max_heading = np.empty(n_h)
    for h in range(n_h):
        r = row_of[h]
        if r >= 0:
            n_t = rows_x.shape[1]
            ddx_lo, ddx_hi, ddy, dh, hd = np.inf, -np.inf, 0.0, 0.0, 0.0
            for k in range(n_t - 1):
                ddx = rows_x[r, k + 1] - rows_x[r, k]
                ddx_lo, ddx_hi = min(ddx_lo, ddx), max(ddx_hi, ddx)
                ddy = max(ddy, abs(rows_y[r, k + 1] - rows_y[r, k]))
                dh = max(dh, abs(rows_h[r, k + 1] - rows_h[r, k]))
            for k in range(n_t):
                hd = max(hd, abs(rows_h[r, k]))
            rel_x = max(ddx_hi - dx_min, dx_max - ddx_lo) if n_t > 1 else 0.0
            rel_y = ddy + dy_max
            pad[h] = 0.25 * (math.hypot(rel_x, rel_y) + r_sv * turn + r_tv[h] * dh)
            max_heading[h] = hd
        else:
            v_min, v_max, yd, rate, max_heading[h] = standard_bounds(
                closed[0, h], closed[1, h], closed[2, h], closed[3, h])
            rel_x = max(v_max * dt - dx_min, dx_max - v_min * dt)
            rel_y = yd * dt + dy_max
            rot = r_sv * turn + r_tv[h] * rate * dt
            pad[h] = 0.25 * (math.hypot(rel_x, rel_y) + rot) * (1.0 + 1e-6) + 1e-9
    return pad, max_heading


@njit
def _first_overlaps(t: Array, par: Array, cx: Array, cy: Array, ctau: Array, sv_hor: Array,
                    sv_l: float, sv_w: float, sin_sv: float, rows_x: Array, rows_y: Array,
                    rows_h: Array, row_of: IntArray, closed: Array, tv_l: Array, tv_w: Array,
                    tv_hor: Array, pad: Array, sin_tv: Array, groups: IntArray, margin: float,
                    col: bool) -> tuple[IntArray, IntArray]:
    """(first sample, first hypothesis) per candidate; see
    `check_candidates`."""
    n_c, n_t, n_h = ctau.size, t.size, row_of.size
    n_g = groups.size - 1
    general = cx.shape[0] > 0
    v0, vxf, w, x0, y0, shift = par[0], par[1], par[2], par[3], par[4], par[5]
    hla, hwa = 0.5 * sv_l, 0.5 * sv_w

    # per hypothesis: growth, reach (circle) and box half extents, both bodies together
    r_sv = math.hypot(hla, hwa)
    sv_hx, sv_hy = hla + hwa * sin_sv, hla * sin_sv + hwa
    reach2 = np.empty(n_h)
    lim_x = np.empty(n_h)
    lim_y = np.empty(n_h)
    for h in range(n_h):
        g = (0.0 if col else margin + pad[h]) * 2.0 * math.sqrt(2.0)
        r = r_sv + math.hypot(0.5 * tv_l[h], 0.5 * tv_w[h]) + g
        reach2[h] = r * r
        lim_x[h] = sv_hx + 0.5 * tv_l[h] + 0.5 * tv_w[h] * sin_tv[h] + g
        lim_y[h] = sv_hy + 0.5 * tv_l[h] * sin_tv[h] + 0.5 * tv_w[h] + g
    # per vehicle: the widest limits, the latest horizon, whether in closed form
    g_lim_x = np.zeros(n_g)
    g_lim_y = np.zeros(n_g)
    g_hor = np.full(n_g, -np.inf)
    g_closed = np.ones(n_g, dtype=np.bool_)
    for g in range(n_g):
        for h in range(groups[g], groups[g + 1]):
            g_lim_x[g] = max(g_lim_x[g], lim_x[h])
            g_lim_y[g] = max(g_lim_y[g], lim_y[h])
            g_hor[g] = max(g_hor[g], tv_hor[h])
            g_closed[g] = g_closed[g] and row_of[h] < 0
    last_t = -np.inf  # no pair is tested after this
    for c in range(n_c):
        last_t = max(last_t, sv_hor[c])
    for g in range(n_g):
        last_t = max(last_t, g_hor[g])

    first_k = np.full(n_c, -1, dtype=np.int64)
    first_h = np.full(n_c, -1, dtype=np.int64)
    alive = np.ones(n_c, dtype=np.bool_)
    n_alive = n_c
    px = np.empty(n_c)
    py = np.empty(n_c)
    sv_k = np.full(n_c, -1, dtype=np.int64)  # the sample whose heading is in sv_cs
    sv_cs = np.empty((n_c, 3))  # cos, sin, heading
    gx = np.empty(n_h)
    gy = np.empty(n_h)
    tv_hk = np.full(n_h, -1, dtype=np.int64)  # the sample whose heading is in tv_cs
    tv_cs = np.empty((n_h, 3))
    # a closed-form cluster is ordered by tau in x and y at every sample (so is the SV's
    # when it starts from rest): its box comes from its two extreme trajectories and
    # the members near a point from binary searches
    for k in range(n_t):
        tk = t[k]
        if n_alive == 0 or tk > last_t:
            break
        sv_at_k = False  # px, py hold every candidate at sample k
        if general:  # not ordered: every remaining candidate, and their box
            bx0, bx1, by0, by1 = np.inf, -np.inf, np.inf, -np.inf
            for c in range(n_c):
                if alive[c]:
                    x, y, _ = _general_pose(cx, cy, c, ctau[c], vxf, tk + shift)
                    px[c], py[c] = x + x0, y + y0
                    bx0, bx1 = min(bx0, px[c]), max(bx1, px[c])
                    by0, by1 = min(by0, py[c]), max(by1, py[c])
        else:
            xa, ya = standard_xy(v0, vxf, w, ctau[0], tk + shift)
            xb, yb = standard_xy(v0, vxf, w, ctau[n_c - 1], tk + shift)
            bx0, bx1 = x0 + min(xa, xb) - _BOX_TOLERANCE, x0 + max(xa, xb) + _BOX_TOLERANCE
            by0, by1 = y0 + min(ya, yb) - _BOX_TOLERANCE, y0 + max(ya, yb) + _BOX_TOLERANCE
        for g in range(n_g):
            h0, h1 = groups[g], groups[g + 1]
            lx, ly = g_lim_x[g], g_lim_y[g]
            if g_closed[g]:
                xa, ya = _closed_xy(closed, h0, tk)
                xb, yb = _closed_xy(closed, h1 - 1, tk)
                gx0, gx1 = min(xa, xb) - _BOX_TOLERANCE, max(xa, xb) + _BOX_TOLERANCE
                gy0, gy1 = min(ya, yb) - _BOX_TOLERANCE, max(ya, yb) + _BOX_TOLERANCE
                if gx1 < bx0 - lx or gx0 > bx1 + lx or gy1 < by0 - ly or gy0 > by1 + ly:
                    continue
                for h in range(h0, h1):
                    gx[h], gy[h] = _closed_xy(closed, h, tk)
                ordered = True
            else:
                gx0, gx1, gy0, gy1 = np.inf, -np.inf, np.inf, -np.inf
                rising, falling = True, True
                for h in range(h0, h1):
                    gx[h], gy[h] = rows_x[row_of[h], k], rows_y[row_of[h], k]
                    gx0, gx1 = min(gx0, gx[h]), max(gx1, gx[h])
                    gy0, gy1 = min(gy0, gy[h]), max(gy1, gy[h])
                    if h > h0:
                        rising = rising and gy[h] >= gy[h - 1]
                        falling = falling and gy[h] <= gy[h - 1]
                if gx1 < bx0 - lx or gx0 > bx1 + lx or gy1 < by0 - ly or gy0 > by1 + ly:
                    continue
                ordered = rising or falling
            ca, cb = 0, n_c
            if not general:  # the candidates near the vehicle's box
                if not sv_at_k:
                    for c in range(n_c):
                        x, y = standard_xy(v0, vxf, w, ctau[c], tk + shift)
                        px[c], py[c] = x + x0, y + y0
                    sv_at_k = True
                xa, xb = _sorted_range(px, 0, n_c, gx0 - lx, gx1 + lx)
                ya, yb = _sorted_range(py, 0, n_c, gy0 - ly, gy1 + ly)
                ca, cb = max(xa, ya), min(xb, yb)
            for c in range(ca, cb):
                if not alive[c]:
                    continue
                sx, sy = px[c], py[c]
                if (sx < gx0 - lx or sx > gx1 + lx or sy < gy0 - ly or sy > gy1 + ly
                        or tk > max(sv_hor[c], g_hor[g])):
                    continue
                a, b = h0, h1
                if h1 - h0 > 8 and ordered:  # the hypotheses whose y is near the candidate's
                    a, b = _sorted_range(gy, h0, h1, sy - ly, sy + ly)
                for h in range(a, b):
                    dx, dy = gx[h] - sx, gy[h] - sy
                    if (abs(dx) > lim_x[h] or abs(dy) > lim_y[h] or dx * dx + dy * dy > reach2[h]
                            or tk > max(sv_hor[c], tv_hor[h])):
                        continue
                    if sv_k[c] != k:
                        sh = (_general_pose(cx, cy, c, ctau[c], vxf, tk + shift)[2] if general
                              else _standard_heading(v0, vxf, w, ctau[c], tk + shift))
                        sv_cs[c, 0], sv_cs[c, 1], sv_cs[c, 2] = math.cos(sh), math.sin(sh), sh
                        sv_k[c] = k
                    if tv_hk[h] != k:
                        r = row_of[h]
                        th = rows_h[r, k] if r >= 0 else _standard_heading(
                            closed[0, h], closed[1, h], closed[2, h], closed[3, h],
                            tk - closed[6, h])
                        tv_cs[h, 0], tv_cs[h, 1], tv_cs[h, 2] = math.cos(th), math.sin(th), th
                        tv_hk[h] = k
                    hlb, hwb = 0.5 * tv_l[h], 0.5 * tv_w[h]
                    if col:
                        hit = _col(sx, sy, sv_cs[c, 2], sv_l, sv_w, gx[h], gy[h], tv_cs[h, 2],
                                   tv_l[h], tv_w[h])
                    else:
                        ca_, sa_, cb_, sb_ = sv_cs[c, 0], sv_cs[c, 1], tv_cs[h, 0], tv_cs[h, 1]
                        hit = _sat(sx, sy, ca_, sa_, hla, hwa, gx[h], gy[h], cb_, sb_, hlb, hwb,
                                   margin)
                        if not hit and pad[h] > 0.0 and _sat(
                                sx, sy, ca_, sa_, hla, hwa, gx[h], gy[h], cb_, sb_, hlb, hwb,
                                margin + pad[h]):
                            hit = _refined(par, cx, cy, ctau[c], c, hla, hwa, rows_x, rows_y,
                                           rows_h, row_of, closed, h, hlb, hwb, k, t, pad[h],
                                           margin)
                    if hit:
                        first_k[c], first_h[c] = k, h
                        alive[c] = False
                        n_alive -= 1
                        break
    return first_k, first_h


@register_warm_up
def warm_up() -> None:
    """Compile (or load from numba's cache) the check's compiled functions now: one tiny
    check of each kind (closed-form and general-start candidates, stored and closed-form
    hypotheses, the exact test and CoL) and one sampling pad."""
    t = np.arange(3) * 0.05
    rows = np.array([[0.0, 1.0, 2.0]])
    nan = np.nan
    tv = TVHypotheses(rows, 0.0 * rows, 0.0 * rows, np.array([0, -1]),
                      np.array([[nan, 20.0], [nan, 20.0], [nan, 3.75], [nan, 2.0], [nan, 0.0],
                                [nan, 0.0], [nan, 0.0]]),
                      np.full(2, 4.32), np.full(2, 1.8), np.full(2, 0.1), np.zeros(2),
                      np.arange(3))
    for start in ({}, {"vy0": 0.1}):
        sv = SVCandidates(np.array([2.0]), 20.0, 20.0, 3.75, 0.0, 0.0, **start)
        for test in COLLISION_TESTS:
            check_candidates(t, sv, 4.32, 1.8, np.array([2.0]), tv, np.full(2, 2.0), test=test)
    sampling_pad(ClusterMotion(0.0, 0.0, 0.0, 0.0, 0.0), rows, rows, rows, 2.35, np.ones(1))
