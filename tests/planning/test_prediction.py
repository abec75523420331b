"""TV futures from V2V messages: C1, C2, C3."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.params import RoadParams, VehicleParams, kmh
from cosim.planning.envelope import stable_set
from cosim.planning.prediction import (
    LEADER_SPEED_STEP,
    C2Options,
    c2_lanes,
    category,
    predict,
    predict_lazy,
)
from cosim.planning.trajectory import BoundaryConditions, LaneChangeTrajectory
from cosim.traffic.v2v import LateralMotion, V2VMessage

ROAD = RoadParams(mu=0.8)
VEH = VehicleParams()
GRID = np.arange(1.0, 10.0001, 0.05)
T_REL = np.arange(0.0, 12.0001, 0.05)


def msg(vid: str = "tv", *, t: float = 0.0, x: float = 50.0, lane: int = 1, speed: float = 25.0,
        accel: float = 0.0, intention: int = 0, motion: LateralMotion | None = None,
        y: float | None = None, lateral_speed: float = 0.0) -> V2VMessage:
    yy = ROAD.lane_center(lane) if y is None else y
    return V2VMessage(vid, t, x, yy, 0.0, speed, accel, lane, lateral_speed, 4.32, 1.8,
                      intention, motion)


def test_c1_constant_acceleration_stops_at_zero_speed() -> None:
    f = predict([msg(speed=10.0, accel=-2.0)], 0.0, T_REL, ROAD, VEH, GRID)
    assert f.categories == ("C1",)
    x = f.x[0]
    # stops after 5 s, 25 m further, and stays
    assert x[T_REL == 2.0][0] == pytest.approx(50 + 20 - 4)
    assert x[-1] == pytest.approx(75.0)
    assert np.all(np.diff(x) >= -1e-12)
    np.testing.assert_allclose(f.y[0], ROAD.lane_center(1))


def test_c1_message_latency_is_projected_to_now() -> None:
    f = predict([msg(t=-0.5, speed=20.0, accel=1.0)], 0.0, T_REL, ROAD, VEH, GRID)
    assert f.x[0, 0] == pytest.approx(50 + 20 * 0.5 + 0.5 * 0.25)


def test_c2_is_the_tvs_whole_stable_cluster() -> None:
    m = msg(speed=kmh(120), lane=2, intention=-1)
    f = predict([m], 0.0, T_REL, ROAD, VEH, GRID)
    assert f.categories == ("C2",)
    st = stable_set(BoundaryConditions(kmh(120), kmh(110), -ROAD.lane_width), GRID, ROAD.mu, VEH)
    # one hypothesis per stable grid point, after a lower bound of tau_min (without the
    # planner's maps: the grid point below the first stable one); all bound cells
    np.testing.assert_allclose(f.tau[1:], GRID[st.stable])
    assert f.tau[0] == GRID[np.flatnonzero(st.stable)[0] - 1] < st.tau_min
    assert f.n_hypotheses == st.stable.sum() + 1 > 100
    cell = predict_lazy([m], 0.0, T_REL, ROAD, VEH, GRID).cell
    assert cell[:-1].all() and not cell[-1]
    np.testing.assert_allclose(f.x[:, 0], 50.0)
    np.testing.assert_allclose(f.y[:, -1], ROAD.lane_center(1), atol=1e-9)  # all end in lane 1
    # the band rule: a decelerating change ends at the target lane's maximum, 110 km/h
    end_speed = (f.x[:, -1] - f.x[:, -2]) / (T_REL[-1] - T_REL[-2])
    np.testing.assert_allclose(end_speed, kmh(110), rtol=1e-9)
    np.testing.assert_allclose(f.t_end, f.tau)


def test_c2_off_the_road_is_c1_and_crossed_line_targets_current_lane() -> None:
    assert c2_lanes(msg(lane=2, intention=1), ROAD) is None
    f = predict([msg(lane=2, intention=1)], 0.0, T_REL, ROAD, VEH, GRID)
    assert f.categories == ("C1",)
    # moving left, already past the line into lane 2 (right of its centre): heads for lane 2
    y = ROAD.lane_center(2) - 1.0
    assert c2_lanes(msg(y=y, intention=1), ROAD) == (1, 2)
    assert c2_lanes(msg(lane=1, intention=1), ROAD) == (1, 2)


def test_c3_follows_the_broadcast_reference() -> None:
    mo = LateralMotion(t0=-1.5, tau=4.0, x0=10.0, y0=ROAD.lane_center(0), vx0=kmh(80),
                       vxf=kmh(90), width=ROAD.lane_width)
    f = predict([msg(motion=mo, intention=1, lane=0)], 0.0, T_REL, ROAD, VEH, GRID)
    assert f.categories == ("C3",)
    ref = LaneChangeTrajectory(-1.5, 4.0, 10.0, ROAD.lane_center(0), kmh(80), kmh(90),
                               ROAD.lane_width)
    x, y = ref.position(T_REL)
    np.testing.assert_allclose(f.x[0], x, atol=1e-9)
    np.testing.assert_allclose(f.y[0], y, atol=1e-9)
    np.testing.assert_allclose(f.heading[0], ref.heading(T_REL), atol=1e-12)
    assert f.t_end[0] == pytest.approx(2.5)


def test_c3_under_way_is_its_trajectory_to_the_last_bit() -> None:
    """A broadcast that starts under way (a rescue: lateral speed, accelerations) is kept
    as rows: its trajectory's own positions and heading, the same when predicted again."""
    mo = LateralMotion(t0=-0.7, tau=3.6, x0=10.0, y0=ROAD.lane_center(0) + 0.4,
                       vx0=kmh(80), vxf=kmh(85), width=ROAD.lane_width - 0.4, ax0=0.3,
                       vy0=0.35, ay0=-0.1)
    ref = LaneChangeTrajectory(-0.7, 3.6, 10.0, ROAD.lane_center(0) + 0.4, kmh(80), kmh(85),
                               ROAD.lane_width - 0.4, 0.3, 0.35, -0.1)
    x, y = ref.position(T_REL)
    xd, yd = ref.derivative(T_REL, 1)
    for _ in range(2):
        f = predict_lazy([msg(motion=mo, intention=1, lane=0)], 0.0, T_REL, ROAD, VEH, GRID)
        assert f.categories == ("C3",) and f.row_of[0] == 0
        for got, want in ((f.sx[0], x), (f.sy[0], y), (f.sh[0], np.arctan2(yd, xd))):
            assert got.tobytes() == want.tobytes()


def test_c3_linear_profile() -> None:
    mo = LateralMotion(t0=0.0, tau=3.0, x0=0.0, y0=1.875, vx0=20.0, vxf=20.0, width=3.75,
                       profile="linear")
    f = predict([msg(motion=mo, intention=1, lane=0)], 0.0, T_REL, ROAD, VEH, GRID)
    i = np.searchsorted(T_REL, 1.5)
    assert f.y[0, i] == pytest.approx(1.875 + 3.75 / 2)
    assert f.heading[0, i] == pytest.approx(np.arctan2(1.25, 20.0))
    assert f.y[0, -1] == pytest.approx(5.625) and f.heading[0, -1] == 0.0


def test_categories() -> None:
    assert category(msg()) == "C1"
    assert category(msg(intention=-1)) == "C2"
    mo = LateralMotion(0, 3, 0, 0, 20, 20, 3.75)
    assert category(msg(intention=1, motion=mo)) == "C3"


def test_c2_under_the_gap_policy_ends_no_faster_than_its_target_lane_leader() -> None:
    """S3 with the gap policy: a C2 TV plans as our SV does, into a gap at its leader's
    speed; the paper's band rule would take it from 10 to 31 m/s inside a 10 m/s queue."""
    tv = msg("tv", x=50.0, lane=1, speed=10.0, intention=1)
    ahead = msg("ahead", x=90.0, lane=2, speed=12.0)
    far = msg("far", x=500.0, lane=2, speed=5.0)  # beyond TV_LEADER_RANGE
    own = msg("own", x=60.0, lane=1, speed=3.0)  # its own lane's leader does not count

    def end_speed(messages: list[V2VMessage], gap: bool) -> np.ndarray:
        f = predict_lazy(messages, 0.0, T_REL, ROAD, VEH, GRID,
                         C2Options(gap_end_speed=gap)).materialise()
        rows = f.owner == 0
        return (f.x[rows, -1] - f.x[rows, -2]) / (T_REL[-1] - T_REL[-2])

    np.testing.assert_allclose(end_speed([tv, ahead, far, own], True), 12.0, rtol=1e-9)
    # a leader's speed is taken down to the LEADER_SPEED_STEP grid (one tau_min map each)
    odd = msg("ahead", x=90.0, lane=2, speed=12.0 + 0.9 * LEADER_SPEED_STEP)
    np.testing.assert_allclose(end_speed([tv, odd, far, own], True), 12.0, rtol=1e-9)
    np.testing.assert_allclose(end_speed([tv, far, own], True), ROAD.target_speed(1, 2), rtol=1e-9)
    np.testing.assert_allclose(end_speed([tv, ahead, far, own], False), ROAD.target_speed(1, 2),
                               rtol=1e-9)


def test_moving_c2_kept_for_the_instant_gives_the_fresh_numbers() -> None:
    """A C2 TV already moving laterally, predicted again at the same instant (a fleet's
    AVs checking together) on a shorter or a longer grid: its rows and its envelope's
    stable mask are those a fresh prediction computes, to the last bit."""
    import cosim.planning.planner as planner_module
    import cosim.planning.prediction as prediction_module
    from cosim.params import PlannerConfig

    options = planner_module.LaneChangePlanner(VEH, ROAD, PlannerConfig()).c2_options()
    moving = [msg("a", lane=2, intention=-1, lateral_speed=-0.4, y=ROAD.lane_center(2) - 0.3),
              msg("b", x=80.0, lane=0, intention=1, lateral_speed=0.2, speed=20.0)]

    def fresh(t_rel: np.ndarray) -> tuple[np.ndarray, ...]:
        prediction_module._MOVING.clear()
        planner_module._TV_ENVELOPES.clear()
        f = predict_lazy(moving, 3.0, t_rel, ROAD, VEH, GRID, options)
        return f.tau, f.sx, f.sy, f.sh

    long, short = fresh(T_REL), fresh(T_REL[:90])  # short kept: long replaces it
    for t_rel, want in ((T_REL, long), (T_REL[:90], short), (T_REL, long)):
        f = predict_lazy(moving, 3.0, t_rel, ROAD, VEH, GRID, options)  # kept from before
        assert f.tau.size > 10 and f.categories == ("C2", "C2")
        for got, expected in zip((f.tau, f.sx, f.sy, f.sh), want, strict=True):
            assert got.tobytes() == expected.tobytes()
    assert prediction_module._MOVING and planner_module._TV_ENVELOPES
