"""Rectangle overlap tests and the collision check of a cluster (Section 3.2, eq. 9-11).

Vehicles are rectangles centred on the trajectory point and turned by the
heading phi: vertices = centre + R(phi) (+-l/2, +-w/2) (eq. 9, with the printed
rotation block corrected).

Two tests:
- `overlap_sat`: exact, by separating axes (two rectangles are disjoint iff their
  projections on one of the four edge normals are disjoint). Optional margin.
- `overlap_col`: the paper's CoL (Appendix 9.2): a vertex of the SV is inside a TV
  rectangle when the four triangles it spans with the TV's edges add up to the
  TV's area. It misses two rectangles that cross without a vertex inside. Run as
  the paper does: at the samples, against the listed durations only.

`check_candidates` runs one of them over SV candidates x time x TV hypotheses:
compiled loops (numba) that evaluate the trajectories where they are needed,
skip what cheap boxes and distances rule out, and stop a candidate at its first
overlap. The exact test is continuous (beyond the paper): each sample stands for
the cell of times within half a step of it and, for a C2 cluster, of every
duration between two neighbouring listed ones (the first listed one a lower
bound of the TV's tau_min). A pair is tested exactly at the sample; then once
more with both rectangles grown by half the most its relative pose can move
within the cell (from the polynomials' own derivative bounds, per pair); only if
that grown test overlaps is the cell split in time or duration, and tested again,
until a real overlap is found (at an instant and a duration inside the cell) or
the grown test clears every piece (`RESOLUTION`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit, register_warm_up
from cosim.params import VehicleParams
from cosim.planning.trajectory import (
    LANE_CHANGE,
    BoundaryConditions,
    cluster_derivatives,
    lane_change_state,
    polynomial_coefficients,
    standard_bounds,
    standard_tau_sensitivity,
    standard_velocity,
    standard_xy,
)

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

class CollisionTest(StrEnum):
    """How candidates and TVs are tested for overlap."""

    EXACT = "exact"  # separating axes, continuous in time (the module docstring)
    COL = "col"  # the paper's CoL at the samples (Appendix 9.2)


COLLISION_TESTS = tuple(t.value for t in CollisionTest)
# m, a grown test still overlapping when the cell's motion bound is below this counts
# as an overlap (the cell is not split further)
RESOLUTION = 1e-4
_BOX_TOLERANCE = 1e-6  # m, a closed-form cluster's box from its two extreme trajectories
_STACK = 96  # cells a refinement holds at once (depth-first: about two per level)
# cells one refinement may judge; past them the pair counts as overlapping (sound: a
# candidate is only ever rejected by it). Bodies that creep side by side within a few
# mm of the margin for seconds (a merge from a standstill beside a queue)
# otherwise split cells for minutes in one plan() call
_MAX_CELLS = 20000
_RUN = 4  # neighbouring durations of a C2 cluster given one grown test first


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


class Box(NamedTuple):
    """A vehicle's rectangle (eq. 9); arrays broadcast. A named tuple: the run's collision
    check builds two per step."""

    x: ArrayLike  # m, centre x
    y: ArrayLike  # m, centre y
    heading: ArrayLike  # rad
    length: ArrayLike  # m
    width: ArrayLike  # m


def overlap_sat(a: Box, b: Box, margin: ArrayLike = 0.0) -> NDArray[np.bool_]:
    """Exact overlap of rectangles A and B, each grown by `margin` (m) on every side.
    Touching counts as overlap."""
    ax, ay, ah, al, aw = a
    bx, by, bh, bl, bw = b
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


def overlap_col(a: Box, b: Box) -> NDArray[np.bool_]:
    """The paper's CoL (Appendix 9.2): True when a vertex of A (the SV) lies inside B
    (a TV), judged by triangle areas: inside iff the four triangles (vertex, edge of B)
    add up to B's area (s_a - s_i > 0 for every vertex means no collision)."""
    va = corners(*a)  # (..., 4, 2)
    vb = corners(*b)
    area_b = np.asarray(b.length, dtype=float) * np.asarray(b.width, dtype=float)
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
    def boundary(self) -> BoundaryConditions:
        """The start and end the candidates share."""
        return BoundaryConditions(self.vx0, self.vxf, self.width, self.ax0, self.vy0,
                                  self.ay0)

    @property
    def standard(self) -> bool:
        """From rest laterally and with no longitudinal acceleration: eq. 2 / eq. 4 in
        closed form (`trajectory.standard_xy`)."""
        return self.ax0 == 0.0 and self.vy0 == 0.0 and self.ay0 == 0.0

    def side(self, t: Array, length: float, width: float, horizon: Array) -> SVSide:
        """The candidates as the compiled check reads them, on the time grid t. A general
        start's motion bounds (`SVSide.bounds`) come from its derivatives on t, widened
        by the next derivative over half a step; from rest they are in closed form."""
        par = np.array([self.vx0, self.vxf, self.width, self.x0, self.y0, self.t_shift])
        tau = np.ascontiguousarray(self.taus, dtype=float).reshape(-1)
        if self.standard:
            cx, cy, bounds = np.zeros((0, 5)), np.zeros((0, 6)), np.zeros((0, 6))
        else:
            c_x, c_y = polynomial_coefficients(self.boundary, tau)
            cx, cy = np.stack(c_x, axis=1), np.stack(c_y, axis=1)
            bounds = _sampled_bounds(self, tau, np.asarray(t, dtype=float) + self.t_shift)
        return SVSide(par, cx, cy, tau, np.ascontiguousarray(horizon, dtype=float), bounds,
                      0.5 * float(length), 0.5 * float(width))


def _sampled_bounds(sv: SVCandidates, tau: Array, s: Array) -> Array:
    """(n_c, 6) least x', most x', most |y'| (m/s), most heading rate (rad/s), most
    |heading| (rad), most |acceleration| (m/s^2) of general-start candidates at manoeuvre
    times s, each widened by 1.5 times the next derivative's sampled extreme over half a
    step."""
    d = cluster_derivatives(sv.boundary, tau, np.maximum(s, 0.0), (1, 2, 3))
    (xd, yd), (xdd, ydd), (x3, y3) = d[1], d[2], d[3]
    h = 0.75 * (float(s[1] - s[0]) if s.size > 1 else 0.0)
    xd_lo = np.maximum(xd.min(axis=1) - h * np.abs(xdd).max(axis=1), 1e-3)
    ay = np.abs(ydd).max(axis=1) + h * np.abs(y3).max(axis=1)
    ax = np.abs(xdd).max(axis=1) + h * np.abs(x3).max(axis=1)
    yd_hi = np.abs(yd).max(axis=1) + h * ay
    rate = ay / xd_lo + yd_hi * ax / xd_lo**2
    heading = np.abs(np.arctan2(yd, xd)).max(axis=1) + h * rate
    return np.stack([xd_lo, xd.max(axis=1) + h * ax, yd_hi, rate, heading, np.hypot(ax, ay)],
                    axis=1)


class SVSide(NamedTuple):
    """The SV candidates in the compiled check."""

    par: Array  # (6,) vx0 m/s, vxf m/s, W m, x0 m, y0 m, t_shift s
    cx: Array  # (n_c, 5) x coefficients of a general start (none: from rest, closed form)
    cy: Array  # (n_c, 6) y coefficients
    tau: Array  # s, (n_c,) ordered
    horizon: Array  # s, (n_c,) tested up to here
    bounds: Array  # (n_c, 6) general start: `_sampled_bounds` (from rest: none, closed form)
    half_l: float  # m
    half_w: float  # m


class TVSide(NamedTuple):
    """The TV hypotheses in the compiled check (see `TVHypotheses`)."""

    rows_x: Array  # m, (n_s, n_t) on the check's grid
    rows_y: Array  # m
    rows_h: Array  # rad
    row_of: IntArray  # (n_h,) stored row (-1: closed form in `lc`)
    lc: Any  # (n_h,) LANE_CHANGE records (nan: a stored row)
    cell: NDArray[np.bool_]  # (n_h,) h and h + 1 bound one continuous range of durations
    half_l: Array  # m, (n_h,)
    half_w: Array  # m, (n_h,)
    horizon: Array  # s, (n_h,)
    groups: IntArray  # (n_g + 1,) hypotheses of vehicle g: groups[g] .. groups[g + 1]
    t0: float  # s, first time of the grid the rows are on
    dt: float  # s, its step


@dataclass(frozen=True)
class TVHypotheses:
    """TV hypotheses as the check reads them: stored rows (n_s, n_t) on the check's grid,
    or lane changes from rest in closed form (`trajectory.LANE_CHANGE` records), grouped
    by vehicle (contiguous; a closed-form group ordered by duration). `cell[h]`: h and
    h + 1 are neighbouring durations of one C2 cluster, every duration between them
    stable too (the check covers them all)."""

    rows_x: Array  # m, (n_s, n_t)
    rows_y: Array  # m
    rows_h: Array  # rad
    row_of: IntArray  # (n_h,) stored row of each hypothesis (-1: closed form)
    lc: NDArray[np.void]  # (n_h,) LANE_CHANGE (nan fields: a stored row)
    cell: NDArray[np.bool_]  # (n_h,)
    length: Array  # m, (n_h,)
    width: Array  # m, (n_h,)
    groups: IntArray  # (n_g + 1,)

    @property
    def n_h(self) -> int:
        return int(self.row_of.size)

    @classmethod
    def from_rows(cls, x: Array, y: Array, heading: Array, length: ArrayLike,
                  width: ArrayLike) -> TVHypotheses:
        """Hypotheses given as (n_h, n_t) arrays, each its own group."""
        n_h = x.shape[0]
        lc = np.full(n_h, np.nan, dtype=LANE_CHANGE)
        return cls(x, y, heading, np.arange(n_h), lc, np.zeros(n_h, dtype=bool),
                   np.broadcast_to(np.asarray(length, dtype=float), (n_h,)),
                   np.broadcast_to(np.asarray(width, dtype=float), (n_h,)), np.arange(n_h + 1))

    @classmethod
    def from_futures(cls, futures: Any) -> TVHypotheses:
        """The hypotheses of `prediction.LazyFutures`."""
        f = futures
        n_h = f.owner.size
        starts = np.flatnonzero(f.owner[1:] != f.owner[:-1]) + 1
        return cls(f.sx, f.sy, f.sh, f.row_of, f.lc, f.cell, f.length, f.width,
                   np.concatenate(([0], starts, [n_h])))

    def side(self, horizon: Array, t0: float, dt: float) -> TVSide:
        flt = (lambda a: np.ascontiguousarray(a, dtype=float))  # noqa: E731
        return TVSide(flt(self.rows_x), flt(self.rows_y), flt(self.rows_h),
                      self.row_of.astype(np.int64), np.ascontiguousarray(self.lc),
                      np.ascontiguousarray(self.cell, dtype=np.bool_), 0.5 * flt(self.length),
                      0.5 * flt(self.width), flt(horizon), self.groups.astype(np.int64),
                      float(t0), float(dt))


def check_candidates(
    t: Array, sv: SVCandidates, vehicle: VehicleParams, sv_horizon: Array,
    tv: TVHypotheses, tv_horizon: Array, *, margin: float = 0.0, test: str = "exact",
) -> ClusterHits:
    """First overlap of every SV candidate (n_c; the body of `vehicle`) with any TV
    hypothesis (n_h) on the uniform time grid t (eq. 10-11).

    A pair (candidate c, hypothesis h) is tested at the times t_k <= max(sv_horizon[c],
    tv_horizon[h]) (the exact test: the cell of the last one reaches that horizon, the
    times up to it all covered; a C2 cell's durations, h to h + 1, are looked at up to
    the horizon of h + 1, the later one). Time runs forwards and a candidate leaves at
    its first overlap (ties at one sample go to the lowest hypothesis). At each sample a
    vehicle's hypotheses are skipped when their box is far from the candidates' box; the
    candidates near the vehicle's box, and for each the hypotheses whose y is near its
    own, come from binary searches (a closed-form cluster, the SV's from rest and a C2
    TV's, is ordered by duration in x and y at every time, so its box is that of its two
    extreme trajectories); then axis-aligned boxes (from bounds on the headings) and
    centre distances. The exact test ("exact") then covers, continuously, the times
    within half a step of t_k and every duration between h and the next listed one of
    its cluster (see the module's docstring; an overlap reported at t_k lies in that
    cell, or, when the cell would need a closer look and the next sample overlaps
    outright, at that sample); "col" is the paper's CoL at the samples and the listed
    durations only. The loops run compiled (numba).
    """
    if test not in COLLISION_TESTS:
        raise ValueError(f"collision test {test!r}: one of {COLLISION_TESTS}")
    n_c = sv.n_c
    if tv.n_h == 0 or n_c == 0:
        none = np.full(n_c, -1, dtype=np.int64)
        return ClusterHits(np.zeros(n_c, dtype=bool), none, none.copy())
    t = np.ascontiguousarray(t, dtype=float)
    dt = float(t[1] - t[0]) if t.size > 1 else 0.0
    first_k, first_h = _first_overlaps(t, sv.side(t, vehicle.length, vehicle.width,
                                                   sv_horizon),
                                       tv.side(tv_horizon, float(t[0]), dt), float(margin),
                                       test == CollisionTest.COL)
    return ClusterHits(first_k >= 0, first_k, first_h)


# -- the compiled loops (numba; no fastmath: IEEE order as in numpy) ------------------------
# Helpers called in the hot loops take scalars, or one array at most: a compiled call
# that passes several arrays costs reference counting (about 100 ns with four, measured).


@njit
def _candidate_velocity(general: bool, cx: Array, cy: Array, c: int, tau: float, v0: float,
                        vxf: float, w: float, t: float) -> tuple[float, float]:
    """m/s, the velocity of SV candidate c (duration tau) at time t after its start:
    from its general-start coefficients (cx, cy) or, from rest laterally, eq. 2 / 4's
    closed form (v0 -> vxf over the lateral displacement w)."""
    if general:
        _, _, xd, yd = _general_state(cx, cy, c, tau, vxf, t)
        return xd, yd
    return standard_velocity(v0, vxf, w, tau, t)


@njit
def _candidate_pose(general: bool, cx: Array, cy: Array, c: int, tau: float, v0: float,
                    vxf: float, w: float, x0: float, y0: float, s: float
                    ) -> tuple[float, float, float, float, float, float]:
    """Global (x, y, cos and sin of the heading, x', y') of SV candidate c (duration tau)
    placed at (x0, y0), s after its start: general start or eq. 2 / 4 from rest."""
    if general:
        x, y, xd, yd = _general_state(cx, cy, c, tau, vxf, s)
        ca, sa = _direction(xd, yd)
        return x + x0, y + y0, ca, sa, xd, yd
    return _closed_pose(v0, vxf, w, tau, x0, y0, s)


@njit
def _direction(xd: float, yd: float) -> tuple[float, float]:
    """(cos, sin) of the heading atan2(yd, xd) of velocity (xd, yd), without
    trigonometry ((1, 0) at rest, as atan2(0, 0) = 0)."""
    n = math.sqrt(xd * xd + yd * yd)
    if n == 0.0:
        return 1.0, 0.0
    return xd / n, yd / n


@njit
def _cell_end(w_hi: float, t_next: float, horizon: float) -> float:
    """s, where the cell of a sample ends for a pair tested up to `horizon` (the sample
    at or before it): half a step on, or the horizon if that comes first; the pair's last
    sample (the next one past the horizon) reaches to the horizon."""
    return horizon if t_next > horizon else min(w_hi, horizon)


@njit
def _closed_pose(v0: float, vxf: float, w: float, tau: float, x0: float, y0: float,
                 s: float) -> tuple[float, float, float, float, float, float]:
    """Global (x, y, cos and sin of the heading, x', y') of eq. 2 / eq. 4 from rest
    placed at (x0, y0), s after its start."""
    x, y = standard_xy(v0, vxf, w, tau, s)
    xd, yd = standard_velocity(v0, vxf, w, tau, s)
    c, sn = _direction(xd, yd)
    return x + x0, y + y0, c, sn, xd, yd


@njit
def _closed_xy(lc: Any, h: int, t: float) -> tuple[float, float]:
    """Centre of closed-form hypothesis h at grid time t."""
    r = lc[h]
    x, y = standard_xy(r["v0"], r["vxf"], r["width"], r["tau"], t - r["start"])
    return x + r["x0"], y + r["y0"]


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
def _closed_range(lc: Any, a: int, b: int, t: float, lo: float, hi: float) -> tuple[int, int]:
    """`_sorted_range` over the y of closed-form hypotheses [a, b) at grid time t (one
    cluster: ordered by duration), each evaluated only where the search looks."""
    lo, hi = lo - _BOX_TOLERANCE, hi + _BOX_TOLERANCE
    rising = _closed_xy(lc, a, t)[1] <= _closed_xy(lc, b - 1, t)[1]
    i, j = a, b
    while i < j:
        mid = (i + j) // 2
        v = _closed_xy(lc, mid, t)[1]
        if (v < lo) if rising else (v > hi):
            i = mid + 1
        else:
            j = mid
    start, j = i, b
    while i < j:
        mid = (i + j) // 2
        v = _closed_xy(lc, mid, t)[1]
        if (v <= hi) if rising else (v >= lo):
            i = mid + 1
        else:
            j = mid
    return start, i


@njit
def _general_xy(cx: Array, cy: Array, c: int, tau: float, vxf: float,
                s: float) -> tuple[float, float]:
    """Relative (x, y) of a general-start candidate c at manoeuvre time s."""
    x, y, _, _ = _general_state(cx, cy, c, tau, vxf, s)
    return x, y


@njit
def _general_state(cx: Array, cy: Array, c: int, tau: float, vxf: float,
                   s: float) -> tuple[float, float, float, float]:
    """Relative (x, y, x', y') of a general-start candidate c at manoeuvre time s (the
    Horner sums of `trajectory.cluster_derivatives`; straight at vxf after tau)."""
    ts = min(max(s, 0.0), tau)
    x = cx[c, 4]
    for j in range(3, -1, -1):
        x = x * ts + cx[c, j]
    y = cy[c, 5]
    for j in range(4, -1, -1):
        y = y * ts + cy[c, j]
    if s > tau:
        return x + vxf * (s - ts), y, vxf, 0.0
    xd = 4.0 * cx[c, 4]
    for j in range(3, 0, -1):
        xd = xd * ts + j * cx[c, j]
    yd = 5.0 * cy[c, 5]
    for j in range(4, 0, -1):
        yd = yd * ts + j * cy[c, j]
    return x, y, xd, yd


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
def _turned(r: float, rate: float, span: float) -> float:
    """m, the most a point r from a body's centre moves as the body turns at up to `rate`
    (rad/s) for `span` s: the chord 2 r sin(dtheta / 2), at most r dtheta and 2 r. The
    heading-rate bound of a lane change from (near) rest grows without limit as its start
    speed falls (`trajectory.standard_bounds`); the chord keeps such a body's growth to
    its own size."""
    return r * min(rate * span, 2.0)


@njit
def _sat_moved(ax: float, ay: float, ca: float, sa: float, hla: float, hwa: float, bx: float,
               by: float, cb: float, sb: float, hlb: float, hwb: float, m: float, mx: float,
               my: float, turn: float) -> bool:
    """`_sat` with B also grown to cover moving by up to mx along x and my along y (m,
    world axes) and any point of it by up to `turn` more (m, turning of either body)."""
    acb, asb = abs(cb), abs(sb)
    return _sat(ax, ay, ca, sa, hla + m, hwa + m, bx, by, cb, sb,
                hlb + m + mx * acb + my * asb + turn, hwb + m + mx * asb + my * acb + turn, 0.0)


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
def _standard_accel(vx0: float, vxf: float, width: float, tau: float) -> float:
    """m/s^2, a bound on |(x'', y'')| of eq. 2 / eq. 4 from rest (`standard_bounds`)."""
    return math.hypot(1.5 * abs(vxf - vx0) / tau, 5.7736 * abs(width) / (tau * tau))


@njit
def _sv_bounds(sv: SVSide, c: int) -> tuple[float, float, float, float, float, float]:
    """(least x', most x', most |y'| m/s, most heading rate rad/s, most |heading| rad,
    most |acceleration| m/s^2) of candidate c over its whole manoeuvre."""
    if sv.cx.shape[0]:
        b = sv.bounds
        return b[c, 0], b[c, 1], b[c, 2], b[c, 3], b[c, 4], b[c, 5]
    p = sv.par
    v_lo, v_hi, yd, rate, head = standard_bounds(p[0], p[1], p[2], sv.tau[c])
    return v_lo, v_hi, yd, rate, head, _standard_accel(p[0], p[1], p[2], sv.tau[c])


@njit
def _tv_state(tv: TVSide, h: int, tau: float, t: float) -> tuple[float, float, float, float,
                                                                  float]:
    """Global (x, y, heading, x', y') of hypothesis h at time t: a closed form with
    duration tau, or its stored row, linear between samples."""
    r = tv.row_of[h]
    if r < 0:
        q = tv.lc[h]
        return lane_change_state(q["v0"], q["vxf"], q["width"], tau, q["x0"], q["y0"],
                                 q["start"], t)
    n_t = tv.rows_x.shape[1]
    u = (t - tv.t0) / tv.dt if tv.dt > 0.0 else 0.0
    j = min(max(int(math.floor(u)), 0), max(n_t - 2, 0))
    f = u - j if n_t > 1 else 0.0
    j1 = min(j + 1, n_t - 1)
    dx, dy = tv.rows_x[r, j1] - tv.rows_x[r, j], tv.rows_y[r, j1] - tv.rows_y[r, j]
    inv = 1.0 / tv.dt if tv.dt > 0.0 else 0.0
    return (tv.rows_x[r, j] + f * dx, tv.rows_y[r, j] + f * dy,
            tv.rows_h[r, j] + f * (tv.rows_h[r, j1] - tv.rows_h[r, j]), dx * inv, dy * inv)


@njit
def _row_bounds(tv: TVSide, h: int, k: int) -> tuple[float, float, float, float, float]:
    """A stored row's motion around sample k, as it is between samples k - 1 and k + 1
    (linear): (least x', most x', most |y'| m/s, most heading rate rad/s) and how far
    the linear pieces may be from the trajectory (m: half the second difference of the
    corners around k, four times the dt^2 a / 8 bound of linear interpolation)."""
    r = tv.row_of[h]
    n_t = tv.rows_x.shape[1]
    if n_t < 2:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    a, b = max(k - 1, 0), min(k + 1, n_t - 1)
    x, y, hd = tv.rows_x, tv.rows_y, tv.rows_h
    dt = tv.dt
    x_lo, x_hi, yd, rate = np.inf, -np.inf, 0.0, 0.0
    for j in range(a, b):
        vx = (x[r, j + 1] - x[r, j]) / dt
        x_lo, x_hi = min(x_lo, vx), max(x_hi, vx)
        yd = max(yd, abs(y[r, j + 1] - y[r, j]) / dt)
        rate = max(rate, abs(hd[r, j + 1] - hd[r, j]) / dt)
    kc = min(max(k, 1), n_t - 2) if n_t > 2 else 0
    second = 0.0
    if n_t > 2:
        rad = math.hypot(tv.half_l[h], tv.half_w[h])
        second = (abs(x[r, kc + 1] - 2 * x[r, kc] + x[r, kc - 1])
                  + abs(y[r, kc + 1] - 2 * y[r, kc] + y[r, kc - 1])
                  + rad * abs(hd[r, kc + 1] - 2 * hd[r, kc] + hd[r, kc - 1]))
    return x_lo, x_hi, yd, rate, 0.5 * second


@njit
def _overlaps_at(sv: SVSide, c: int, tv: TVSide, h: int, tau_a: float, tau_b: float, t: float,
                 margin: float) -> bool:
    """Candidate c and hypothesis h overlap at time t, at duration tau_a or tau_b."""
    p = sv.par
    ax, ay, ca, sa, _, _ = _candidate_pose(sv.cx.shape[0] > 0, sv.cx, sv.cy, c, sv.tau[c], p[0],
                                           p[1], p[2], p[3], p[4], t + p[5])
    hla, hwa, hlb, hwb = sv.half_l, sv.half_w, tv.half_l[h], tv.half_w[h]
    if tv.row_of[h] >= 0:
        bx, by, bh, _, _ = _tv_state(tv, h, tau_a, t)
        return _sat(ax, ay, ca, sa, hla, hwa, bx, by, math.cos(bh), math.sin(bh), hlb, hwb,
                    margin)
    q = tv.lc[h]
    v0, vxf, w, x0, y0, s = q["v0"], q["vxf"], q["width"], q["x0"], q["y0"], t - q["start"]
    bx, by, cb, sb, _, _ = _closed_pose(v0, vxf, w, tau_a, x0, y0, s)
    if _sat(ax, ay, ca, sa, hla, hwa, bx, by, cb, sb, hlb, hwb, margin):
        return True
    if tau_b > tau_a:
        bx, by, cb, sb, _, _ = _closed_pose(v0, vxf, w, tau_b, x0, y0, s)
        return _sat(ax, ay, ca, sa, hla, hwa, bx, by, cb, sb, hlb, hwb, margin)
    return False


@njit
def _refine(sv: SVSide, c: int, tv: TVSide, h: int, tau_a: float, tau_b: float, lo: float,
            hi: float, margin: float, acc: float, rate_a: float, rate_b: float, vtau: float,
            tau_rate: float, vjump: float, extra: float) -> bool:
    """Whether candidate c overlaps hypothesis h at some time in [lo, hi] and duration in
    [tau_a, tau_b] (nan: a stored row; equal: that duration only).

    Depth first over cells (a duration range x a time range), each judged at its
    centre time tm: the rectangles are tested exactly at both end durations, then
    grown by half of how far any corner of the TV can be from the reference rectangle,
    relative to the SV: over the durations, half the distance of the two ends' centres
    (every centre lies between them) plus `tau_rate` (m/s, the corners' turning per
    second of duration) times the range; over the times within d of tm, d times the
    relative speed at tm (widened by `vtau` (m/s per s of duration) times the range,
    and by `vjump`, m/s, a row's change of slope at a sample) and the corners' turning
    (`rate_a`, `rate_b`: rad/s, each body's heading rate; `_turned`), plus acc d^2 / 2
    (acc: m/s^2, both accelerations); and
    `extra`, m, how far a stored row may be from its linear pieces. A cell whose grown
    test overlaps is split in the dimension that moves more, until a real overlap
    (True) or every piece clears (False); a piece whose bound is below RESOLUTION and
    still overlaps counts as an overlap, and so does a pair not settled within
    `_MAX_CELLS` cells."""
    hla, hwa, hlb, hwb = sv.half_l, sv.half_w, tv.half_l[h], tv.half_w[h]
    r_a, r_b = math.hypot(hla, hwa), math.hypot(hlb, hwb)
    # (closed forms evaluated from scalars: no arrays passed in the loop)
    p = sv.par
    general, tau_c = sv.cx.shape[0] > 0, sv.tau[c]
    closed = tv.row_of[h] < 0
    q = tv.lc[h]
    v0, vxf, w, x0, y0, start = q["v0"], q["vxf"], q["width"], q["x0"], q["y0"], q["start"]
    stack = np.empty((_STACK, 4))
    stack[0, 0], stack[0, 1], stack[0, 2], stack[0, 3] = tau_a, tau_b, lo, hi
    n, cells = 1, 0
    while n > 0:
        n -= 1
        cells += 1
        if cells > _MAX_CELLS:
            return True
        ta, tb, t0, t1 = stack[n, 0], stack[n, 1], stack[n, 2], stack[n, 3]
        tm = 0.5 * (t0 + t1)
        ax, ay, ca, sa, avx, avy = _candidate_pose(general, sv.cx, sv.cy, c, tau_c, p[0], p[1],
                                                   p[2], p[3], p[4], tm + p[5])
        if closed:
            bx, by, cb, sb, bvx, bvy = _closed_pose(v0, vxf, w, ta, x0, y0, tm - start)
        else:
            bx, by, bh, bvx, bvy = _tv_state(tv, h, ta, tm)
            cb, sb = math.cos(bh), math.sin(bh)
        if _sat(ax, ay, ca, sa, hla, hwa, bx, by, cb, sb, hlb, hwb, margin):
            return True
        span = 0.0
        tx, ty, t_turn = 0.0, 0.0, 0.0  # the durations' part
        if tb > ta:  # (a closed form)
            span = tb - ta
            ex, ey, ce, se, _, _ = _closed_pose(v0, vxf, w, tb, x0, y0, tm - start)
            if _sat(ax, ay, ca, sa, hla, hwa, ex, ey, ce, se, hlb, hwb, margin):
                return True
            tx, ty, t_turn = 0.5 * abs(ex - bx), 0.5 * abs(ey - by), min(tau_rate * span,
                                                                          2.0 * r_b)
            bx, by = 0.5 * (bx + ex), 0.5 * (by + ey)  # between them lies every centre
        half = 0.5 * (t1 - t0)
        widen = vtau * span + vjump
        curve = 0.5 * acc * half * half
        mx = half * (abs(bvx - avx) + widen) + curve  # the times' part
        my = half * (abs(bvy - avy) + widen) + curve
        m_turn = _turned(r_a, rate_a, half) + _turned(r_b, rate_b, half)
        if not _sat_moved(ax, ay, ca, sa, hla, hwa, bx, by, cb, sb, hlb, hwb, margin,
                          tx + mx, ty + my, t_turn + m_turn + extra):
            continue
        d_tau = max(tx, ty) + t_turn
        d_time = max(mx, my) + m_turn
        if d_tau + d_time < RESOLUTION or n + 2 > _STACK:
            return True
        if d_tau > d_time:
            mid = 0.5 * (ta + tb)
            stack[n, 0], stack[n, 1], stack[n, 2], stack[n, 3] = mid, tb, t0, t1
            stack[n + 1, 0], stack[n + 1, 1], stack[n + 1, 2], stack[n + 1, 3] = ta, mid, t0, t1
        else:
            stack[n, 0], stack[n, 1], stack[n, 2], stack[n, 3] = ta, tb, tm, t1
            stack[n + 1, 0], stack[n + 1, 1], stack[n + 1, 2], stack[n + 1, 3] = ta, tb, t0, tm
        n += 2
    return False


@njit
def _tv_static(tv: TVSide, h: int) -> tuple[float, float, float, float, float, float, float,
                                             float]:
    """Over the whole horizon, for hypothesis h: (least x', most x', most |y'| m/s, most
    heading rate rad/s, most |heading| rad; for a closed form, how fast its centre and
    its corners' turning move with the duration (m/s, for every duration >= its own);
    for a stored row, the most its linear pieces may be off (m, `_row_bounds`))."""
    r = tv.row_of[h]
    r_tv = math.hypot(tv.half_l[h], tv.half_w[h])
    if r < 0:
        q = tv.lc[h]
        v_lo, v_hi, yd, rate, head = standard_bounds(q["v0"], q["vxf"], q["width"], q["tau"])
        sx, sy, srot = standard_tau_sensitivity(q["v0"], q["vxf"], q["width"], q["tau"])
        return v_lo, v_hi, yd, rate, head, math.hypot(sx, sy), r_tv * srot, 0.0
    x, y, hd = tv.rows_x, tv.rows_y, tv.rows_h
    n_t = x.shape[1]
    x_lo, x_hi, yd, rate, head, second = np.inf, -np.inf, 0.0, 0.0, 0.0, 0.0
    for k in range(n_t - 1):
        vx = (x[r, k + 1] - x[r, k]) / tv.dt
        x_lo, x_hi = min(x_lo, vx), max(x_hi, vx)
        yd = max(yd, abs(y[r, k + 1] - y[r, k]) / tv.dt)
        rate = max(rate, abs(hd[r, k + 1] - hd[r, k]) / tv.dt)
    for k in range(n_t):
        head = max(head, abs(hd[r, k]))
    for k in range(1, n_t - 1):
        second = max(second, abs(x[r, k + 1] - 2 * x[r, k] + x[r, k - 1])
                     + abs(y[r, k + 1] - 2 * y[r, k] + y[r, k - 1])
                     + r_tv * abs(hd[r, k + 1] - 2 * hd[r, k] + hd[r, k - 1]))
    if n_t < 2:
        x_lo, x_hi = 0.0, 0.0
    return x_lo, x_hi, yd, rate, head, 0.0, 0.0, 0.5 * second


@njit
def _phase_bounds(sv: SVSide, tv: TVSide, margin: float, col: bool) -> tuple[
        Array, Array, Array, Array, Array, Array, Array, Array, Array, NDArray[np.bool_],
        float, float, float]:
    """Phase 1 of `_first_overlaps`: per candidate its motion bounds (x' least and
    most, |y'|, heading rate, |acceleration|); per hypothesis its motion bounds, the
    most a cell can grow both rectangles by, the reach (circle) and box half extents of
    both bodies together; per vehicle the widest limits, the latest horizon and whether
    its hypotheses are in closed form; the last time any pair is tested; the SV's
    circumradius, and grown by the margin."""
    n_c, n_h = sv.tau.size, tv.row_of.size
    n_g = tv.groups.size - 1
    groups, row_of, lc, cell = tv.groups, tv.row_of, tv.lc, tv.cell
    hla, hwa = sv.half_l, sv.half_w
    half = 0.5 * tv.dt

    # the SV cluster's bounds, each candidate's and over all
    sv_b = np.empty((n_c, 5))  # x' least, most, |y'|, heading rate, |acceleration|
    s_lo, s_hi, s_yd, s_rate, s_head = np.inf, -np.inf, 0.0, 0.0, 0.0
    for c in range(n_c):
        a0, a1, a2, a3, a4, a5 = _sv_bounds(sv, c)
        sv_b[c, 0], sv_b[c, 1], sv_b[c, 2], sv_b[c, 3], sv_b[c, 4] = a0, a1, a2, a3, a5
        s_lo, s_hi = min(s_lo, a0), max(s_hi, a1)
        s_yd, s_rate, s_head = max(s_yd, a2), max(s_rate, a3), max(s_head, a4)
    sin_sv = math.sin(min(s_head, 0.5 * math.pi))
    r_sv = math.hypot(hla, hwa)
    r_sv_m = math.hypot(hla + margin, hwa + margin)  # grown by the margin
    sv_hx, sv_hy = hla + hwa * sin_sv, hla * sin_sv + hwa

    # per hypothesis: motion bounds, the most a cell can grow both rectangles by, the
    # reach (circle) and box half extents of both bodies together
    tv_b = np.empty((n_h, 7))
    rad = np.empty((n_h, 2))  # m, circumradius, and grown by the margin
    reach2 = np.empty(n_h)
    lim_x = np.empty(n_h)
    lim_y = np.empty(n_h)
    for h in range(n_h):
        v_lo, v_hi, yd, rate, head, centre_tau, turn_tau, extra = _tv_static(tv, h)
        r_tv = math.hypot(tv.half_l[h], tv.half_w[h])
        rad[h, 0], rad[h, 1] = r_tv, math.hypot(tv.half_l[h] + margin, tv.half_w[h] + margin)
        tv_b[h, 0], tv_b[h, 1], tv_b[h, 2], tv_b[h, 3], tv_b[h, 4] = v_lo, v_hi, yd, rate, turn_tau
        if row_of[h] < 0:  # |acceleration| and how fast the velocity moves with the duration
            q = lc[h]
            tv_b[h, 5] = _standard_accel(q["v0"], q["vxf"], q["width"], q["tau"])
            tv_b[h, 6] = math.hypot(0.8889 * abs(q["vxf"] - q["v0"]) / q["tau"],
                                    4.0673 * abs(q["width"]) / (q["tau"] * q["tau"]))
        else:
            tv_b[h, 5], tv_b[h, 6] = 0.0, 0.0
        # a cell's durations, seen from its h end
        d_tau = 0.0
        if cell[h]:
            span = lc[h + 1]["tau"] - lc[h]["tau"]
            d_tau = centre_tau * span + min(turn_tau * span, 2.0 * r_tv)
        speed = math.hypot(max(s_hi - v_lo, v_hi - s_lo, 0.0), s_yd + yd)
        turning = _turned(r_sv, s_rate, half) + _turned(r_tv, rate, half)
        grow = 0.0 if col else margin + 0.5 * (half * speed + turning + d_tau + extra)
        g = grow * 2.0 * math.sqrt(2.0)
        sin_tv = math.sin(min(head, 0.5 * math.pi))
        rr = r_sv + r_tv + g
        reach2[h] = rr * rr
        lim_x[h] = sv_hx + tv.half_l[h] + tv.half_w[h] * sin_tv + g
        lim_y[h] = sv_hy + tv.half_l[h] * sin_tv + tv.half_w[h] + g
    # per vehicle: the widest limits, the latest horizon, whether in closed form
    g_lim_x = np.zeros(n_g)
    g_lim_y = np.zeros(n_g)
    g_hor = np.full(n_g, -np.inf)
    g_closed = np.ones(n_g, dtype=np.bool_)
    for g in range(n_g):
        for h in range(groups[g], groups[g + 1]):
            g_lim_x[g] = max(g_lim_x[g], lim_x[h])
            g_lim_y[g] = max(g_lim_y[g], lim_y[h])
            g_hor[g] = max(g_hor[g], tv.horizon[h])
            g_closed[g] = g_closed[g] and row_of[h] < 0
    last_t = -np.inf  # no pair is tested after this
    for c in range(n_c):
        last_t = max(last_t, sv.horizon[c])
    for g in range(n_g):
        last_t = max(last_t, g_hor[g])
    return (sv_b, tv_b, rad, reach2, lim_x, lim_y, g_lim_x, g_lim_y, g_hor, g_closed, last_t,
            r_sv, r_sv_m)


@njit
def _first_overlaps(t: Array, sv: SVSide, tv: TVSide, margin: float,
                    col: bool) -> tuple[IntArray, IntArray]:
    """(first sample, first hypothesis) per candidate; see `check_candidates`.

    Phase map (one compiled function for the hot part: numba does not inline helpers
    that write into arrays well, and the per-sample caches below are such arrays):

    1. bounds (`_phase_bounds`, once per check): motion bounds of every SV candidate
       and TV hypothesis, the reach (circles) and box half extents of both bodies
       together per hypothesis, their widest per vehicle, the last time any pair is
       tested;
    2. per sample k, broad phase: the box of the live candidates (closed form: of the
       first and last, ordered by duration) against each vehicle's box of hypotheses,
       grown by its limits; then the candidates near the vehicle's box (a sorted range),
       and the hypotheses whose y is near the candidate's (a sorted range); a run of
       _RUN neighbouring durations of a closed-form cluster cleared by one grown test;
    3. per pair, narrow phase: the limits and reach of the pair, the exact test at the
       sample (separating axes, or CoL), then the cell (times within half a step,
       durations up to the next) by one grown test (`_sat_moved`), and only when that
       fails the next sample (`_overlaps_at`) or the refined search (`_refine`). The
       first hit ends the candidate.
    """
    n_c, n_t, n_h = sv.tau.size, t.size, tv.row_of.size
    n_g = tv.groups.size - 1
    groups, row_of, lc, cell = tv.groups, tv.row_of, tv.lc, tv.cell
    general = sv.cx.shape[0] > 0
    p = sv.par
    v0, vxf, w, x0, y0, shift = p[0], p[1], p[2], p[3], p[4], p[5]
    hla, hwa = sv.half_l, sv.half_w
    dt = tv.dt
    half = 0.5 * dt
    (sv_b, tv_b, rad, reach2, lim_x, lim_y, g_lim_x, g_lim_y, g_hor, g_closed, last_t,
     r_sv, r_sv_m) = _phase_bounds(sv, tv, margin, col)

    first_k = np.full(n_c, -1, dtype=np.int64)
    first_h = np.full(n_c, -1, dtype=np.int64)
    alive = np.ones(n_c, dtype=np.bool_)
    n_alive = n_c
    live = np.arange(n_c)  # the candidates alive when the sample began, in order
    n_live = n_c
    px = np.empty(n_c)  # the centre of live[i] at the sample (evaluated when needed)
    py = np.empty(n_c)
    sv_k = np.full(n_c, -1, dtype=np.int64)  # the sample whose heading is in sv_cs
    sv_cs = np.empty((n_c, 3))  # cos, sin, heading
    gx = np.empty(n_h)
    gy = np.empty(n_h)
    tv_xk = np.full(n_h, -1, dtype=np.int64)  # the sample whose centre is in gx, gy
    tv_hk = np.full(n_h, -1, dtype=np.int64)  # the sample whose heading is in tv_cs
    tv_cs = np.empty((n_h, 3))
    for k in range(n_t):
        tk = t[k]
        if n_alive == 0 or tk > last_t:
            break
        if n_live > n_alive:  # drop the candidates that left (only the live are evaluated)
            j = 0
            for i in range(n_live):
                if alive[live[i]]:
                    live[j] = live[i]
                    j += 1
            n_live = j
        # the cell of times of sample k (within the grid)
        w_lo, w_hi = max(tk - half, t[0]), min(tk + half, t[n_t - 1])
        t_next = t[k + 1] if k + 1 < n_t else tk  # (a pair's last sample: up to its horizon)
        sv_at_k = False  # px, py hold every live candidate at sample k
        if general:  # not ordered: every live candidate, and their box
            bx0, bx1, by0, by1 = np.inf, -np.inf, np.inf, -np.inf
            for i in range(n_live):
                c = live[i]
                x, y = _general_xy(sv.cx, sv.cy, c, sv.tau[c], vxf, tk + shift)
                px[i], py[i] = x + x0, y + y0
                bx0, bx1 = min(bx0, px[i]), max(bx1, px[i])
                by0, by1 = min(by0, py[i]), max(by1, py[i])
        else:  # ordered: the box of the first and last live ones
            xa, ya = standard_xy(v0, vxf, w, sv.tau[live[0]], tk + shift)
            xb, yb = standard_xy(v0, vxf, w, sv.tau[live[n_live - 1]], tk + shift)
            bx0, bx1 = x0 + min(xa, xb) - _BOX_TOLERANCE, x0 + max(xa, xb) + _BOX_TOLERANCE
            by0, by1 = y0 + min(ya, yb) - _BOX_TOLERANCE, y0 + max(ya, yb) + _BOX_TOLERANCE
        for g in range(n_g):
            h0, h1 = groups[g], groups[g + 1]
            lx, ly = g_lim_x[g], g_lim_y[g]
            if g_closed[g]:  # ordered: the box of the extremes; the rest when needed
                xa, ya = _closed_xy(lc, h0, tk)
                xb, yb = _closed_xy(lc, h1 - 1, tk)
                gx0, gx1 = min(xa, xb) - _BOX_TOLERANCE, max(xa, xb) + _BOX_TOLERANCE
                gy0, gy1 = min(ya, yb) - _BOX_TOLERANCE, max(ya, yb) + _BOX_TOLERANCE
                if gx1 < bx0 - lx or gx0 > bx1 + lx or gy1 < by0 - ly or gy0 > by1 + ly:
                    continue
                gx[h0], gy[h0], gx[h1 - 1], gy[h1 - 1] = xa, ya, xb, yb
                tv_xk[h0], tv_xk[h1 - 1] = k, k
                ordered = True
            else:
                gx0, gx1, gy0, gy1 = np.inf, -np.inf, np.inf, -np.inf
                rising, falling = True, True
                for h in range(h0, h1):
                    gx[h], gy[h] = tv.rows_x[row_of[h], k], tv.rows_y[row_of[h], k]
                    tv_xk[h] = k
                    gx0, gx1 = min(gx0, gx[h]), max(gx1, gx[h])
                    gy0, gy1 = min(gy0, gy[h]), max(gy1, gy[h])
                    if h > h0:
                        rising = rising and gy[h] >= gy[h - 1]
                        falling = falling and gy[h] <= gy[h - 1]
                if gx1 < bx0 - lx or gx0 > bx1 + lx or gy1 < by0 - ly or gy0 > by1 + ly:
                    continue
                ordered = rising or falling
            ca, cb = 0, n_live
            if not general:  # the candidates near the vehicle's box
                if not sv_at_k:
                    for i in range(n_live):
                        x, y = standard_xy(v0, vxf, w, sv.tau[live[i]], tk + shift)
                        px[i], py[i] = x + x0, y + y0
                    sv_at_k = True
                xa_, xb_ = _sorted_range(px, 0, n_live, gx0 - lx, gx1 + lx)
                ya_, yb_ = _sorted_range(py, 0, n_live, gy0 - ly, gy1 + ly)
                ca, cb = max(xa_, ya_), min(xb_, yb_)
            for i in range(ca, cb):
                c = live[i]
                if not alive[c]:
                    continue
                sx, sy = px[i], py[i]
                if (sx < gx0 - lx or sx > gx1 + lx or sy < gy0 - ly or sy > gy1 + ly
                        or tk > max(sv.horizon[c], g_hor[g])):
                    continue
                a, b = h0, h1
                if h1 - h0 > 8 and ordered:  # the hypotheses whose y is near the candidate's
                    a, b = (_closed_range(lc, h0, h1, tk, sy - ly, sy + ly) if g_closed[g]
                            else _sorted_range(gy, h0, h1, sy - ly, sy + ly))
                    if not col and a > h0 and cell[a - 1]:
                        a -= 1  # the durations between a - 1 and a may come nearer
                skip = a
                for h in range(a, b):
                    if h < skip:
                        continue
                    if not col and g_closed[g] and (h - a) % _RUN == 0 and min(h + _RUN, b) - h > 2:
                        ra, stop = h, min(h + _RUN, b)
                        # one grown test for a run of _RUN durations first (the rectangle of
                        # ra grown to hold every duration from ra to e at every time of the
                        # cell): when clear, nothing in the run's cells overlaps, so its
                        # pairs are skipped
                        e = stop if (stop < h1 and cell[stop - 1]) else stop - 1
                        for hh in (ra, e):
                            if tv_xk[hh] != k:
                                gx[hh], gy[hh] = _closed_xy(lc, hh, tk)
                                tv_xk[hh] = k
                        if tv_hk[ra] != k:
                            q = lc[ra]
                            xd, yd = standard_velocity(q["v0"], q["vxf"], q["width"], q["tau"],
                                                       tk - q["start"])
                            tv_cs[ra, 0], tv_cs[ra, 1] = _direction(xd, yd)
                            tv_cs[ra, 2] = 0.0
                            tv_hk[ra] = k
                        if sv_k[c] != k:
                            xd, yd = _candidate_velocity(general, sv.cx, sv.cy, c, sv.tau[c],
                                                         v0, vxf, w, tk + shift)
                            sv_cs[c, 0], sv_cs[c, 1] = _direction(xd, yd)
                            sv_cs[c, 2] = 0.0
                            sv_k[c] = k
                        # the cluster's bounds over the run (each holds for its own duration)
                        # and the latest end of its pairs' cells
                        v_lo, v_hi, yd, rate, tau_rate = np.inf, -np.inf, 0.0, 0.0, 0.0
                        p_hi = w_hi
                        for hh in range(ra, e + 1):
                            v_lo, v_hi = min(v_lo, tv_b[hh, 0]), max(v_hi, tv_b[hh, 1])
                            yd, rate = max(yd, tv_b[hh, 2]), max(rate, tv_b[hh, 3])
                            tau_rate = max(tau_rate, tv_b[hh, 4])
                            p_hi = max(p_hi, _cell_end(w_hi, t_next,
                                                       max(sv.horizon[c], tv.horizon[hh])))
                        far = max(tk - w_lo, p_hi - tk)
                        # centres: between those of ra and e (ordered by duration in x and y)
                        mx = (far * max(sv_b[c, 1] - v_lo, v_hi - sv_b[c, 0], 0.0)
                              + 0.5 * abs(gx[e] - gx[ra]) + _BOX_TOLERANCE)
                        my = far * (sv_b[c, 2] + yd) + 0.5 * abs(gy[e] - gy[ra]) + _BOX_TOLERANCE
                        turn = (_turned(r_sv, sv_b[c, 3], far) + _turned(rad[ra, 0], rate, far)
                                + min(tau_rate * (lc[e]["tau"] - lc[ra]["tau"]),
                                      2.0 * rad[ra, 0]))
                        bx, by = 0.5 * (gx[ra] + gx[e]), 0.5 * (gy[ra] + gy[e])
                        reach = (r_sv_m + rad[ra, 1] + mx + my + math.sqrt(2.0) * turn
                                 + _BOX_TOLERANCE)
                        ex, ey = bx - sx, by - sy
                        clear = ex * ex + ey * ey > reach * reach or not _sat_moved(
                                sx, sy, sv_cs[c, 0], sv_cs[c, 1], hla, hwa, bx, by, tv_cs[ra, 0],
                                tv_cs[ra, 1], tv.half_l[ra], tv.half_w[ra], margin, mx, my, turn)
                        if clear:
                            skip = stop
                            continue
                    nxt = h + 1 if (cell[h] and not col) else -1
                    # the pair's horizon: a cell's durations reach that of h + 1 (later)
                    hor = max(sv.horizon[c], tv.horizon[nxt] if nxt >= 0 else tv.horizon[h])
                    if tv_xk[h] != k:
                        gx[h], gy[h] = _closed_xy(lc, h, tk)
                        tv_xk[h] = k
                    dx, dy = gx[h] - sx, gy[h] - sy
                    if (abs(dx) > lim_x[h] or abs(dy) > lim_y[h] or dx * dx + dy * dy > reach2[h]
                            or tk > hor):
                        continue
                    if sv_k[c] != k:  # cos, sin from the velocity (no trigonometry)
                        xd, yd = _candidate_velocity(general, sv.cx, sv.cy, c, sv.tau[c], v0,
                                                     vxf, w, tk + shift)
                        sv_cs[c, 0], sv_cs[c, 1] = _direction(xd, yd)
                        sv_cs[c, 2] = math.atan2(yd, xd) if col else 0.0
                        sv_k[c] = k
                    if tv_hk[h] != k:
                        r = row_of[h]
                        if r >= 0:
                            th = tv.rows_h[r, k]
                            tv_cs[h, 0], tv_cs[h, 1], tv_cs[h, 2] = math.cos(th), math.sin(th), th
                        else:
                            q = lc[h]
                            xd, yd = standard_velocity(q["v0"], q["vxf"], q["width"], q["tau"],
                                                       tk - q["start"])
                            tv_cs[h, 0], tv_cs[h, 1] = _direction(xd, yd)
                            tv_cs[h, 2] = math.atan2(yd, xd) if col else 0.0
                        tv_hk[h] = k
                    hlb, hwb = tv.half_l[h], tv.half_w[h]
                    if col:
                        hit = _col(sx, sy, sv_cs[c, 2], 2 * hla, 2 * hwa, gx[h], gy[h],
                                   tv_cs[h, 2], 2 * hlb, 2 * hwb)
                    else:
                        ca_, sa_, cb_, sb_ = sv_cs[c, 0], sv_cs[c, 1], tv_cs[h, 0], tv_cs[h, 1]
                        hit = _sat(sx, sy, ca_, sa_, hla, hwa, gx[h], gy[h], cb_, sb_, hlb, hwb,
                                   margin)
                        if not hit:  # the cell: times within half a step, durations to h + 1
                            r_tv = rad[h, 0]
                            if row_of[h] >= 0:
                                v_lo, v_hi, yd, rate, extra = _row_bounds(tv, h, k)
                            else:
                                v_lo, v_hi = tv_b[h, 0], tv_b[h, 1]
                                yd, rate = tv_b[h, 2], tv_b[h, 3]
                                extra = 0.0
                            # relative motion over the cell, along x and y, and turning
                            p_hi = _cell_end(w_hi, t_next, hor)
                            far = max(tk - w_lo, p_hi - tk)  # (at the ends: not centred)
                            mx = far * max(sv_b[c, 1] - v_lo, v_hi - sv_b[c, 0], 0.0)
                            my = far * (sv_b[c, 2] + yd)
                            turn = (_turned(r_sv, sv_b[c, 3], far) + _turned(r_tv, rate, far)
                                    + extra)
                            bx, by = gx[h], gy[h]
                            tau_a, tau_b, tau_rate, vjump = np.nan, np.nan, 0.0, 0.0
                            if row_of[h] >= 0 and extra > 0.0:
                                vjump = 2.0 * extra / dt  # the second difference per step
                            if row_of[h] < 0:
                                tau_a = tau_b = lc[h]["tau"]
                            if nxt >= 0:  # every centre between those of h and h + 1
                                if tv_xk[nxt] != k:
                                    gx[nxt], gy[nxt] = _closed_xy(lc, nxt, tk)
                                    tv_xk[nxt] = k
                                tau_b = lc[nxt]["tau"]
                                tau_rate = tv_b[h, 4]
                                mx += 0.5 * abs(gx[nxt] - bx)
                                my += 0.5 * abs(gy[nxt] - by)
                                turn += min(tau_rate * (tau_b - tau_a), 2.0 * r_tv)
                                bx, by = 0.5 * (bx + gx[nxt]), 0.5 * (by + gy[nxt])
                            # the circumcircles of `_sat_moved`'s rectangles (each corner
                            # of B moves by at most mx + my, and sqrt(2) turn)
                            reach = (r_sv_m + rad[h, 1] + mx + my + math.sqrt(2.0) * turn
                                     + _BOX_TOLERANCE)
                            ex, ey = bx - sx, by - sy
                            if ex * ex + ey * ey <= reach * reach and _sat_moved(
                                    sx, sy, ca_, sa_, hla, hwa, bx, by, cb_, sb_, hlb, hwb,
                                    margin, mx, my, turn):
                                # a real overlap at the next sample ends the candidate as
                                # surely, and is cheaper to find than one inside this cell
                                if (k + 1 < n_t
                                        and t[k + 1] <= hor
                                        and _overlaps_at(sv, c, tv, h, tau_a, tau_b, t[k + 1],
                                                         margin)):
                                    first_k[c], first_h[c] = k + 1, h
                                    alive[c] = False
                                    n_alive -= 1
                                    break
                                hit = _refine(sv, c, tv, h, tau_a, tau_b, w_lo, p_hi, margin,
                                              sv_b[c, 4] + tv_b[h, 5], sv_b[c, 3], rate,
                                              tv_b[h, 6], tau_rate, vjump, extra)
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
    hypotheses, the exact test and CoL)."""
    t = np.arange(3) * 0.05
    rows = np.array([[0.0, 1.0, 2.0]])
    lc = np.full(3, np.nan, dtype=LANE_CHANGE)
    for i, tau in ((1, 2.0), (2, 2.5)):
        lc[i] = (20.0, 20.0, 3.75, tau, 0.0, 0.0, 0.0)
    tv = TVHypotheses(rows, 0.0 * rows, 0.0 * rows, np.array([0, -1, -1]), lc,
                      np.array([False, True, False]), np.full(3, 4.32), np.full(3, 1.8),
                      np.array([0, 1, 3]))
    for start in ({}, {"vy0": 0.1}):
        sv = SVCandidates(np.array([2.0]), 20.0, 20.0, 3.75, 0.0, 0.0, **start)
        for test in COLLISION_TESTS:
            check_candidates(t, sv, VehicleParams(), np.array([2.0]), tv, np.full(3, 2.0),
                             test=test)
