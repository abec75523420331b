"""How the gap policy keeps its merges gentle, on hand-made scenes without SUMO: the
slot's time gap to the new leader, the car following that settles after a merge (ACC
model), the reachability rule, the ranking of gaps, courtesy asked only when needed,
insisting only within b_safe, and the entry test."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cosim.driving.gap.decision import GapRules, Seeking, gap_decision, has_room
from cosim.driving.gap.geometry import (
    ChangeStart,
    GapConfig,
    OwnLane,
    TargetLane,
    choose_gap,
    entry_test,
    gap_cost,
    lane_gaps,
)
from cosim.driving.gap.policy import TIME_GAP
from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig, idm_acceleration
from cosim.driving.view import SVView, TrafficView
from cosim.params import RoadParams
from cosim.planning.interaction import FollowerModel, LaneTraffic

ROAD = RoadParams()  # lanes 0 / 1 / 2 at y = 1.875 / 5.625 / 9.375
GAP = GapConfig(horizon=20.0)  # gaps up to 20 s away (the default, 8 s, leaves some out)
KRAUSS = FollowerModel()
L = 4.32
RULES = GapRules(DecisionConfig(), GAP, KRAUSS)
START = ChangeStart(0.0, ROAD.lane_center(1), 25.0, L, 3.75)  # a change from lane 1 to 2


def target(xs: list[float], speeds: list[float], lane_speed: float) -> TargetLane:
    """A target lane of TVs at xs driving `speeds`, its open end at `lane_speed`."""
    n = len(xs)
    return TargetLane(LaneTraffic.of(xs, speeds, [L] * n, [True] * n), lane_speed)


def scene(xs: list[float], lanes: list[int], speeds: list[float]) -> TrafficView:
    n = len(xs)
    return TrafficView.arrays(xs, [ROAD.lane_center(k) for k in lanes], speeds, np.full(n, L),
                          np.full(n, 1.8))


def test_the_slot_leaves_at_least_the_headway_to_the_new_leader() -> None:
    for v in (15.0, 25.0, 31.8):
        gaps = lane_gaps(L, target([-200.0, 200.0], [v, v], v), GAP, KRAUSS)
        # the slot's front end: the SV's front at >= headway x v + min_gap behind the rear
        front_gap = gaps.front[1] - (gaps.hi[1] + 0.5 * L)
        assert front_gap / v >= GAP.headway - 1e-9
        assert front_gap / v < GAP.headway + 0.2  # and not much more at equal speeds
    # a faster SV needs more: what it must shed before it would close on the leader
    fast = lane_gaps(L, target([-200.0, 200.0], [25.0, 25.0], 25.0), GAP, KRAUSS)
    # not much shorter than what SUMO's own driver leaves (docs/tuned_constants.md)
    assert GAP.headway >= 0.6
    assert fast.hi[1] < 200.0 - 0.5 * L - 25.0 * GAP.headway


def test_the_sv_following_from_the_slot_brakes_within_the_comfort_limit() -> None:
    # the gap policy's car following (ACC model, SUMO's tau as its time gap) from the
    # slot's time gap at equal speeds
    cfg = DecisionConfig(idm_min_gap=2.5, idm_coolness=0.99, idm_time_gap=TIME_GAP)
    for v in (10.0, 20.0, 30.0):
        gap = GAP.min_gap + GAP.headway * v
        assert idm_acceleration(v, v + 3.0, gap, v, cfg) >= -GAP.comfort_decel
        # the plain IDM (the paper's rule) brakes harder there
        assert idm_acceleration(v, v + 3.0, gap, v, DecisionConfig(idm_min_gap=2.5)) < \
            idm_acceleration(v, v + 3.0, gap, v, cfg)
    # even 0.4 s behind a leader that keeps its speed: about b, not the IDM's 8 m/s^2
    assert idm_acceleration(30.0, 33.0, 12.0, 30.0, cfg) > -2.5
    assert idm_acceleration(30.0, 33.0, 12.0, 30.0, DecisionConfig(idm_min_gap=2.5)) <= -7.9
    # but a leader much slower close ahead still makes it brake hard
    assert idm_acceleration(30.0, 33.0, 10.0, 20.0, cfg) < -4.0


def test_a_gap_ahead_moving_at_the_sv_lane_limit_or_faster_is_not_chased() -> None:
    # one gap 60 m ahead in the target lane, moving at 31.8 m/s; the SV at 28 m/s may
    # drive 30.6 m/s in its own lane
    gaps = lane_gaps(L, target([-60.0, 160.0], [31.8, 31.8], 31.8), GAP, KRAUSS)
    free = choose_gap(SVView(0.0, 0.0, 28.0, L, 30.6), gaps, GAP, KRAUSS)
    assert free is not None and free.index == 1 and free.offset > 0.0  # it would chase it
    capped = choose_gap(SVView(0.0, 0.0, 28.0, L, 30.6), gaps, GAP, KRAUSS, OwnLane(max_speed=30.6))
    # held to 30.6 m/s it does not chase it (the only other gap, behind the follower,
    # is beyond its reach of 80 m: none at all)
    assert capped is None or capped.offset <= 0.0
    # a gap ahead that is slower than the limit is reached no sooner than the speed
    # difference allows
    slow = lane_gaps(L, target([-60.0, 160.0], [29.6, 29.6], 29.6), GAP, KRAUSS)
    a = choose_gap(SVView(0.0, 0.0, 28.0, L, 30.6), slow, GAP, KRAUSS, OwnLane(max_speed=30.6))
    b = choose_gap(SVView(0.0, 0.0, 28.0, L, 30.6), slow, GAP, KRAUSS)
    assert a is not None and b is not None
    if a.index == 1:
        assert a.reach_time >= a.offset / 1.0 - 1e-6 > b.reach_time


def test_gaps_rank_by_reach_time_and_what_they_cost() -> None:
    gaps = lane_gaps(L, target([-200.0, -100.0, 0.0, 100.0], [25.0] * 4, 25.0), GAP, KRAUSS)
    aim = np.array([-300.0, -150.0, -50.0, 50.0, 150.0])
    t = np.full(5, 4.0)
    cost = gap_cost(t, aim, 0.0, 25.0, L, gaps, GAP, KRAUSS)
    # at the same reach time a gap behind (the SV and its followers slow down) costs
    # more than one ahead
    assert cost[2] > cost[3]
    # a gap whose new follower would have to brake for the SV at its aim costs more
    near = gap_cost(np.array([4.0] * 5), np.array([-300.0, -150.0, -50.0, -95.0, 150.0]),
                    0.0, 25.0, L, gaps, GAP, KRAUSS)
    assert near[3] > cost[3] - (25.0 - 25.0)  # the follower term is >= 0
    far = gaps.rear[3] + 0.5 * L + 60.0
    close = gaps.rear[3] + 0.5 * L + 3.0
    c_far, c_close = gap_cost(np.array([4.0, 4.0]), np.array([far, close]), 0.0, 25.0, L,
                              _two(gaps, 3), GAP, KRAUSS)
    assert c_close > c_far
    # with nothing to brake for, the cost is the reach time: the first gap is taken
    alongside = lane_gaps(L, target([-120.0, 120.0], [25.0, 25.0], 25.0), GAP, KRAUSS)
    c = choose_gap(SVView(0.0, 0.0, 25.0, L, 25.0), alongside, GAP, KRAUSS, OwnLane(max_speed=25.0))
    assert c is not None and c.relation == "alongside" and c.reachable


def _two(gaps, j):  # noqa: ANN001, ANN202 - the same gap twice (two aims in it)
    from dataclasses import fields, replace

    return replace(gaps, **{f.name: np.repeat(getattr(gaps, f.name)[j:j + 1], 2)
                            for f in fields(gaps)})


def test_courtesy_is_asked_only_of_a_follower_without_room() -> None:
    lanes = LaneLayout(ROAD)
    # the SV (lane 1, 25 m/s) wants lane 2, whose traffic drives 22 m/s: a long gap
    # ahead of a TV just behind the SV
    close = scene([-6.0, 200.0], [2, 2], [22.0, 22.0])
    sv = SVView(0.0, ROAD.lane_center(1), 25.0, L, 30.0)
    assert not has_room(sv, close, 0, GAP, KRAUSS)
    d = gap_decision(sv, close, lanes, RULES, Seeking(wanted_lane=2))
    assert d.gap is not None and d.gap.follower == 0
    assert d.cooperate_with == 0  # it blocks the slot: asked to make room
    # the same TV 80 m back has room: nobody is asked
    roomy = scene([-80.0, 200.0], [2, 2], [22.0, 22.0])
    assert has_room(sv, roomy, 0, GAP, KRAUSS)
    d = gap_decision(sv, roomy, lanes, RULES, Seeking(wanted_lane=2))
    assert d.cooperate_with == -1
    assert math.isfinite(d.vxf)


def test_the_sv_insists_on_an_entry_only_when_told_and_within_b_safe() -> None:
    lanes = LaneLayout(ROAD)
    sv = SVView(0.0, ROAD.lane_center(1), 25.0, L, 25.0)
    # a TV 30 m behind in the target lane at the SV's speed: Krauss brakes at its decel
    # for an entry now (its secure gap is 27.5 m + what it closes): not within plan_decel,
    # and not even when insisting (below the follower's decel: never a brake at b at once)
    tight = scene([-30.0, 150.0], [2, 2], [25.0, 25.0])
    d = gap_decision(sv, tight, lanes, RULES, Seeking(wanted_lane=2))
    assert not d.plan_now
    assert GAP.plan_decel < GAP.insist_decel < KRAUSS.decel <= KRAUSS.b_safe
    d = gap_decision(sv, tight, lanes, RULES, Seeking(wanted_lane=2, insist=True))
    assert not d.plan_now
    # with a limit at its decel (SUMO's LC2013 asks that much) it would go
    bold = replace(RULES, gap=replace(GAP, insist_decel=KRAUSS.decel))
    d = gap_decision(sv, tight, lanes, bold, Seeking(wanted_lane=2, insist=True))
    assert d.plan_now and d.follower_decel == KRAUSS.decel
    # 10 m behind it would need an emergency stop: never
    closer = scene([-10.0, 150.0], [2, 2], [25.0, 25.0])
    d = gap_decision(sv, closer, lanes, bold, Seeking(wanted_lane=2, insist=True))
    assert not d.plan_now
    # 60 m behind: it goes at once, within plan_decel
    roomy = scene([-60.0, 150.0], [2, 2], [25.0, 25.0])
    d = gap_decision(sv, roomy, lanes, RULES, Seeking(wanted_lane=2))
    assert d.plan_now and d.follower_decel == GAP.plan_decel


def test_the_entry_test_anticipates_the_change_and_refuses_a_level_tv() -> None:
    e = entry_test(START, target([0.0, 150.0], [25.0, 25.0], 25.0), GAP, KRAUSS)
    assert not e.ok and e.follower == -1  # level with the SV when it enters: refused
    # a leader now 18 m ahead, 6 m/s faster than the SV: the SV is not yet in the slot
    # behind it, but by its entry, 1.75 s on, that leader is far enough ahead: taken now
    polite = KRAUSS.limited(GAP.plan_decel)
    e = entry_test(START, target([-150.0, 18.0], [25.0, 31.0], 31.0), GAP, polite)
    gaps = lane_gaps(L, target([-150.0, 18.0], [25.0, 31.0], 31.0), GAP, KRAUSS)
    assert gaps.hi[1] < 0.0  # the slot alone would have it wait
    assert e.ok and e.leader == 1 and e.leader_gap >= e.secure
    assert e.secure >= GAP.min_gap + GAP.headway * 25.0  # never closer than the headway
    # the same leader at the SV's speed: too close, refused
    e = entry_test(START, target([-150.0, 18.0], [25.0, 25.0], 25.0), GAP, polite)
    assert not e.ok and e.leader_gap < e.secure
