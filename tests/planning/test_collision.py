"""Rectangle overlap: exact separating-axes test, the paper's CoL, the compiled check."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cosim.params import VehicleParams
from cosim.planning.collision import (
    Box,
    SVCandidates,
    TVHypotheses,
    check_candidates,
    corners,
    overlap_col,
    overlap_sat,
)
from cosim.planning.trajectory import (
    BoundaryConditions,
    cluster_derivatives,
    standard_bounds,
    standard_positions,
    standard_tau_sensitivity,
    standard_velocities,
)

RNG = np.random.default_rng(7)


def check_cluster(t, sv, sl, sw, sv_hor, tx, ty, th, tl, tw, tv_hor, **kw):  # noqa: ANN001, ANN003, ANN201
    """`check_candidates` against TV trajectories given as (n_h, n_t) arrays."""
    return check_candidates(t, sv, VehicleParams(length=sl, width=sw), sv_hor,
                            TVHypotheses.from_rows(tx, ty, th, tl, tw), tv_hor, **kw)


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
    fast = overlap_sat(Box(ax, ay, ah, al, aw), Box(bx, by, bh, bl, bw))
    ca, cb = corners(ax, ay, ah, al, aw), corners(bx, by, bh, bl, bw)
    slow = np.array([brute_overlap(ca[i], cb[i]) for i in range(n)])
    assert 0.2 < slow.mean() < 0.8  # both outcomes well represented
    np.testing.assert_array_equal(fast, slow)


def test_exact_test_is_symmetric_and_margin_grows() -> None:
    ax, ay, ah, al, aw, bx, by, bh, bl, bw = _random_pairs(2000)
    ab = overlap_sat(Box(ax, ay, ah, al, aw), Box(bx, by, bh, bl, bw))
    ba = overlap_sat(Box(bx, by, bh, bl, bw), Box(ax, ay, ah, al, aw))
    np.testing.assert_array_equal(ab, ba)
    grown = overlap_sat(Box(ax, ay, ah, al, aw), Box(bx, by, bh, bl, bw), margin=0.5)
    assert (grown >= ab).all() and grown.sum() > ab.sum()
    # two axis-aligned cars 0.4 m apart side by side: clear, but not with a 0.25 m margin
    args = (Box(0.0, 0.0, 0.0, 4.32, 1.8), Box(0.0, 2.2, 0.0, 4.32, 1.8))
    assert not overlap_sat(*args)
    assert overlap_sat(*args, margin=0.25)


def test_col_misses_a_crossing_that_the_exact_test_catches() -> None:
    """A TV turned 90 deg across the SV's middle: no vertex of either inside the other."""
    sv = (0.0, 0.0, 0.0, 4.32, 1.8)
    tv = (0.0, 0.0, np.pi / 2, 4.32, 1.8)
    assert overlap_sat(Box(*sv), Box(*tv))
    assert not overlap_col(Box(*sv), Box(*tv))
    # a cross with a small heading: still missed by CoL, still an overlap
    tv_skew = (0.3, 0.0, 1.3, 4.32, 1.8)
    assert overlap_sat(Box(*sv), Box(*tv_skew)) and not overlap_col(Box(*sv), Box(*tv_skew))


def test_col_sees_an_sv_vertex_inside_but_not_a_tv_vertex_inside() -> None:
    # SV front-left corner inside the TV: CoL detects it
    assert overlap_col(Box(0.0, 0.0, 0.0, 4.32, 1.8), Box(3.5, 1.2, 0.0, 4.32, 1.8))
    # a TV corner pokes into the SV's side, no SV vertex inside the TV: CoL misses it
    sv = (0.0, 0.0, 0.0, 4.32, 1.8)
    tv = (0.0, 1.9, 0.6, 4.32, 1.8)
    assert overlap_sat(Box(*sv), Box(*tv)) and not overlap_col(Box(*sv), Box(*tv))


def test_col_agrees_with_its_definition() -> None:
    """CoL == 'some vertex of A inside B' (brute force), on random pairs."""
    ax, ay, ah, al, aw, bx, by, bh, bl, bw = _random_pairs(1500)
    col = overlap_col(Box(ax, ay, ah, al, aw), Box(bx, by, bh, bl, bw))
    ca, cb = corners(ax, ay, ah, al, aw), corners(bx, by, bh, bl, bw)
    ref = np.array([any(_inside(p, cb[i]) for p in ca[i]) for i in range(ah.size)])
    np.testing.assert_array_equal(col, ref)


def _dense_reference(t, sv, sl, sw, sv_hor, tx, ty, th, tl, tw, tv_hor, test="exact"):  # noqa: ANN001, ANN202
    """Every (c, h, k) through the test, with the SV from `cluster_derivatives`: first
    overlap per candidate (no margin, no pad)."""
    d = cluster_derivatives(sv.boundary, sv.taus, t + sv.t_shift, (0, 1))
    sx, sy = d[0][0] + sv.x0, d[0][1] + sv.y0
    sh = np.arctan2(d[1][1], d[1][0])
    overlap = overlap_sat if test == "exact" else overlap_col
    first = np.full(sx.shape[0], -1)
    for c in range(sx.shape[0]):
        for k in range(t.size):
            ok = t[k] <= np.maximum(sv_hor[c], tv_hor)
            hit = ok & overlap(Box(sx[c, k], sy[c, k], sh[c, k], sl, sw),
                               Box(tx[:, k], ty[:, k], th[:, k], tl, tw))
            if hit.any():
                first[c] = k
                break
    return first


def _target_lane_traffic(rng: np.random.Generator, t: np.ndarray, n_h: int) -> tuple:  # noqa: ANN001
    """TVs a few car lengths away in the target lane, closing in or falling back."""
    tx = rng.choice([-1, 1], (n_h, 1)) * rng.uniform(6, 30, (n_h, 1)) + (
        20.0 + rng.uniform(-6, 6, (n_h, 1))) * t[None, :]
    ty = np.full((n_h, 1), 3.75) + 0 * t[None, :]
    return tx, ty, np.zeros_like(tx), np.full(n_h, 4.32), np.full(n_h, 1.8)


def _between_samples(t, sv, c, k, tx, ty, th, tl, tw, n=50, horizon=np.inf):  # noqa: ANN001, ANN202, PLR0913
    """Candidate c against the (linear) rows at n + 1 instants of [t_k - dt/2, t_k + dt/2]
    (to the horizon instead when the next sample lies past it: the cell of the last
    sample tested reaches it)."""
    dt = t[1] - t[0]
    end = horizon if k + 1 < t.size and t[k + 1] > horizon else t[k] + 0.5 * dt
    tt = np.clip(np.linspace(t[k] - 0.5 * dt, end, n + 1), t[0], t[-1])
    d = cluster_derivatives(sv.boundary, sv.taus[c:c + 1], tt + sv.t_shift, (0, 1))
    sx, sy, sh = d[0][0][0] + sv.x0, d[0][1][0] + sv.y0, np.arctan2(d[1][1][0], d[1][0][0])
    lerp = [np.array([np.interp(tt, t, row) for row in a]) for a in (tx, ty, th)]
    return overlap_sat(Box(sx[None, :], sy[None, :], sh[None, :], 4.32, 1.8),
                       Box(*lerp, tl[:, None], tw[:, None])).any()


def test_check_matches_a_dense_check() -> None:
    """Standard and general-start candidates, exact test and CoL. CoL (at the samples,
    as the paper): the first overlap of each candidate is the one a test of every
    (candidate, TV, sample) finds. Exact (continuous in time): it finds every overlap
    at the samples, at the same sample or before; one found earlier is a real overlap
    within half a step of its sample (or, at the last sample of a pair, up to its
    horizon)."""
    outcomes, between = [], 0
    for seed in range(8):
        rng = np.random.default_rng(seed)
        n_c, n_h = 12, 3
        t = np.linspace(0, 6, 60)
        taus = np.linspace(2, 8, n_c)
        start = {} if seed % 2 else {"ax0": 0.4, "vy0": 0.3, "ay0": -0.2}
        sv = SVCandidates(taus, 20.0, 20.0 + seed % 3, 3.75, 0.0, 0.0, **start)
        tx, ty, th, tl, tw = _target_lane_traffic(rng, t, n_h)
        sv_hor, tv_hor = taus + 1.0, np.full(n_h, -np.inf)
        for test in ("exact", "col"):
            fast = check_cluster(t, sv, 4.32, 1.8, sv_hor, tx, ty, th, tl, tw, tv_hor, test=test)
            ref = _dense_reference(t, sv, 4.32, 1.8, sv_hor, tx, ty, th, tl, tw, tv_hor, test)
            if test == "col":
                np.testing.assert_array_equal(fast.first_index, ref)
            else:
                assert (fast.collides >= (ref >= 0)).all()
                assert (fast.first_index[ref >= 0] <= ref[ref >= 0]).all()
                for c in np.flatnonzero(fast.first_index != ref):
                    assert _between_samples(t, sv, c, fast.first_index[c], tx, ty, th, tl, tw,
                                            horizon=sv_hor[c])
                    between += 1
            outcomes.append(fast.collides)
    both = np.concatenate(outcomes)
    assert 0.1 < both.mean() < 0.9  # the check saw both verdicts


def _stationary_sv() -> SVCandidates:
    return SVCandidates(np.array([1.0]), 0.0, 0.0, 0.0, 0.0, 0.0)  # at the origin, heading 0


def test_an_overlap_between_samples_is_caught() -> None:
    """A TV crossing the SV's path at 80 m/s sideways overlaps it only between samples:
    the exact test catches it, CoL (at the samples, as the paper) does not."""
    t = np.array([0.0, 0.05])
    tx = np.zeros((1, 2))
    ty = np.array([[-1.9, 2.1]])  # |y| > 1.8 at both samples: no overlap at the samples
    th = np.zeros((1, 2))
    args = (t, _stationary_sv(), 4.32, 1.8, np.array([1.0]), tx, ty, th, np.array([4.32]),
            np.array([1.8]), np.array([1.0]))
    assert check_cluster(*args).collides[0]
    assert not check_cluster(*args, test="col").collides[0]


def test_a_near_miss_between_samples_is_not_an_overlap() -> None:
    """A real crossing between samples stays a collision; a pass 15 cm to the side at
    30 m/s relative, whose motion bound overlaps at the samples near the pass, does not."""
    t = np.arange(0.0, 0.5001, 0.05)
    n_t = t.size

    def run(ty: np.ndarray, tx: np.ndarray, margin: float = 0.0) -> bool:
        return bool(check_cluster(
            t, _stationary_sv(), 4.32, 1.8, np.array([1.0]), tx[None, :], ty[None, :],
            np.zeros((1, n_t)), np.array([4.32]), np.array([1.8]), np.array([1.0]),
            margin=margin).collides[0])

    ty = -1.9 + 80.0 * (t - 0.2)  # overlaps only between t = 0.2 and 0.25
    assert run(ty, np.zeros(n_t))
    tx = -5.0 + 30.0 * t
    side = np.full(n_t, 1.95)
    assert overlap_sat(Box(0.0, 0.0, 0.0, 4.32, 1.8), Box(tx, side, 0.0, 4.32, 1.8),
                       margin=0.4).any()
    assert not run(side, tx)
    assert not run(side, tx, margin=0.07)  # 15 cm apart: clear with 7 cm on each
    assert run(side, tx, margin=0.08)  # and not with 8 cm


def test_closed_form_bounds_cover_the_sampled_motion() -> None:
    """`standard_bounds` (in time) and `standard_tau_sensitivity` (in the duration) hold
    on a fine grid of times and durations."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        vx0, vxf = rng.uniform(10, 35, 2)
        W = rng.choice([-1, 1]) * rng.uniform(2, 4)
        tau0 = rng.uniform(1.5, 4.0)
        taus = np.arange(tau0, 10.0, 0.01)
        t = np.arange(0.0, 12.001, 0.01)  # fine: the true derivatives, not chords
        d = cluster_derivatives(BoundaryConditions(vx0, vxf, W), taus, t, (1, 2))
        (xd, yd), (xdd, ydd) = d[1], d[2]
        rate = np.abs((xd * ydd - yd * xdd) / (xd**2 + yd**2))
        v_lo, v_hi, yd_max, rate_max, head = standard_bounds(vx0, vxf, W, tau0)
        assert v_lo <= xd.min() + 1e-9 and v_hi >= xd.max() - 1e-9
        assert yd_max >= np.abs(yd).max() - 1e-9
        assert rate_max >= rate.max() - 1e-9
        assert head >= np.abs(np.arctan2(yd, xd)).max() - 1e-9
        sx, sy, srot = standard_tau_sensitivity(vx0, vxf, W, tau0)
        x, y = standard_positions(vx0, vxf, W, taus, t)
        vx, vy = standard_velocities(vx0, vxf, W, taus[:, None], t[None, :])
        dtau = np.diff(taus)[:, None]
        assert (np.abs(np.diff(x, axis=0)) / dtau).max() <= sx + 1e-9
        assert (np.abs(np.diff(y, axis=0)) / dtau).max() <= sy + 1e-9
        assert (np.abs(np.diff(np.arctan2(vy, vx), axis=0)) / dtau).max() <= srot + 1e-9
        # ordered by the duration at every time: the box of two durations holds the others
        assert ((np.diff(y, axis=0) * np.sign(W)) <= 1e-12).all()
        assert ((np.diff(x, axis=0) * np.sign(vx0 - vxf)) >= -1e-12).all()


def _c2_scene(rng: np.random.Generator, t: np.ndarray):  # noqa: ANN202
    from cosim.params import RoadParams, VehicleParams
    from cosim.planning.prediction import predict_lazy
    from cosim.traffic.v2v import V2VMessage

    road = RoadParams(mu=0.8)
    msgs = [V2VMessage(f"tv{i}", 0.0, 500.0 + float(rng.uniform(-30, 40)),
                       road.lane_center(lane), 0.0, float(rng.uniform(22, 32)), 0.0, lane, 0.0,
                       4.32, 1.8, intention, None)
            for i, (lane, intention) in enumerate([(2, -1), (2, 0), (0, 1), (1, 0)])]
    return road, predict_lazy(msgs, 0.0, t, road, VehicleParams(), np.arange(2.0, 10.001, 0.05))


def test_closed_form_hypotheses_give_what_their_rows_give() -> None:
    """C2 clusters left in closed form (evaluated where needed, windows by binary search)
    give the verdicts of their materialised rows at the listed durations; with their
    cells (every duration between neighbours) they reject at least as much."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 12.001, 0.05)
    grid = np.arange(2.0, 10.001, 0.05)
    hits, more = 0, 0
    for margin in (0.0, 0.1, 0.1, 0.3):
        road, f = _c2_scene(rng, t)
        assert (f.row_of < 0).sum() > 100  # C2 clusters in closed form
        sv = SVCandidates(grid, 27.0, 30.0, 3.75, 500.0, road.lane_center(1))
        cells = TVHypotheses.from_futures(f)
        listed = replace(cells, cell=np.zeros_like(cells.cell))
        rows = replace(TVHypotheses.from_rows(f.x, f.y, f.heading, f.length, f.width),
                       groups=cells.groups)
        sv_hor = grid + 2.0
        tv_hor = np.where(np.isfinite(f.t_end), f.t_end, -np.inf) + 2.0
        a, b, c = (check_candidates(t, sv, VehicleParams(), sv_hor, tv, tv_hor, margin=margin)
                   for tv in (listed, rows, cells))
        np.testing.assert_array_equal(a.collides, b.collides)
        assert (c.collides >= a.collides).all()
        hits += int(a.collides.sum())
        more += int((c.collides & ~a.collides).sum())
    assert 0 < hits < 4 * grid.size


def test_a_broadcast_quintic_is_kept_in_closed_form() -> None:
    """A C3 quintic broadcast started before the plan is a closed-form hypothesis whose
    rows are the path it broadcast (`prediction.motion_path`)."""
    from cosim.params import RoadParams, VehicleParams
    from cosim.planning.prediction import motion_path, predict_lazy
    from cosim.traffic.v2v import LateralMotion, V2VMessage

    road = RoadParams(mu=0.8)
    t = np.arange(0.0, 12.001, 0.05)
    quintic = LateralMotion(-0.7, 4.0, 590.0, road.lane_center(0), 24.0, 26.0, 3.75)
    msgs = [V2VMessage("b", 0.0, 520.0, road.lane_center(0), 0.0, 20.0, 0.5, 0, 0.0, 4.32, 1.8,
                       0, None),
            V2VMessage("c", 0.0, 607.0, road.lane_center(0) + 0.3, 0.0, 24.5, 0.0, 0, 0.0, 4.32,
                       1.8, 1, quintic)]
    f = predict_lazy(msgs, 1.0, t, road, VehicleParams(), np.arange(2.0, 10.001, 0.05))
    assert f.categories == ("C1", "C3")
    assert f.row_of.tolist() == [0, -1]  # C1 stored, C3 in closed form
    px, py, ph = motion_path(quintic, f.t)
    np.testing.assert_allclose(f.x[1], px, atol=1e-9)
    np.testing.assert_allclose(f.y[1], py, atol=1e-9)
    np.testing.assert_allclose(f.heading[1], ph, atol=1e-12)


def test_a_started_manoeuvre_is_checked_at_its_own_time() -> None:
    """A candidate t_shift into its manoeuvre (a re-check under way) gives what the
    same candidate from its start gives on the grid shifted by t_shift, the looks
    between samples included."""
    rng = np.random.default_rng(3)
    shift = 1.3
    t = np.arange(0.0, 9.0, 0.05)
    taus = np.linspace(3.0, 8.0, 21)
    refined, outcomes = 0, []
    for seed in range(6):
        start = {} if seed % 2 else {"vy0": 0.2, "ay0": 0.1}
        tx, ty, th, tl, tw = _target_lane_traffic(rng, t, 2)
        tx += 22.0 * shift  # around the SV, which is under way
        hor = (taus + 1.0, np.full(2, -np.inf))
        under_way = SVCandidates(taus, 22.0, 25.0, 3.75, 0.0, 0.0, t_shift=shift, **start)
        from_start = replace(under_way, t_shift=0.0)
        a = check_cluster(t, under_way, 4.32, 1.8, hor[0] - shift, tx, ty, th, tl, tw, hor[1],
                          margin=0.3)
        b = check_cluster(t + shift, from_start, 4.32, 1.8, hor[0], tx, ty, th, tl, tw,
                          hor[1], margin=0.3)
        for name in ("collides", "first_index", "first_hypothesis"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        samples = check_cluster(t, under_way, 4.32, 1.8, hor[0] - shift, tx, ty, th, tl, tw,
                                hor[1], margin=0.3, test="col")
        refined += int((a.first_index != samples.first_index).sum())
        outcomes.append(a.collides)
    both = np.concatenate(outcomes)
    assert 0.05 < both.mean() < 0.95  # both verdicts
    assert refined > 0  # the looks between samples took part


def test_a_merge_from_a_creep_beside_a_creeping_queue_is_planned_at_once() -> None:
    """A planner call recorded in the merge study (ramp_merge, 50 veh/km/lane, seed 2,
    t = 33.1 s): the SV creeps at 1 m/s 25 m before its acceleration lane's end beside
    a queue creeping at 0-3 m/s, whose drivers signal. Each candidate then passes within
    millimetres of the margin for seconds, and the exact test's refinement would split
    cells for minutes in this one call. It is cut at `_MAX_CELLS` cells per pair,
    as an overlap: the call returns, and every candidate it rejects for a collision is
    one the refinement could not clear."""
    import json

    from cosim.params import PlannerConfig, RoadParams, VehicleParams
    from cosim.planning.planner import LaneChangePlanner, PredictionOptions, RoadCurve, SVPlanState
    from cosim.scenario import project_root
    from cosim.traffic.v2v import V2VMessage

    rec = json.loads((project_root() / "tests" / "data" / "creep_merge_plan.json").read_text())
    bands = ((50 / 3.6, 90 / 3.6),) * 2 + ((90 / 3.6, 110 / 3.6), (110 / 3.6, 120 / 3.6))
    road = RoadParams(mu=0.6, y_right=-3.75, speed_bands=bands,
                      lane_ends=(194.5, np.inf, np.inf, np.inf))
    planner = LaneChangePlanner(VehicleParams(), road, PlannerConfig(policy="gap"),
                                prediction=PredictionOptions(gap_end_speed=True),
                                curve=RoadCurve(0.0, 9.375, 120 / 3.6, 2.34))
    plan = planner.plan(rec["t"], SVPlanState(**rec["sv"]), rec["target_lane"],
                        [V2VMessage(**m) for m in rec["messages"]], rec["occupant"],
                        **rec["kwargs"])
    assert plan.trajectory is None  # no gap beside the queue
    assert {r.reason for r in plan.rejections} >= {"collision"}


def test_a_creeping_tv_changing_lanes_grows_its_cells_by_its_size_at_most() -> None:
    """A TV creeping at 2 cm/s, predicted to change lanes from rest (C2 in closed form):
    its heading-rate bound is huge (the heading of a path from near rest swings at
    once), but a corner moves at most a chord of its circle, so the check's reach stays
    within the bodies' size (a TV 70 m behind is cleared at once, not refined), and the
    verdicts are those of its materialised rows."""
    from cosim.planning import collision
    from cosim.planning.trajectory import LANE_CHANGE, lane_change_state

    t = np.arange(0.0, 12.001, 0.05)
    durations = np.arange(2.1, 10.001, 0.05)
    sv = SVCandidates(np.arange(2.25, 10.001, 0.5), 8.9, 12.8, 3.75, 182.0, 5.625)
    sv_hor = sv.taus + 2.0
    for x_tv, expect_hit in ((111.5, False), (178.0, True)):
        lc = np.zeros(durations.size, dtype=LANE_CHANGE)
        lc["v0"], lc["vxf"], lc["width"], lc["tau"] = 0.0229, 4.25, 3.75, durations
        lc["x0"], lc["y0"], lc["start"] = x_tv, 5.625, 0.0
        n_h = durations.size
        closed = TVHypotheses(np.zeros((0, t.size)), np.zeros((0, t.size)), np.zeros((0, t.size)),
                              np.full(n_h, -1), lc, np.zeros(n_h, dtype=bool),
                              np.full(n_h, 4.32), np.full(n_h, 1.8), np.array([0, n_h]))
        tv_hor = durations + 2.0
        side = closed.side(tv_hor, 0.0, 0.05)
        bounds = collision._phase_bounds(sv.side(t, 4.32, 1.8, sv_hor), side, 0.02, False)
        assert bounds[6].max() < 15.0  # g_lim_x, m (3544 m from the rate bound alone)
        rows = np.array([[lane_change_state(*q[["v0", "vxf", "width", "tau", "x0", "y0",
                                                "start"]].tolist(), tk)[:3] for tk in t]
                         for q in lc])
        stored = replace(TVHypotheses.from_rows(rows[..., 0], rows[..., 1], rows[..., 2], 4.32,
                                                1.8), groups=closed.groups)
        a, b = (check_candidates(t, sv, VehicleParams(), sv_hor, tv, tv_hor, margin=0.02)
                for tv in (closed, stored))
        np.testing.assert_array_equal(a.collides, b.collides)
        assert a.collides.any() == expect_hit
