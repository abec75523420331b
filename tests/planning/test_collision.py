"""Rectangle overlap: exact separating-axes test, the paper's CoL, the vectorised check."""

from __future__ import annotations

import numpy as np

from cosim.planning.collision import check_cluster, corners, overlap_col, overlap_sat

RNG = np.random.default_rng(7)


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _inside(p: np.ndarray, poly: np.ndarray) -> bool:
    """Point in a counter-clockwise convex polygon (boundary included)."""
    return all(_cross(poly[i], poly[(i + 1) % 4], p) >= 0 for i in range(4))


def _segments_cross(p1, p2, q1, q2) -> bool:  # noqa: ANN001
    d1, d2 = _cross(q1, q2, p1), _cross(q1, q2, p2)
    d3, d4 = _cross(p1, p2, q1), _cross(p1, p2, q2)
    return d1 * d2 <= 0 and d3 * d4 <= 0


def brute_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Two convex quadrilaterals overlap iff an edge of one crosses an edge of the
    other or one holds a vertex of the other: plain geometry, no projections."""
    if any(_inside(p, b) for p in a) or any(_inside(p, a) for p in b):
        return True
    return any(
        _segments_cross(a[i], a[(i + 1) % 4], b[j], b[(j + 1) % 4])
        for i in range(4) for j in range(4)
    )


def _random_pairs(n: int) -> tuple[np.ndarray, ...]:
    ax, ay, bx, by = RNG.uniform(-4, 4, (4, n))
    ah, bh = RNG.uniform(-np.pi, np.pi, (2, n))
    al, bl = RNG.uniform(1.0, 6.0, (2, n))
    aw, bw = RNG.uniform(0.5, 3.0, (2, n))
    return ax, ay, ah, al, aw, bx, by, bh, bl, bw


def test_exact_test_agrees_with_brute_force_geometry() -> None:
    n = 3000
    ax, ay, ah, al, aw, bx, by, bh, bl, bw = _random_pairs(n)
    fast = overlap_sat(ax, ay, ah, al, aw, bx, by, bh, bl, bw)
    ca, cb = corners(ax, ay, ah, al, aw), corners(bx, by, bh, bl, bw)
    slow = np.array([brute_overlap(ca[i], cb[i]) for i in range(n)])
    assert 0.2 < slow.mean() < 0.8  # both outcomes well represented
    np.testing.assert_array_equal(fast, slow)


def test_exact_test_is_symmetric_and_margin_grows() -> None:
    ax, ay, ah, al, aw, bx, by, bh, bl, bw = _random_pairs(2000)
    ab = overlap_sat(ax, ay, ah, al, aw, bx, by, bh, bl, bw)
    ba = overlap_sat(bx, by, bh, bl, bw, ax, ay, ah, al, aw)
    np.testing.assert_array_equal(ab, ba)
    grown = overlap_sat(ax, ay, ah, al, aw, bx, by, bh, bl, bw, margin=0.5)
    assert (grown >= ab).all() and grown.sum() > ab.sum()
    # two axis-aligned cars 0.4 m apart side by side: clear, but not with a 0.25 m margin
    args = (0.0, 0.0, 0.0, 4.32, 1.8, 0.0, 2.2, 0.0, 4.32, 1.8)
    assert not overlap_sat(*args)
    assert overlap_sat(*args, margin=0.25)


def test_col_misses_a_crossing_that_the_exact_test_catches() -> None:
    """A TV turned 90 deg across the SV's middle: no vertex of either inside the other."""
    sv = (0.0, 0.0, 0.0, 4.32, 1.8)
    tv = (0.0, 0.0, np.pi / 2, 4.32, 1.8)
    assert overlap_sat(*sv, *tv)
    assert not overlap_col(*sv, *tv)
    # a cross with a small heading: still missed by CoL, still an overlap
    tv_skew = (0.3, 0.0, 1.3, 4.32, 1.8)
    assert overlap_sat(*sv, *tv_skew) and not overlap_col(*sv, *tv_skew)


def test_col_sees_an_sv_vertex_inside_but_not_a_tv_vertex_inside() -> None:
    # SV front-left corner inside the TV: CoL detects it
    assert overlap_col(0.0, 0.0, 0.0, 4.32, 1.8, 3.5, 1.2, 0.0, 4.32, 1.8)
    # a TV corner pokes into the SV's side, no SV vertex inside the TV: CoL misses it
    sv = (0.0, 0.0, 0.0, 4.32, 1.8)
    tv = (0.0, 1.9, 0.6, 4.32, 1.8)
    assert overlap_sat(*sv, *tv) and not overlap_col(*sv, *tv)


def test_col_agrees_with_its_definition() -> None:
    """CoL == 'some vertex of A inside B' (brute force), on random pairs."""
    ax, ay, ah, al, aw, bx, by, bh, bl, bw = _random_pairs(1500)
    col = overlap_col(ax, ay, ah, al, aw, bx, by, bh, bl, bw)
    ca, cb = corners(ax, ay, ah, al, aw), corners(bx, by, bh, bl, bw)
    ref = np.array([any(_inside(p, cb[i]) for p in ca[i]) for i in range(ah.size)])
    np.testing.assert_array_equal(col, ref)


def _dense_reference(t, sx, sy, sh, sl, sw, sv_hor, tx, ty, th, tl, tw, tv_hor):  # noqa: ANN001, ANN202
    """Every (c, h, k) through the exact test: first overlap per candidate."""
    first = np.full(sx.shape[0], -1)
    for c in range(sx.shape[0]):
        for k in range(t.size):
            ok = t[k] <= np.maximum(sv_hor[c], tv_hor)
            hit = ok & overlap_sat(sx[c, k], sy[c, k], sh[c, k], sl, sw,
                                   tx[:, k], ty[:, k], th[:, k], tl, tw)
            if hit.any():
                first[c] = k
                break
    return first


def test_check_cluster_matches_a_dense_check() -> None:
    outcomes = []
    for seed in range(8):
        rng = np.random.default_rng(seed)
        n_c, n_h, n_t = 12, 3, 60
        t = np.linspace(0, 6, n_t)
        taus = np.linspace(2, 8, n_c)
        s = np.clip(t[None, :] / taus[:, None], 0, 1)
        sx = 20.0 * t[None, :] + 0 * taus[:, None]
        sy = 3.75 * (6 * s**5 - 15 * s**4 + 10 * s**3)
        sh = np.arctan2(np.gradient(sy, t, axis=1), 20.0)
        # target-lane TVs a few car lengths away, closing in or falling back
        tx = rng.choice([-1, 1], (n_h, 1)) * rng.uniform(6, 30, (n_h, 1)) + (
            20.0 + rng.uniform(-6, 6, (n_h, 1))) * t[None, :]
        ty = np.full((n_h, 1), 3.75) + 0 * t[None, :]
        th = np.zeros_like(tx)
        tl, tw = np.full(n_h, 4.32), np.full(n_h, 1.8)
        sv_hor = taus + 1.0
        tv_hor = np.full(n_h, -np.inf)
        fast = check_cluster(t, sx, sy, sh, 4.32, 1.8, sv_hor, tx, ty, th, tl, tw, tv_hor,
                             chunk=7)
        ref = _dense_reference(t, sx, sy, sh, 4.32, 1.8, sv_hor, tx, ty, th, tl, tw, tv_hor)
        np.testing.assert_array_equal(fast.first_index, ref)
        np.testing.assert_array_equal(fast.collides, ref >= 0)
        outcomes.append(fast.collides)
    both = np.concatenate(outcomes)
    assert 0.1 < both.mean() < 0.9  # the check saw both verdicts


def test_padding_catches_an_overlap_between_samples() -> None:
    """A TV crossing the SV's path at 80 m/s sideways overlaps it only between samples."""
    t = np.array([0.0, 0.05])
    sx = np.zeros((1, 2))
    sy = np.zeros((1, 2))
    sh = np.zeros((1, 2))
    tx = np.zeros((1, 2))
    ty = np.array([[-1.9, 2.1]])  # |y| > 1.8 at both samples: no overlap at the samples
    th = np.zeros((1, 2))
    args = (t, sx, sy, sh, 4.32, 1.8, np.array([1.0]), tx, ty, th, np.array([4.32]),
            np.array([1.8]), np.array([1.0]))
    assert not check_cluster(*args).collides[0]
    pad = np.array([0.25 * 4.0])  # D/4 with D = 4 m of relative travel per step
    assert check_cluster(*args, pad=pad).collides[0]


def test_closed_form_cluster_bounds_cover_the_sampled_motion() -> None:
    from cosim.planning.collision import standard_cluster_motion
    from cosim.planning.trajectory import cluster_derivatives

    rng = np.random.default_rng(11)
    for _ in range(20):
        vx0, vxf = rng.uniform(10, 35, 2)
        W = rng.choice([-1, 1]) * rng.uniform(2, 4)
        taus = np.arange(rng.uniform(1.5, 4.0), 10.0, 0.05)
        t = np.arange(0.0, 12.001, 0.01)  # fine: the true derivatives, not chords
        d = cluster_derivatives(vx0, vxf, W, taus, t, (1, 2))
        (xd, yd), (xdd, ydd) = d[1], d[2]
        rate = np.abs((xd * ydd - yd * xdd) / (xd**2 + yd**2))
        b = standard_cluster_motion(vx0, vxf, W, float(taus.min()), 1.0)
        assert b.dx_min <= xd.min() + 1e-9 and b.dx_max >= xd.max() - 1e-9
        assert b.dy_max >= np.abs(yd).max() - 1e-9
        assert b.turn >= rate.max() - 1e-9
        assert b.max_heading >= np.abs(np.arctan2(yd, xd)).max() - 1e-9


def test_refinement_keeps_real_overlaps_and_drops_pad_only_ones() -> None:
    """Between-sample look: a real crossing between samples stays a collision, a near
    miss that only the pad turned into an overlap does not."""
    t = np.arange(0.0, 0.5001, 0.05)
    n_t = t.size
    zeros = np.zeros((1, n_t))

    def pose(c: np.ndarray, tt: np.ndarray) -> tuple[np.ndarray, ...]:
        return np.zeros_like(tt), np.zeros_like(tt), np.zeros_like(tt)

    def run(ty: np.ndarray, tx: np.ndarray, pad: float, refine: bool) -> bool:
        return bool(check_cluster(
            t, zeros, zeros, zeros, 4.32, 1.8, np.array([1.0]), tx[None, :], ty[None, :],
            np.zeros((1, n_t)), np.array([4.32]), np.array([1.8]), np.array([1.0]),
            pad=np.array([pad]), sv_pose=pose if refine else None,
        ).collides[0])

    # crossing sideways at 80 m/s: overlaps only between t = 0.2 and 0.25
    ty = -1.9 + 80.0 * (t - 0.2)
    assert run(ty, np.zeros(n_t), 1.0, refine=False)
    assert run(ty, np.zeros(n_t), 1.0, refine=True)
    # passing 1.95 m to the side (15 cm clear) at 30 m/s relative: never overlaps
    tx = -5.0 + 30.0 * t
    side = np.full(n_t, 1.95)
    assert run(side, tx, 0.4, refine=False)  # the pad alone calls it a collision
    assert not run(side, tx, 0.4, refine=True)


def _standard_case(rng: np.random.Generator):  # noqa: ANN202
    from cosim.planning.trajectory import standard_positions, standard_velocities

    vx0, vxf = rng.uniform(15, 35, 2)
    if rng.random() < 0.2:
        vxf = vx0  # no speed change: every candidate has the same x
    W = float(rng.choice([-1, 1]) * rng.uniform(2.5, 4.0))
    t = np.arange(0.0, 12.001, 0.05)
    taus = np.arange(rng.uniform(1.5, 4.0), 10.0, 0.05)
    taus = np.insert(taus, 0, taus[0] - rng.uniform(0.001, 0.05))  # tau_min itself
    x0, y0 = 400.0, 5.625

    def heading(c: np.ndarray, k: np.ndarray) -> np.ndarray:
        xd, yd = standard_velocities(vx0, vxf, W, taus[c], t[k])
        return np.arctan2(yd, xd)

    x, y = standard_positions(vx0, vxf, W, taus, t)
    return t, taus, (x0, y0, vx0, vxf, W), x + x0, y + y0, heading


def test_standard_cluster_gives_the_arrays_positions_and_window_supersets() -> None:
    from cosim.planning.collision import StandardCluster

    rng = np.random.default_rng(5)
    for _ in range(10):
        t, taus, (x0, y0, vx0, vxf, W), x, y, heading = _standard_case(rng)
        sc = StandardCluster(t, taus, x0, y0, vx0, vxf, W, heading)
        c = rng.integers(0, taus.size, 500)
        k = rng.integers(0, t.size, 500)
        px, py = sc.xy(c, k)
        np.testing.assert_array_equal(px, x[c, k])  # the same numbers, to the last bit
        np.testing.assert_array_equal(py, y[c, k])
        # windows: every candidate inside a query box is inside its window
        q = 400
        kq = rng.integers(0, t.size, q)
        pick = rng.integers(0, taus.size, q)
        qx = x[pick, kq] + rng.normal(0, 4, q)
        qy = y[pick, kq] + rng.normal(0, 1.5, q)
        hx, hy = rng.uniform(0.5, 6, q), rng.uniform(0.2, 3, q)
        lo, hi = sc.windows(kq, qx, hx, qy, hy, 10.0)
        inside = (np.abs(x[:, kq] - qx) <= hx) & (np.abs(y[:, kq] - qy) <= hy)  # (n_c, q)
        rows = np.arange(taus.size)[:, None]
        assert not (inside & ((rows < lo) | (rows >= hi))).any()
        excess = (hi - lo) - inside.sum(axis=0)
        assert inside.any() and np.median(excess) <= 6  # and they are tight


def test_standard_cluster_check_equals_the_array_check() -> None:
    from cosim.planning.collision import (
        StandardCluster,
        TVArrays,
        check_sv_cluster,
        sampling_pad,
        standard_cluster_motion,
    )

    rng = np.random.default_rng(9)
    hits = 0
    for _ in range(6):
        t, taus, (x0, y0, vx0, vxf, W), x, y, heading = _standard_case(rng)
        n_h = 12
        lane = y0 + W * rng.integers(0, 2, (n_h, 1))
        tx = x0 + rng.uniform(-40, 40, (n_h, 1)) + rng.uniform(15, 35, (n_h, 1)) * t[None, :]
        ty = lane + 0 * t[None, :]
        th = np.zeros_like(tx)
        tl, tw = np.full(n_h, 4.32), np.full(n_h, 1.8)
        motion = standard_cluster_motion(vx0, vxf, W, float(taus.min()), 0.05)
        pad = sampling_pad(motion, tx, ty, th, 2.35, np.full(n_h, 2.35))
        kw = {"margin": 0.1, "sv_max_heading": motion.max_heading}
        sv_hor, tv_hor = taus + 2.0, np.full(n_h, -np.inf)
        a = check_cluster(t, x, y, heading, 4.32, 1.8, sv_hor, tx, ty, th, tl, tw, tv_hor,
                          pad=pad, **kw)
        b = check_sv_cluster(t, StandardCluster(t, taus, x0, y0, vx0, vxf, W, heading), 4.32,
                             1.8, sv_hor, TVArrays(tx, ty, th, tl, tw, pad), tv_hor, **kw)
        for f in ("collides", "first_index", "first_hypothesis"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        hits += int(a.collides.sum())
    assert hits > 0


def test_closed_form_tv_clusters_give_the_array_check() -> None:
    """C2 clusters left in closed form (evaluated where needed, pads exact where the
    exact test runs, bounded before) give what their stored arrays give."""
    from cosim.params import RoadParams, VehicleParams
    from cosim.planning.collision import (
        StandardCluster,
        TVClosedForm,
        check_sv_cluster,
        sampling_pad,
        standard_cluster_motion,
    )
    from cosim.planning.prediction import predict_lazy
    from cosim.planning.trajectory import standard_positions
    from cosim.traffic.v2v import V2VMessage

    road, veh = RoadParams(mu=0.8), VehicleParams()
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 12.001, 0.05)
    grid = np.arange(2.0, 10.001, 0.05)
    hits = 0
    vx0, vxf, W = 27.0, 30.0, 3.75
    y0 = road.lane_center(1)
    for _ in range(4):
        msgs = [V2VMessage(f"tv{i}", 0.0, 500.0 + float(rng.uniform(-30, 40)),
                           road.lane_center(lane), 0.0, float(rng.uniform(22, 32)), 0.0, lane,
                           0.0, 4.32, 1.8, intention, None)
                for i, (lane, intention) in enumerate([(2, -1), (2, 0), (0, 1), (1, 0)])]
        f = predict_lazy(msgs, 0.0, t, road, veh, grid)
        assert f.blocks  # some hypotheses are in closed form
        x, y = standard_positions(vx0, vxf, W, grid, t)
        x, y = x + 500.0, y + y0

        def heading(c: np.ndarray, k: np.ndarray) -> np.ndarray:
            from cosim.planning.trajectory import standard_velocities

            xd, yd = standard_velocities(vx0, vxf, W, grid[c], t[k])
            return np.arctan2(yd, xd)

        motion = standard_cluster_motion(vx0, vxf, W, float(grid.min()), 0.05)
        kw = {"margin": 0.1, "sv_max_heading": motion.max_heading}
        sv_hor = grid + 2.0
        tv_hor = np.where(np.isfinite(f.t_end), f.t_end, -np.inf) + 2.0
        pad = sampling_pad(motion, f.x, f.y, f.heading, 2.35, 0.5 * np.hypot(f.length, f.width))
        a = check_cluster(t, x, y, heading, 4.32, 1.8, sv_hor, f.x, f.y, f.heading, f.length,
                          f.width, tv_hor, pad=pad, **kw)
        sc = StandardCluster(t, grid, 500.0, y0, vx0, vxf, W, heading)
        b = check_sv_cluster(t, sc, 4.32, 1.8, sv_hor, TVClosedForm(f, motion, 2.35), tv_hor,
                             **kw)
        for name in ("collides", "first_index", "first_hypothesis"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        hits += int(a.collides.sum())
    assert 0 < hits < 4 * grid.size


def test_lazy_futures_give_their_arrays_pointwise() -> None:
    from cosim.params import RoadParams, VehicleParams
    from cosim.planning.prediction import predict_lazy
    from cosim.traffic.v2v import V2VMessage

    road = RoadParams(mu=0.8)
    t = np.arange(0.0, 12.001, 0.05)
    msgs = [V2VMessage("a", 0.0, 480.0, road.lane_center(2), 0.0, 25.0, 0.0, 2, 0.0, 4.32, 1.8,
                       -1, None),
            V2VMessage("b", 0.0, 520.0, road.lane_center(0), 0.0, 20.0, 0.5, 0, 0.0, 4.32, 1.8,
                       0, None)]
    f = predict_lazy(msgs, 1.0, t, road, VehicleParams(), np.arange(2.0, 10.001, 0.05))
    h = RNG.integers(0, f.n_hypotheses, 300)
    k = RNG.integers(0, t.size, 300)
    x, y = f.xy(h, k)
    np.testing.assert_array_equal(x, f.x[h, k])
    np.testing.assert_array_equal(y, f.y[h, k])
    np.testing.assert_array_equal(f.heading_at(h, k), f.heading[h, k])


def test_closed_form_pad_bound_covers_the_exact_pad() -> None:
    from cosim.params import RoadParams, VehicleParams
    from cosim.planning.collision import TVClosedForm, standard_cluster_motion
    from cosim.planning.prediction import predict_lazy
    from cosim.traffic.v2v import V2VMessage

    road = RoadParams(mu=0.8)
    t = np.arange(0.0, 12.001, 0.05)
    rng = np.random.default_rng(2)
    for _ in range(5):
        msgs = [V2VMessage(f"tv{i}", 0.0, float(rng.uniform(400, 600)), road.lane_center(lane),
                           0.0, float(rng.uniform(15, 34)), 0.0, lane, 0.0, 4.32, 1.8,
                           1 if lane < 2 else -1, None) for i, lane in enumerate((0, 1, 2))]
        f = predict_lazy(msgs, 0.0, t, road, VehicleParams(), np.arange(1.5, 10.001, 0.05))
        motion = standard_cluster_motion(float(rng.uniform(20, 30)), 27.0, 3.75, 2.5, 0.05)
        tv = TVClosedForm(f, motion, 2.35)
        closed = np.flatnonzero(f.closed)
        assert closed.size > 100
        exact = tv.pad(closed)
        assert (tv.pad_bound[closed] >= exact).all()
        assert (tv.pad_bound[closed] <= 1.5 * exact).all()  # and not far above
