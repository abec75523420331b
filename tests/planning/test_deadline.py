"""Lanes that end (cosim.planning.deadline): which lane continues, when the mandatory
change is due, the planner's deadline on the SV's plans and the C2 prediction of a TV
that must merge. Hand-made roads: an acceleration lane at d < 0 (lane 0,
y_right = -lane width) beside a three-lane mainline, and lane drops."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cosim.params import PlannerConfig, RoadParams, VehicleParams
from cosim.planning.deadline import (
    END_MARGIN,
    LOOK_FORWARD,
    LOOKAHEAD_LEFT,
    MIN_GAP,
    continuing_lane,
    end_ahead,
    ends_ahead,
    fit_speed,
    look_ahead,
    merging_messages,
)
from cosim.planning.planner import (
    LANE_END,
    LaneChangePlanner,
    SVPlanState,
    path_curvature,
    peak_accel,
)
from cosim.planning.prediction import predict
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.traffic.v2v import V2VMessage

BANDS = ((60 / 3.6, 90 / 3.6),) * 4
END = 200.0
RAMP = RoadParams(mu=0.8, y_right=-3.75, speed_bands=BANDS, lane_ends=(END,))
VEH = VehicleParams()
GRID = np.arange(1.0, 10.0001, 0.05)
T_REL = np.arange(0.0, 14.0001, 0.05)
INF = math.inf
PLANNER = LaneChangePlanner(VEH, RAMP, PlannerConfig())


def msg(vid: str, x: float, lane: int, speed: float = 20.0, intention: int = 0,
        road: RoadParams = RAMP) -> V2VMessage:
    return V2VMessage(vid, 0.0, x, road.lane_center(lane), 0.0, speed, 0.0, lane, 0.0, 4.32,
                      1.8, intention)


@pytest.mark.parametrize(("ends", "lane", "expected"), [
    ((200.0, INF, INF, INF), 0, (1, 1)),  # acceleration lane: into the mainline
    ((200.0, INF, INF, INF), 1, None),  # the mainline runs on
    ((INF, INF, 500.0), 2, (1, 1)),  # the left lane drops: to the right
    ((300.0, 300.0, INF), 0, (1, 2)),  # two lanes end: towards the one that runs on
    ((INF, 300.0, INF), 1, (0, 1)),  # a middle lane ends: the right one on a tie
    ((300.0, 300.0), 0, None),  # nothing runs on past it
])
def test_the_continuing_lane_is_towards_the_nearest_lane_that_runs_on(
        ends: tuple[float, ...], lane: int, expected: tuple[int, int] | None) -> None:
    assert continuing_lane(ends, lane) == expected


def test_the_look_ahead_is_lc2013s() -> None:
    # laDist = v 10 s (x2 to the left) + 2 (length + minGap), per lane to cross
    assert LOOK_FORWARD == 10.0 and LOOKAHEAD_LEFT == 2.0 and MIN_GAP == 2.5
    assert float(look_ahead(20.0, 5.0, True, 1)) == pytest.approx(20 * 10 * 2 + 2 * 7.5)
    assert float(look_ahead(20.0, 5.0, False, 2)) == pytest.approx(2 * (200 + 15))
    end = end_ahead((END, INF, INF, INF), 0, 100.0, 20.0, 4.32)
    assert end is not None and (end.lane, end.target) == (0, 1)
    assert end.remaining == pytest.approx(END - 100.0 - 2.16)
    assert end.due and 0.0 < end.urgency < 1.0
    assert end.urgency == pytest.approx(1.0 - end.remaining / end.horizon)
    far = end_ahead((5000.0, INF), 0, 0.0, 20.0, 4.32)
    assert far is not None and not far.due and far.urgency == 0.0
    assert end.x_limit(4.32) == pytest.approx(END - END_MARGIN - 2.16)
    assert fit_speed(30.0, 2.0, 4.0) == pytest.approx(13.0)  # (2 + 13) / 2 * 4 = 30 m
    assert fit_speed(1.0, 2.0, 4.0) == 0.0


def sv_state(x: float, speed: float) -> SVPlanState:
    return SVPlanState(x=x, y=RAMP.lane_center(0), heading=0.0, vx=speed, ax=0.0, vy=0.0,
                       ay=0.0, lane=0)


def test_the_planner_drops_every_tau_that_ends_past_the_limit() -> None:
    planner = LaneChangePlanner(VEH, RAMP, PlannerConfig())
    sv = sv_state(100.0, 15.0)
    free = planner.plan(0.0, sv, 1, [], 0.5, vxf=15.0)
    assert free.late is None and free.tau is not None
    # a limit between two grid points below the free optimum
    x_limit = 100.0 + 15.0 * 3.02
    plan = planner.plan(0.0, sv, 1, [], 0.5, vxf=15.0, x_limit=x_limit)
    assert plan.tau is not None and plan.trajectory is not None
    assert plan.tau <= 3.0 + 1e-9 < free.tau
    x_end = float(plan.trajectory.position(plan.t + plan.tau)[0])
    assert x_end <= x_limit + 1e-9
    # every stable tau past the limit is rejected as "lane end", none before it
    late = np.array([r.tau for r in plan.rejections if r.reason == LANE_END])
    assert late.min() == pytest.approx(3.05) and late.max() == pytest.approx(10.0)
    assert plan.collision_free[plan.taus <= 3.0 + 1e-9].sum() == (
        plan.stable[plan.taus <= 3.0 + 1e-9].sum()) > 0
    # boundary: the last tau allowed ends within the limit, the first rejected past it
    for tau, inside in ((3.0, True), (3.05, False)):
        tr = LaneChangeTrajectory(t0=0.0, tau=tau, x0=100.0, y0=sv.y, vx0=15.0, vxf=15.0,
                                  width=3.75)
        assert (float(tr.position(tau)[0]) <= x_limit) is inside


def test_a_tv_on_an_ending_lane_is_predicted_to_merge_before_the_end() -> None:
    # in its look-ahead, not signalling: it signals for lane 1 (C2); far from the end,
    # or on the mainline, nothing changes
    near, far, main = msg("ramp", 120.0, 0), msg("far", -600.0, 0), msg("main", 120.0, 1)
    out = merging_messages([near, far, main], RAMP, 0.0)
    assert [m.intention for m in out] == [1, 0, 0]
    assert merging_messages([near], RoadParams(), 0.0)[0].intention == 0  # no lane ends
    f = predict(out[:1], 0.0, T_REL, RAMP, VEH, GRID)
    assert f.categories == ("C2",)
    np.testing.assert_allclose(f.y[:, -1], RAMP.lane_center(1), atol=1e-9)
    # every listed duration ends with its front END_MARGIN before the lane's end
    k = np.searchsorted(T_REL, f.tau)
    x_end = f.x[np.arange(f.n_hypotheses), k]
    assert np.all(x_end + 2.16 + END_MARGIN <= END + 0.5)  # (the grid's 0.05 s step)
    # 78 m left at 20 m/s to the band rule's 16.7 m/s: nothing longer than 4.19 s
    longest = (END - END_MARGIN - 2.16 - 120.0) / (0.5 * (20.0 + 60 / 3.6))
    assert longest - 0.05 < f.tau.max() <= longest
    # on a road where the lane runs on, the same (signalling) TV may take all of them
    g = predict([msg("ramp", 120.0, 1, intention=1, road=RoadParams(mu=0.8))], 0.0, T_REL,
                RoadParams(mu=0.8), VEH, GRID)
    assert g.tau.max() == pytest.approx(10.0)


def test_a_tv_that_cannot_make_it_is_still_predicted_to_squeeze_in() -> None:
    # 10 m left: no stable duration ends in time; its whole cluster is kept
    m = msg("late", END - 12.0, 0, intention=1)
    f = predict([m], 0.0, T_REL, RAMP, VEH, GRID)
    assert f.categories == ("C2",) and f.tau.max() == pytest.approx(10.0)


def test_the_planner_sees_a_merging_tv_as_c2() -> None:
    planner = LaneChangePlanner(VEH, RAMP, PlannerConfig())
    sv = SVPlanState(x=100.0, y=RAMP.lane_center(1), heading=0.0, vx=20.0, ax=0.0, vy=0.0,
                     ay=0.0, lane=1)
    plan = planner.plan(0.0, sv, 2, [msg("ramp", 110.0, 0)], 0.5)
    assert plan.categories == {"ramp": "C2"}


def test_max_curvature_leaves_only_paths_a_car_can_steer() -> None:
    # from 1 m/s (a standstill at the stop line) to 9 m/s: the envelope allows 2.1 s on,
    # whose paths bend at up to 1/m; with 0.2 1/m only the long ones are stable
    planner = LaneChangePlanner(VEH, RAMP, PlannerConfig())
    sv = sv_state(150.0, 1.0)
    free = planner.plan(0.0, sv, 1, [], 0.5, vxf=3.0)
    bent = planner.plan(0.0, sv, 1, [], 0.5, vxf=3.0, max_curvature=0.2)
    kappa = path_curvature(sv, 3.0, 3.75, free.taus)
    assert kappa[free.stable].max() > 0.5
    np.testing.assert_array_equal(bent.stable, free.stable & (kappa <= 0.2))
    assert bent.tau is not None and kappa[np.isclose(bent.taus, bent.tau)][0] <= 0.2
    assert path_curvature(sv_state(0.0, 20.0), 20.0, 3.75, np.array([3.0]))[0] < 0.02


def test_max_accel_leaves_only_plans_that_speed_up_comfortably() -> None:
    # from 6 m/s to 20 m/s: eq. 2 peaks at 1.5 (vxf - vx0) / tau, 3.9 m/s^2 from 5.4 s on
    sv = sv_state(0.0, 6.0)
    free = PLANNER.plan(0.0, sv, 1, [], 0.5, vxf=20.0)
    gentle = PLANNER.plan(0.0, sv, 1, [], 0.5, vxf=20.0, max_accel=3.9)
    peak = peak_accel(6.0, 20.0, 0.0, free.taus)
    np.testing.assert_allclose(peak, 21.0 / free.taus)
    assert free.tau is not None and free.tau < 5.3
    np.testing.assert_array_equal(gentle.stable, free.stable & (peak <= 3.9 * (1 + 1e-6)))
    assert gentle.tau is not None and gentle.tau >= 21.0 / 3.9 - 1e-6
    # a start already accelerating peaks at its start; braking plans are never bound
    assert peak_accel(6.0, 6.0, 2.0, np.array([3.0]))[0] == pytest.approx(2.0)
    assert peak_accel(20.0, 6.0, 0.0, np.array([3.0]))[0] == 0.0


@settings(max_examples=25, deadline=None)
@given(x0=st.floats(0.0, 180.0), vx0=st.floats(1.0, 30.0), vxf=st.floats(1.0, 30.0),
       room=st.floats(5.0, 200.0))
def test_no_plan_ever_ends_past_its_limit(x0: float, vx0: float, vxf: float,
                                          room: float) -> None:
    plan = PLANNER.plan(0.0, sv_state(x0, vx0), 1, [], 0.5, vxf=vxf, x_limit=x0 + room)
    assert plan.late is not None
    if plan.trajectory is not None:
        tr = plan.trajectory
        assert float(tr.position(tr.t0 + tr.tau)[0]) <= x0 + room + 1e-6
    # exactly the stable taus whose end (eq. 2) lies past the limit are late
    x_end = x0 + 0.5 * (vx0 + vxf) * plan.taus
    np.testing.assert_array_equal(plan.late, plan.stable & (x_end > x0 + room + 1e-9))
    assert not (plan.collision_free & plan.late).any()


def test_a_lane_in_two_ends_nowhere_past_its_first_part() -> None:
    """From an on-ramp over an off-ramp: lane 0 is the acceleration lane to 200 m, then
    the deceleration lane from 400 m on (its begin past its end); lanes 1, 2 exit at 600
    m. A TV on lane 0 before 200 m merges left; one on lane 1 near 600 m, past the
    acceleration lane's end, is predicted to change right into the deceleration lane."""
    road = RoadParams(mu=0.8, speed_bands=BANDS[:3], lane_ends=(200.0, 600.0, 600.0),
                      lane_begins=(400.0, 100.0, 100.0))
    assert road.split_ends() == (200.0,)
    assert ends_ahead((200.0, 600.0, 600.0), (400.0, 100.0, 100.0), 250.0) == (
        math.inf, 600.0, 600.0)
    tvs = [msg("acc", 150.0, 0, road=road), msg("exit", 540.0, 1, road=road),
           msg("main", 150.0, 1, road=road)]
    out = merging_messages(tvs, road, 0.0)
    assert [m.intention for m in out] == [1, -1, 0]
