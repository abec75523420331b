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

from collections.abc import Callable
from dataclasses import dataclass

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


def check_cluster(
    t: Array, sv_x: Array, sv_y: Array, sv_heading: Array | HeadingFn, sv_length: float,
    sv_width: float, sv_horizon: Array, tv_x: Array, tv_y: Array, tv_h: Array,
    tv_length: Array, tv_width: Array, tv_horizon: Array, *, margin: float = 0.0,
    test: str = "exact", pad: Array | None = None, chunk: int = 40,
    sv_max_heading: float = 0.5 * np.pi, split_above: int = 50_000,
    sv_pose: PoseFn | None = None,
) -> ClusterHits:
    """First overlap of every SV candidate (n_c, n_t) with any TV hypothesis (n_h, n_t).

    A pair (candidate c, hypothesis h) is checked at the times t_k <=
    max(sv_horizon[c], tv_horizon[h]) (eq. 10's horizon, extended by the caller).
    Time is taken in chunks (growing up to `chunk` samples; halved while more than
    `split_above` candidate x pair combinations are near), in order, and a
    candidate leaves the check at its
    first overlap (its earliest one: nothing earlier can follow). Stage 1 keeps
    the (h, k) whose TV is near the bounding box of the SV cluster at t_k; per
    chunk, stage 2 keeps the (c, h, k) whose centres are within the sum
    of the circumradii and whose axis-aligned boxes overlap (the SV's box from
    `sv_max_heading`, a bound on |heading| over the cluster); stage 3 runs the
    exact (or CoL) test on those only.
    `sv_heading` is an (n_c, n_t) array or a function of (c, k) index arrays (so
    headings are computed only where needed); `pad` (n_h,) grows the rectangles of
    the exact test (see `sampling_pad`). With `sv_pose` (the SV's exact pose at any
    time), an overlap that exists only thanks to the pad is looked at again at
    REFINE_SUBSTEPS instants around its sample with a pad that many times smaller:
    the verdict stays conservative but nearly exact.
    """
    n_c, n_t = sv_x.shape
    n_h = tv_x.shape[0]
    collides = np.zeros(n_c, dtype=bool)
    first_k = np.full(n_c, -1, dtype=np.int64)
    first_h = np.full(n_c, -1, dtype=np.int64)
    if n_h == 0 or n_c == 0:
        return ClusterHits(collides, first_k, first_h, 0)
    if test not in COLLISION_TESTS:
        raise ValueError(f"collision test {test!r}: one of {COLLISION_TESTS}")
    heading_at: HeadingFn = (
        sv_heading if callable(sv_heading) else (lambda c, k: sv_heading[c, k])  # type: ignore[index]
    )
    pad_h = np.zeros(n_h) if pad is None or test == "col" else np.asarray(pad, dtype=float)
    grow = (margin if test == "exact" else 0.0) + pad_h  # (n_h,)
    r_sv = 0.5 * np.hypot(sv_length, sv_width)
    r_tv = 0.5 * np.hypot(tv_length, tv_width)
    reach = r_sv + r_tv + 2.0 * np.sqrt(2.0) * grow  # (n_h,); growth lengthens the diagonals
    reach2 = reach**2
    # half extents of the SV's axis-aligned box for any heading within +-sv_max_heading
    sin_max = np.sin(min(abs(sv_max_heading), 0.5 * np.pi))
    sv_hx = 0.5 * sv_length + 0.5 * sv_width * sin_max
    sv_hy = 0.5 * sv_length * sin_max + 0.5 * sv_width
    last_k = np.searchsorted(t, np.maximum(sv_horizon.max(), tv_horizon), side="right")  # (n_h,)
    checked = 0
    sample_pad = pad_h if pad is not None else np.zeros(n_h)
    dt = float(t[1] - t[0]) if n_t > 1 else 0.0

    def _refine(c: IntArray, h: IntArray, k: IntArray) -> NDArray[np.bool_]:
        """Overlap anywhere in [t_k - dt/2, t_k + dt/2], at REFINE_SUBSTEPS + 1 instants:
        the SV exactly (`sv_pose`), the TV interpolated linearly between its samples
        (its interpolation error bounded from the second differences and added)."""
        assert sv_pose is not None
        n_sub = REFINE_SUBSTEPS
        frac = np.arange(n_sub + 1) / n_sub - 0.5  # (n_s,), in steps
        kp, km = np.minimum(k + 1, n_t - 1), np.maximum(k - 1, 0)
        pos = frac[None, :] > 0

        def interp(a: Array) -> Array:
            ak, ap, am = a[h, k][:, None], a[h, kp][:, None], a[h, km][:, None]
            return np.where(pos, ak + frac * (ap - ak), ak + frac * (ak - am))

        # second differences around k (at the ends of the grid, around its neighbour)
        kc = np.clip(k, 1, max(n_t - 2, 1))
        k2p, k2m = np.minimum(kc + 1, n_t - 1), kc - 1
        second = (np.abs(tv_x[h, k2p] - 2 * tv_x[h, kc] + tv_x[h, k2m])
                  + np.abs(tv_y[h, k2p] - 2 * tv_y[h, kc] + tv_y[h, k2m])
                  + r_tv[h] * np.abs(tv_h[h, k2p] - 2 * tv_h[h, kc] + tv_h[h, k2m]))
        fine_pad = margin + sample_pad[h] / n_sub + 0.25 * second  # >= 2x the (dt^2/8) a bound
        sx, sy, sh = sv_pose(c, t[k][:, None] + frac[None, :] * dt)
        hit = overlap_sat(sx, sy, sh, sv_length, sv_width, interp(tv_x), interp(tv_y),
                          interp(tv_h), tv_length[h][:, None], tv_width[h][:, None],
                          margin=fine_pad[:, None])
        return hit.any(axis=1)

    k_end = int(last_k.max(initial=0))
    bounds = [0]
    size = max(1, chunk // 8)  # short chunks first: most overlaps, if any, come early
    while bounds[-1] < k_end:
        bounds.append(min(bounds[-1] + size, k_end))
        size = min(2 * size, chunk)
    # stage 1, once for all times: hypothesis vs the bounding box of the whole cluster
    r = reach[:, None]
    near_all = (
        (np.arange(n_t)[None, :] < last_k[:, None])
        & (tv_x >= sv_x.min(axis=0) - r) & (tv_x <= sv_x.max(axis=0) + r)
        & (tv_y >= sv_y.min(axis=0) - r) & (tv_y <= sv_y.max(axis=0) + r)
    )
    busy = np.flatnonzero(near_all.any(axis=0))  # times with any TV near
    # a lane-change cluster is ordered by tau at every time (|y| falls, and x moves one
    # way, as tau grows): each window condition holds on one run of candidates
    slack = float(reach.max()) + 8.0
    ord_x, ord_y = _ordered(sv_x, slack), _ordered(sv_y, slack)
    todo = list(zip(bounds[:-1], bounds[1:], strict=True))[::-1]  # a stack, earliest on top
    while todo:  # chunks of time, in order
        k0, k1 = todo.pop()
        if not ((busy >= k0) & (busy < k1)).any():
            continue
        alive = np.flatnonzero(~collides)
        if alive.size == 0:
            break
        ph, pk = np.nonzero(near_all[:, k0:k1])
        if k1 - k0 > 1 and ph.size * alive.size > split_above:
            # crowded: the earlier half may settle most candidates before the later one
            mid = (k0 + k1) // 2
            todo += [(mid, k1), (k0, mid)]
            continue
        pk = pk + k0
        # stage 2: remaining candidates x surviving (h, k): boxes, centre distance, horizon
        th = tv_h[ph, pk]
        ct, st = np.abs(np.cos(th)), np.abs(np.sin(th))
        g2 = 2.0 * grow[ph]  # each box grows by at most 2 g (g on each of two sides' projections)
        lim_x = sv_hx + 0.5 * tv_length[ph] * ct + 0.5 * tv_width[ph] * st + g2
        lim_y = sv_hy + 0.5 * tv_length[ph] * st + 0.5 * tv_width[ph] * ct + g2
        if ord_x is not None or ord_y is not None:
            runs = [_run(o, pk, v, lim) for o, v, lim in (
                (ord_x, tv_x[ph, pk], lim_x), (ord_y, tv_y[ph, pk], lim_y)) if o is not None]
            lo = np.maximum.reduce([r[0] for r in runs])
            hi = np.minimum.reduce([r[1] for r in runs])
            qc, qp = _expand(lo, hi)
            keep = ~collides[qc]
            qc, qp = qc[keep], qp[keep]
        else:
            qa, qp = np.nonzero(np.ones((alive.size, pk.size), dtype=bool))
            qc = alive[qa]  # unordered cluster: every remaining candidate
        dx = sv_x[qc, pk[qp]] - tv_x[ph[qp], pk[qp]]
        dy = sv_y[qc, pk[qp]] - tv_y[ph[qp], pk[qp]]
        close = (
            (np.abs(dx) <= lim_x[qp]) & (np.abs(dy) <= lim_y[qp])
            & (dx * dx + dy * dy <= reach2[ph[qp]])
            & (t[pk[qp]] <= np.maximum(sv_horizon[qc], tv_horizon[ph[qp]]))
        )
        qc, qp = qc[close], qp[close]
        if qc.size == 0:
            continue
        qh, qk = ph[qp], pk[qp]
        checked += int(qc.size)
        # stage 3: the exact test on the survivors
        args = (sv_x[qc, qk], sv_y[qc, qk], heading_at(qc, qk), sv_length, sv_width,
                tv_x[qh, qk], tv_y[qh, qk], tv_h[qh, qk], tv_length[qh], tv_width[qh])
        if test == "col":
            ov = overlap_col(*args)
        else:
            ov = overlap_sat(*args, margin=grow[qh])
            if sv_pose is not None:
                # padded overlaps that are not overlaps at the sample itself: look
                # between the samples, where the pad needed is n_sub times smaller
                raw = overlap_sat(*args, margin=margin)
                maybe = np.flatnonzero(ov & ~raw)
                if maybe.size:
                    ov = raw
                    ov[maybe] = _refine(qc[maybe], qh[maybe], qk[maybe])
        if not ov.any():
            continue
        oc, oh, ok = qc[ov], qh[ov], qk[ov]
        order = np.lexsort((ok, oc))  # by candidate, then time
        cs, first = np.unique(oc[order], return_index=True)
        collides[cs] = True
        first_k[cs] = ok[order][first]
        first_h[cs] = oh[order][first]
    return ClusterHits(collides, first_k, first_h, checked)
