"""The road frame: exact conversions both ways, the identity on the straight road,
bounded deviation from SUMO's lanes, refusal of what cannot be smoothed."""

from __future__ import annotations

import functools
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely

from cosim.errors import InputError
from cosim.road.frame import ArcFrame, FrameLimits, StraightFrame, polyline_radius, smooth
from cosim.road.road import Road, load_road
from cosim.traffic.network import NETWORK_DIR

CURVED = NETWORK_DIR / "curved_motorway.net.xml"
ROUTE = ("e1", "e2", "e3", "e4")


@functools.cache
def curved() -> Road:
    return load_road(CURVED, ROUTE)


def test_round_trip_on_the_curved_motorway_within_a_nanometre() -> None:
    frame = curved().frame
    assert isinstance(frame, ArcFrame)
    rng = np.random.default_rng(3)
    s = rng.uniform(-150.0, frame.length + 150.0, 20_000)  # past both ends too
    d = rng.uniform(-20.0, 30.0, s.size)  # radii >= 700 m: far from any centre
    x, y, _ = frame.to_cartesian(s, d)
    s2, d2 = frame.to_frenet(x, y)  # no hint: every arc searched
    assert np.abs(s2 - s).max() < 1e-9
    assert np.abs(d2 - d).max() < 1e-9
    s3, d3 = frame.to_frenet(x, y, s_hint=s + rng.uniform(-6.0, 6.0, s.size))
    assert np.abs(s3 - s).max() < 1e-9 and np.abs(d3 - d).max() < 1e-9
    # and the other way round, from points anywhere near the road
    s4, d4 = frame.to_frenet(x + 0.3, y - 0.2)
    x5, y5, _ = frame.to_cartesian(s4, d4)
    assert np.abs(x5 - (x + 0.3)).max() < 1e-9 and np.abs(y5 - (y - 0.2)).max() < 1e-9


def test_scalars_in_scalars_out() -> None:
    frame = curved().frame
    x, y, h = frame.to_cartesian(1234.5, 5.625)
    assert all(isinstance(v, float) for v in (x, y, h))
    s, d = frame.to_frenet(x, y, s_hint=1230.0)
    assert (s, d) == pytest.approx((1234.5, 5.625), abs=1e-9)


def test_geometry_is_right_not_only_consistent_on_a_circle() -> None:
    """A SUMO-like polyline on a circle of radius 1000 m (a point every 10 m): d is the
    distance from the line, the heading its tangent, the curvature 1 / R."""
    R = 1000.0
    ang = np.linspace(-0.5 * math.pi, -0.5 * math.pi + 0.6, 61)
    poly = np.column_stack((R * np.cos(ang), R + R * np.sin(ang)))  # starts at (0, 0), +x
    frame = smooth(poly)
    s = np.linspace(50.0, frame.length - 50.0, 200)  # the smoothing's free ends apart
    for d in (-7.0, 0.0, 5.0):
        x, y, h = frame.to_cartesian(s, d)
        # radius R - d from the centre (0, R), within the polyline's chord sag (1.25 cm)
        assert np.abs(np.hypot(x, y - R) - (R - d)).max() < 0.0125
        # the heading is the tangent of the line d = const: its numerical derivative
        xa, ya, _ = frame.to_cartesian(s - 0.01, d)
        xb, yb, _ = frame.to_cartesian(s + 0.01, d)
        assert np.abs(np.angle(np.exp(1j * (np.arctan2(yb - ya, xb - xa) - h)))).max() < 1e-6
    # the least smoothing within 10 % of the best radius leaves a ripple at the vertices
    kappa = frame.curvature(s)
    assert np.abs(kappa - 1.0 / R).max() < 0.1 / R
    mean = np.mean(frame.curvature(np.arange(50.0, frame.length - 50.0, 0.25)))
    assert abs(mean - 1.0 / R) < 1e-6
    assert frame.quality.max_deviation < 0.02


def test_the_straight_shipped_road_is_the_identity_bit_for_bit() -> None:
    road = load_road(NETWORK_DIR / "highway.net.xml")
    frame = road.frame
    assert isinstance(frame, StraightFrame)
    assert (frame.x0, frame.y0) == (0.0, 0.0)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-100, 6100, 1000), rng.uniform(-5, 15, 1000)
    s, d = frame.to_frenet(x, y)
    assert np.array_equal(s, x) and np.array_equal(d, y)
    x2, y2, h = frame.to_cartesian(s, d)
    assert np.array_equal(x2, x) and np.array_equal(y2, y) and not h.any()
    assert [t.centre(100.0) for t in road.lanes] == [1.875, 5.625, 9.375]
    assert [t.speed_limit(3000.0) * 3.6 for t in road.lanes] == pytest.approx([90, 110, 120])
    assert road.s_of_lane_position("highway_1", 250.0) == 250.0


def _farthest(points: np.ndarray, line: np.ndarray) -> float:
    """m, the largest distance from `points` to the polyline through `line`'s points."""
    segments = shapely.linestrings(np.stack((line[:-1], line[1:]), axis=1))
    _, distance = shapely.STRtree(segments).query_nearest(
        shapely.points(points), return_distance=True, all_matches=False)
    return float(distance.max())


def test_lane_centres_stay_within_the_reported_deviation_of_sumo_lanes() -> None:
    road = curved()
    frame = road.frame
    assert frame.quality.max_deviation <= FrameLimits().max_deviation
    assert frame.quality.min_radius > 700.0  # lanes of R 790-1511 m
    for table in road.lanes:
        s = np.concatenate([np.linspace(a, b, max(2, math.ceil((b - a) / 0.25)))
                            for a, b in zip(table.s_start, table.s_end, strict=True)])
        x, y, _ = frame.to_cartesian(s, table.centre(s))
        ours = np.column_stack((x, y))
        sumo = shapely.segmentize(shapely.LineString(table.track.shape()), 0.25)
        # the Hausdorff distance of the two lines, both sampled every 0.25 m, half the
        # code's own step, SUMO's vertices kept (the distance between samples exceeds
        # theirs by well under 1 mm at these headings): each sample's distance to the
        # other line, through a tree of that line's segments
        measured = max(_farthest(ours, shapely.get_coordinates(sumo)),
                       _farthest(shapely.get_coordinates(sumo), ours))
        assert measured <= table.deviation + 1e-3, table.track.name
        assert table.deviation <= road.max_deviation <= 0.05


def test_lane_tables_follow_the_tracks_along_s() -> None:
    road = curved()
    t1, added = road.lane(1), road.lane(3)
    s_e3 = 0.5 * (added.begin + added.end)
    assert t1.piece_at(1000.0).lane == "e1_1" and t1.piece_at(s_e3).lane == "e3_2"
    assert t1.piece_at(4500.0).lane == "e4_1"
    assert t1.centre(s_e3) == pytest.approx(5.625)
    assert added.centre(s_e3) == pytest.approx(-1.875)  # right of the reference track
    assert added.bounds(s_e3) == pytest.approx((-3.75, 0.0))
    assert 3090 < added.begin < 3120 and 3880 < added.end < 3910
    assert not added.contains(3000.0) and added.contains(s_e3)
    assert road.lane(0).end == pytest.approx(road.frame.length)
    # SUMO's lane positions: 0 on the edge's first lane point
    assert road.s_of_lane_position("e1_0", 0.0) == pytest.approx(0.0, abs=1e-9)


def test_a_kink_that_cannot_be_smoothed_is_refused_naming_the_radius() -> None:
    a = math.radians(20.0)
    poly = [(-300.0, 0.0), (0.0, 0.0), (300.0 * math.cos(a), 300.0 * math.sin(a))]
    with pytest.raises(InputError) as err:
        smooth(poly, source="net.xml")
    text = str(err.value)
    assert text.startswith("net.xml: reference line radius = '")
    assert "at least 100 m within 0.2 m" in text and "\n" not in text
    # a looser bound takes it
    frame = smooth(poly, FrameLimits(max_deviation=2.0, min_stretch=0.75))
    assert frame.quality.min_radius >= 60.0 and frame.quality.max_deviation <= 2.0


def test_a_gentle_kink_is_smoothed_within_the_target() -> None:
    a = math.radians(1.0)
    poly = [(-300.0, 0.0), (0.0, 0.0), (300.0 * math.cos(a), 300.0 * math.sin(a))]
    frame = smooth(poly)
    q = frame.quality
    assert q.max_deviation <= FrameLimits().target_deviation
    assert q.min_radius >= 100.0 and q.smoothing_length > 0.0
    assert q.max_kink == pytest.approx(math.radians(1.0))  # SUMO's own kink


def test_werling_state_conversions_match_the_path_they_describe() -> None:
    """A path d(s) = 4 sin(s / 60) + 5 drawn in the curved frame: the formulas' heading,
    curvature and speed equal the Cartesian path's own (finite differences), and the
    inverse gives back (s, d, s_dot, d', d'')."""
    from cosim.road.frame import cartesian_state, frenet_state

    frame = curved().frame
    # through the S-bend, at the arcs' middles: a finite difference stays on one arc
    # (across a knot the arcs' curvature steps, and so does an offset path's ds-rate)
    k0 = int((1500.0 - frame.s_min) / frame.h)
    s = frame.s_min + frame.h * (np.arange(k0, k0 + 1400, 3) + 0.5)
    d, d1, d2 = 4 * np.sin(s / 60) + 5, 4 / 60 * np.cos(s / 60), -4 / 3600 * np.sin(s / 60)
    s_dot = np.full(s.shape, 30.0)
    x, y, theta, kappa, v = cartesian_state(frame, s, d, s_dot, d1, d2)
    e = 1e-3
    xa, ya, *_ = cartesian_state(frame, s - e, 4 * np.sin((s - e) / 60) + 5, s_dot, d1, d2)
    xb, yb, *_ = cartesian_state(frame, s + e, 4 * np.sin((s + e) / 60) + 5, s_dot, d1, d2)
    heading = np.arctan2(yb - ya, xb - xa)
    assert np.abs(np.angle(np.exp(1j * (heading - theta)))).max() < 1e-7
    # speed: |dp/ds| ds/dt
    assert np.abs(np.hypot(xb - xa, yb - ya) / (2 * e) * 30.0 - v).max() < 1e-5
    # curvature: the turn of the heading per metre of path
    sa, sb = s - 0.05, s + 0.05
    ha = cartesian_state(frame, sa, 4 * np.sin(sa / 60) + 5, s_dot, 4 / 60 * np.cos(sa / 60),
                         d2)[2]
    hb = cartesian_state(frame, sb, 4 * np.sin(sb / 60) + 5, s_dot, 4 / 60 * np.cos(sb / 60),
                         d2)[2]
    xa2, ya2, _ = frame.to_cartesian(sa, 4 * np.sin(sa / 60) + 5)
    xb2, yb2, _ = frame.to_cartesian(sb, 4 * np.sin(sb / 60) + 5)
    numeric = (hb - ha) / np.hypot(xb2 - xa2, yb2 - ya2)
    assert np.abs(numeric - kappa).max() < 1e-6
    back = frenet_state(frame, x, y, theta, kappa, v, s_hint=s)
    for got, want in zip(back, (s, d, s_dot, d1, d2), strict=True):
        assert np.abs(got - want).max() < 1e-9


def test_compiled_conversions_equal_the_interpreted_functions(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """numba's kernels give the interpreted functions' numbers, bit for bit (no fastmath);
    the interpreted kernel calls the interpreted helpers, as the compiled the compiled."""
    from cosim.road import frame as fr

    frame = curved().frame
    rng = np.random.default_rng(7)
    s = rng.uniform(-50.0, frame.length + 50.0, 300)
    d = rng.uniform(-10.0, 20.0, s.size)
    outs = [np.empty(s.size) for _ in range(6)]
    args = (frame.s_min, frame.h, frame.x, frame.y, frame.theta, frame.kappa)
    fr._cartesian(s, d - frame.d_offset, *args, *outs[:3])
    fr._cartesian.py_func(s, d - frame.d_offset, *args, *outs[3:])
    for a, b in zip(outs[:3], outs[3:], strict=True):
        assert np.array_equal(a, b)
    x, y = outs[0] + 0.1, outs[1] - 0.1
    hints = np.where(np.arange(s.size) % 3 == 0, np.nan, s + 2.0)
    res = [np.empty(s.size) for _ in range(4)]
    tables = (frame.s_min, frame.h, frame.x, frame.y, frame._cos, frame._sin, frame.kappa)
    fr._frenet(x, y, hints, fr.WINDOW, *tables, res[0], res[1])
    for name in ("_local", "_covers", "_walk", "_scan", "_nearest_knot"):
        monkeypatch.setattr(fr, name, getattr(fr, name).py_func)  # interpreted helpers
    fr._frenet.py_func(x, y, hints, fr.WINDOW, *tables, res[2], res[3])
    assert np.array_equal(res[0], res[2]) and np.array_equal(res[1], res[3])


@pytest.mark.parametrize("where", ["curved_motorway", "tight_bend"])
def test_a_body_drawn_in_s_d_is_within_the_distortion_margin_of_its_true_image(
        where: str) -> None:
    """Cartesian rectangles (the car, random poses, headings +-0.3 rad off the road),
    their outlines mapped into (s, d): every point lies inside the same rectangle drawn
    in (s, d) grown by distortion_margin (and the margin is not loose by 3x)."""
    from cosim.road.frame import distortion_margin, kappa_max

    if where == "curved_motorway":
        frame, s_range, d_range = curved().frame, (1400.0, 2500.0), (-5.0, 15.0)
    else:  # a 60 m radius bend (a ramp's), drawn as SUMO would (a point every 2 m)
        ang = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 95)
        poly = np.column_stack((60.0 * np.cos(ang), 60.0 + 60.0 * np.sin(ang)))
        frame = smooth(poly, FrameLimits(min_radius=50.0), reach=7.5)
        s_range, d_range = (20.0, frame.length - 20.0), (-8.0, 12.0)
    L, W = 4.32, 1.8
    r = 0.5 * math.hypot(L, W)
    rng = np.random.default_rng(11)
    u = np.linspace(-0.5, 0.5, 41)
    outline = np.concatenate([np.column_stack((u * L, np.full_like(u, sgn * W / 2)))
                              for sgn in (-1, 1)] +
                             [np.column_stack((np.full_like(u, sgn * L / 2), u * W))
                              for sgn in (-1, 1)])
    worst_ratio = 0.0
    for _ in range(300):
        s0, d0 = rng.uniform(*s_range), rng.uniform(*d_range)
        rel = rng.uniform(-0.3, 0.3)  # heading relative to the road
        x0, y0, h0 = frame.to_cartesian(s0, d0)
        c, sn = math.cos(h0 + rel), math.sin(h0 + rel)
        px = x0 + c * outline[:, 0] - sn * outline[:, 1]
        py = y0 + sn * outline[:, 0] + c * outline[:, 1]
        ps, pd = frame.to_frenet(px, py, s_hint=s0)
        # the same rectangle in (s, d): centre (s0, d0), heading rel
        du, dw = ps - s0, pd - d0
        lu = math.cos(rel) * du + math.sin(rel) * dw
        lw = -math.sin(rel) * du + math.cos(rel) * dw
        outside = float(np.max(np.maximum(np.abs(lu) - L / 2, np.abs(lw) - W / 2)))
        margin = distortion_margin(kappa_max(frame, s0 - 2 * r, s0 + 2 * r),
                                   abs(d0 - frame.d_offset), r)
        assert outside <= margin, (s0, d0, rel, outside, margin)
        worst_ratio = max(worst_ratio, outside / margin)
    assert worst_ratio > 1 / 3  # the bound is not empty talk: the distortion is real
    print(f"{where}: largest distortion / margin {worst_ratio:.2f}")


@pytest.mark.parametrize(("jog", "deviation"), [((499.95, 0.01), 0.006),  # 5 cm overlap
                                                ((499.5, 0.3), 0.151),  # back and aside
                                                ((500.5, 0.3), 0.15)])  # a 31-degree jog
def test_lanes_that_overlap_or_jog_at_a_junction_are_smoothed(
        jog: tuple[float, float], deviation: float) -> None:
    """SUMO's next lane may start a little behind (or aside of) the end of the one
    before: no loop in the frame, the deviation about half the jog."""
    poly = [(0.0, 0.0), (500.0, 0.0), jog, (1000.0, jog[1])]
    frame = smooth(poly)
    assert frame.quality.max_deviation <= deviation
    assert frame.quality.min_radius >= FrameLimits().min_radius
    assert frame.length == pytest.approx(1000.0, abs=0.01)
    s = np.linspace(0.0, frame.length, 500)
    x, _, _ = frame.to_cartesian(s, 0.0)
    assert np.all(np.diff(x) > 0)  # runs forwards all along


def test_one_point_kernels_equal_the_array_conversions() -> None:
    """pose_in_frame / point_of_frame (the controller's per-sample conversions) give what
    to_frenet / to_cartesian / heading / curvature give, to 1e-9."""
    from cosim.road.frame import point_of_frame, pose_in_frame

    frame = curved().frame
    fp, fr = frame.packed()
    rng = np.random.default_rng(11)
    s = rng.uniform(0.0, frame.length, 300)
    d = rng.uniform(-4.0, 12.0, 300)
    x, y, heading = frame.to_cartesian(s, d)
    for i in range(s.size):
        s1, d1, h1, k1 = pose_in_frame(fp, fr, x[i], y[i], math.nan)
        assert abs(s1 - s[i]) < 1e-9 and abs(d1 - d[i]) < 1e-9
        assert abs(h1 - float(frame.heading(s1))) < 1e-9
        assert k1 == float(frame.curvature(s1))
        # with a hint 30 m off the search still lands on the right arc
        s2, _, _, _ = pose_in_frame(fp, fr, x[i], y[i], s[i] + 30.0)
        assert abs(s2 - s[i]) < 1e-9
        x1, y1, h2, _ = point_of_frame(fp, fr, s[i], d[i])
        assert math.hypot(x1 - x[i], y1 - y[i]) < 1e-9 and abs(h2 - heading[i]) < 1e-9


def test_one_point_kernels_on_the_straight_road_are_the_identity_bit_for_bit() -> None:
    from cosim.road.frame import point_of_frame, pose_in_frame

    fp, fr = StraightFrame(0.0, 0.0, 1000.0).packed()
    for x, y in ((12.5, 1.875), (-0.0, -0.0), (1e5, -3.3)):
        s, d, h, k = pose_in_frame(fp, fr, x, y, math.nan)
        assert (s, d, h, k) == (x, y, 0.0, 0.0)
        assert math.copysign(1.0, s) == math.copysign(1.0, x)
        px, py, _, _ = point_of_frame(fp, fr, x, y)
        assert (px, py) == (x, y) and math.copysign(1.0, px) == math.copysign(1.0, x)


def _arc_polyline(radius: float, step: float, length: float) -> np.ndarray:
    """Vertices every `step` m on an arc of `radius` between two 300 m straights."""
    a = np.arange(0.0, length + 1e-9, step) / radius
    arc = np.column_stack([radius * np.sin(a), radius * (1.0 - np.cos(a))])
    end, h = arc[-1], a[-1]
    return np.vstack([[-300.0, 0.0], arc, end + 300.0 * np.array([np.cos(h), np.sin(h)])])


def test_polyline_radius_is_the_radius_the_vertices_lie_on() -> None:
    assert polyline_radius(_arc_polyline(1200.0, 60.0, 1500.0)) == pytest.approx(1200.0,
                                                                                rel=1e-3)
    a = math.radians(1.0)  # one kink between straights implies no curve
    assert polyline_radius(np.array([(-300.0, 0.0), (0.0, 0.0),
                                     (300.0 * math.cos(a), 300.0 * math.sin(a))])) == math.inf


def test_a_curve_drawn_every_60_m_is_smoothed_towards_its_own_radius() -> None:
    # an OSM-style R 1200 m curve, a node every 60 m (2.9 degree kinks): within the 5 cm
    # target the line keeps R ~170 m at every vertex, within 0.2 m R ~460 m; it spends
    # up to coarse_deviation to bend as the curve does, off SUMO's chords by their sagitta
    # (0.375 m on the circle through the vertices)
    poly = _arc_polyline(1200.0, 60.0, 1500.0)
    target = FrameLimits().target_deviation
    tight = smooth(poly, FrameLimits(max_deviation=target, coarse_deviation=target))
    near = smooth(poly, FrameLimits(coarse_deviation=FrameLimits().max_deviation))
    frame = smooth(poly)
    assert tight.quality.min_radius < 200.0
    assert 400.0 < near.quality.min_radius < 600.0 and not near.quality.coarse
    assert frame.quality.min_radius > 0.85 * 1200.0 and frame.quality.coarse
    assert frame.quality.max_deviation <= FrameLimits().coarse_deviation
    # a curve drawn finely is left as it was (the shipped motorway: 10 m vertices)
    fine = smooth(_arc_polyline(800.0, 10.0, 1000.0))
    assert fine.quality.max_deviation <= FrameLimits().target_deviation


def test_a_junctions_jog_is_smoothed_to_the_radius_the_speed_limit_needs() -> None:
    """Two straights joined by a 22 cm jog over 4.4 m (2.9-degree kinks, as on SUMO's
    Bremen motorway where its lanes change edges): within the 5 cm target the line
    bends at R ~140 m there; for a 160 km/h limit (R 988 m at 2 m/s^2) it spends up
    to max_deviation instead. Without a speed limit the line is as before."""
    a = math.radians(2.9)
    poly = np.array([(-300.0, 0.0), (0.0, 0.0), (4.4 * math.cos(a), 4.4 * math.sin(a)),
                     (304.4, 4.4 * math.sin(a))])
    plain = smooth(poly)
    frame = smooth(poly, speed_limit=160.0 / 3.6)
    assert plain.quality.min_radius < 200.0
    wanted = (160.0 / 3.6) ** 2 / FrameLimits().limit_lat_accel
    assert frame.quality.min_radius >= 0.9 * wanted
    assert frame.quality.max_deviation <= FrameLimits().max_deviation
    assert not frame.quality.coarse


def test_the_curved_motorway_is_smoothed_over_its_vertex_spacing() -> None:
    """SUMO draws the curved motorway's lanes with a vertex every 10 m; smoothing over
    less (the least that reaches the radius: 2.8 m) left the curvature rippling by
    +-10 % between vertices. Smoothed over at least the spacing, within the target
    deviation, it is steady along a curve (R ~790 m, s 1400-1650: within 1 %)."""
    road = curved()
    q = road.frame.quality
    assert q.smoothing_length >= 10.0
    assert q.max_deviation <= FrameLimits().target_deviation
    kappa = road.frame.curvature(np.arange(1400.0, 1650.0, 0.5))
    assert np.abs(kappa / kappa.mean() - 1.0).max() < 0.01


def test_the_scene_view_equals_the_conversions_it_stands_for_bit_for_bit() -> None:
    """ArcFrame.view (one compiled pass) gives what to_frenet, tangent and the stretch q
    give, value for value, NaN for a point off the road; a float's arc is found with
    math as the array's with numpy."""
    from cosim.traffic.road_view import stretch

    frame = curved().frame
    rng = np.random.default_rng(4)
    s0, d0 = rng.uniform(0.0, 4800.0, 300), rng.uniform(-2.0, 13.0, 300)
    x, y, theta = frame.to_cartesian(s0, d0)
    x, y = np.append(x, 1e6), np.append(y, 1e6)
    heading = np.append(theta + rng.uniform(-0.3, 0.3, 300), 0.0)
    for hint in (2000.0, None):
        s, d = frame.to_frenet(x, y, s_hint=hint)
        th, kappa = frame.tangent(s)
        rel = (heading - th + np.pi) % (2.0 * np.pi) - np.pi
        want = (s, d, rel, stretch(frame, s, d, kappa))
        for got, expected in zip(frame.view(x, y, heading, hint), want, strict=True):
            assert np.array_equal(got, expected, equal_nan=True)
    for s in np.concatenate((s0, [frame.s_min, frame.s_max, -1e9, 1e9])):
        assert frame.curvature(float(s)) == frame.curvature(np.array(s))
        assert frame.heading(float(s)) == frame.heading(np.array(s))


def test_a_sideways_step_is_refused_where_the_line_first_leaves_the_lane() -> None:
    """Lanes that jump 4.8 m sideways over 4.8 m (SUMO's lanes re-spread at a junction):
    even the unsmoothed line cannot follow within 0.2 m, and it stays off downstream,
    so the refusal names the step, not the far end where the line lies furthest off."""
    poly = [(0.0, 0.0), (1000.0, 0.0), (1000.0, 4.8), (1900.0, 4.8), (2000.0, 10.0)]
    with pytest.raises(InputError) as err:
        smooth(poly, source="net.xml", where=lambda x, y: f"where {x:.0f}")
    text = str(err.value)
    assert err.value.key == "reference line deviation" and "\n" not in text
    assert "within 0.2 m of SUMO's lane shape" in text
    # at one of the step's two corners
    assert re.search(r"turns by 90 degrees, near x = 1000\.0, y = (0\.0|4\.8), where 1000\)$",
                     text), text


@pytest.fixture(scope="module")
def c343(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """3 -> 4 -> 3 lanes (AB, BC 300 m, CD) as netconvert connects them with the lanes
    centred on each edge (spreadType "center"): every lane steps half a lane (1.6 m)
    sideways through each junction's 8 m."""
    sys.path.insert(0, str(Path(__file__).parent))
    from handdrawn import netconvert

    edges = "".join(f'<edge id="{e}" from="{a}" to="{b}" numLanes="{n}" speed="33.3" '
                    'spreadType="center"/>'
                    for e, a, b, n in (("AB", "A", "B", 3), ("BC", "B", "C", 4),
                                       ("CD", "C", "D", 3)))
    return netconvert(tmp_path_factory.mktemp("c343"),
                      '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
                      '<node id="C" x="1300" y="0"/><node id="D" x="2300" y="0"/></nodes>',
                      f"<edges>{edges}</edges>", name="c343")


def test_lanes_re_spread_at_a_lane_count_change_shift_the_frame_sideways(c343: Path) -> None:
    """Where SUMO's lanes step sideways at a junction the frame's line shifts with them,
    over as long as a curve of the radius the speed limit needs (33.3 m/s at 2 m/s^2:
    R 555 m, 72 m for the 1.6 m step), so that every lane keeps its d and lies on SUMO's
    lane away from the step, half the step off it at the junction."""
    road = load_road(c343, ["AB", "BC", "CD"])
    frame = road.frame
    assert isinstance(frame, ArcFrame)
    assert [sh.jump for sh in road.shifts] == pytest.approx([1.6, -1.6], abs=1e-6)
    assert [sh.s for sh in road.shifts] == pytest.approx([1000.0, 1300.0], abs=0.1)
    assert [sh.length for sh in road.shifts] == pytest.approx([71.6, 71.6], abs=0.1)
    # the shift bends the line no tighter than the speed limit needs, its curvature
    # continuous (a quintic smootherstep: it changes by at most 60 x 1.6 m / L^3 per m)
    assert frame.quality.min_radius >= 0.99 * 33.3**2 / 2.0
    assert np.abs(np.diff(frame.kappa)).max() <= 1.02 * 0.5 * 60.0 * 1.6 / 71.6**3
    # the through lanes keep their d; away from the steps within a micrometre of SUMO's
    ref = road.lane(1)
    assert ref.track is road.reference
    assert np.all(ref.d_start == 1.6) and np.all(ref.d_end == 1.6)
    assert road.max_deviation < 1e-5
    y = {s: frame.to_cartesian(s, 1.6)[1] for s in (900.0, 964.2, 1000.0, 1035.8, 1200.0)}
    assert y[900.0] == pytest.approx(0.0, abs=1e-6)  # AB_1 at y = 0
    assert y[964.2] == pytest.approx(0.0, abs=1e-3)  # the shift begins
    assert y[1000.0] == pytest.approx(0.8, abs=0.01)  # half the step at the junction
    assert y[1035.8] == pytest.approx(1.6, abs=1e-3)  # BC_2 at y = 1.6
    assert y[1200.0] == pytest.approx(1.6, abs=1e-6)
    assert frame.length == pytest.approx(2300.0, abs=0.1)


@pytest.mark.sumo
def test_lanes_re_spread_at_a_lane_count_change_are_driven(c343: Path, tmp_path: Path) -> None:
    """The SV keeps its lane through the 1.6 m step at B (SUMO's lane centre within half
    the step), and changes lanes across it as on a straight road."""
    from cosim.run.loop import simulate
    from cosim.scenario.load import scenario_from_dict

    def run(**change: object) -> tuple[dict, dict]:
        sv = {"edge": "AB", "lane": 1, "position_m": 900.0, "speed_kmh": 110.0, **change}
        doc = {"scenario": {"name": "c343", "duration_s": 6.0, "seed": 1},
               "road": {"network": str(c343), "route": ["AB", "BC", "CD"], "mu": 0.6},
               "sv": sv}
        result = simulate(scenario_from_dict(doc, path=tmp_path / "c343.toml"))
        assert {"AB", "BC"} <= set(result.edges)  # through the junction
        assert result.metrics["collisions"] == 0 and result.metrics["sumo_events"] == 0
        return result.metrics, result.trace

    m, tr = run()
    assert float(np.max(np.abs(tr["ye_m"]))) < 1e-3  # measured 0.3 mm
    assert 0.5 < m["lane_keeping_max_offset_m"] < 0.8  # measured 0.62 m, at the step
    m, tr = run(lane_changes=[{"at_s": 0.5, "direction": "left"}])
    assert m["lane_change_completed"] == 1 and m["final_lane"] == 2
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.01  # measured 3.1 mm
