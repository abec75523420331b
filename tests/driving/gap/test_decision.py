"""The gap-seeking decision (cosim.driving.gap.decision) on hand-made scenes, without SUMO."""

from __future__ import annotations

import math

import numpy as np

from cosim.driving.gap.decision import GapRules, Seeking, gap_decision
from cosim.driving.gap.geometry import GapConfig
from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig
from cosim.driving.view import SVView, TrafficView
from cosim.params import RoadParams
from cosim.planning.interaction import FollowerModel

ROAD = RoadParams()  # lanes 0 / 1 / 2 at y = 1.875 / 5.625 / 9.375
CFG = DecisionConfig()
GAP = GapConfig()
KRAUSS = FollowerModel()
L = 4.32


def scene(xs: list[float], lanes: list[int], speeds: list[float]) -> TrafficView:
    n = len(xs)
    return TrafficView.arrays(xs, [ROAD.lane_center(k) for k in lanes], speeds, np.full(n, L),
                          np.full(n, 1.8))


def drive(sv_x: float, sv_speed: float, tvs: TrafficView, **kw: object):
    return gap_decision(SVView(sv_x, ROAD.lane_center(1), sv_speed, L, 30.0), tvs,
                        LaneLayout(ROAD), GapRules(CFG, GAP, KRAUSS), Seeking(**kw))


def test_free_road_keeps_the_lane() -> None:
    d = drive(0.0, 28.0, scene([300.0], [1], [28.0]))
    assert d.target_lane is None and not d.plan_now and d.gap is None
    assert d.accel > 0.0  # IDM toward the desired 30 m/s


def test_slow_leader_and_a_blocked_faster_lane_approaches_a_gap() -> None:
    # a slow leader 30 m ahead in lane 1; lane 2 has a TV right beside the SV and
    # others 100 m before and after it: the old rule's free-lane filter says no;
    # the gap policy aims at a gap and adjusts its speed
    tvs = scene([30.0, -100.0, 0.0, 100.0], [1, 2, 2, 2], [22.0, 28.0, 28.0, 28.0])
    d = drive(0.0, 25.0, tvs)
    assert d.target_lane == 2
    assert d.gap is not None and d.gap.relation == "behind"  # slower than lane 2: behind
    assert d.gap.follower == 1 and d.gap.leader == 2
    assert not d.plan_now
    # the chosen gap's follower is 100 m behind: it already has room, nobody is asked
    assert d.cooperate_with == -1
    assert d.vxf == 28.0  # the gap's speed, not the band rule's 30.6
    assert d.accel < 0.0  # it falls back toward the gap


def test_gap_reached_plans_at_the_gap_speed() -> None:
    # the SV already sits in the middle of a 200 m gap in lane 2 at its speed
    tvs = scene([40.0, -100.0, 100.0], [1, 2, 2], [22.0, 28.0, 28.0])
    d = drive(0.0, 28.0, tvs)
    assert d.target_lane == 2 and d.gap is not None
    assert d.gap.relation == "alongside" and d.plan_now and d.vxf == 28.0


def test_no_plan_below_the_planner_speed() -> None:
    # a queue: everybody at 3 m/s; a wide gap beside the SV, and a slow leader
    tvs = scene([12.0, -100.0, 100.0], [1, 2, 2], [1.0, 3.0, 3.0])
    d = drive(0.0, 3.0, tvs)
    assert d.gap is not None and d.gap.relation == "alongside"
    assert not d.plan_now  # 3 m/s < GapConfig.min_speed (5 m/s)
    assert GAP.min_speed == 5.0
    d_fast = drive(0.0, 3.0, tvs, wanted_lane=2)
    assert d_fast.target_lane == 2 and not d_fast.plan_now


def test_own_leader_caps_the_approach() -> None:
    # the gap is ahead (the SV is faster than lane 2), but the own leader is close:
    # never accelerate into it
    tvs = scene([8.0, -100.0, 0.0, 100.0], [1, 2, 2, 2], [20.0, 25.0, 25.0, 25.0])
    d = drive(0.0, 27.0, tvs)
    assert d.accel < 0.0  # IDM brakes for the leader 8 m ahead, whatever the gap wants
    assert d.gap is None or d.gap.relation != "ahead"


def test_scripted_request_is_followed_without_a_slow_leader() -> None:
    tvs = scene([-100.0, 100.0], [0, 0], [25.0, 25.0])
    d = drive(0.0, 25.0, tvs, wanted_lane=0)
    assert d.target_lane == 0 and d.gap is not None and d.plan_now
    assert d.vxf == 25.0
    # no change allowed: car-following only
    d2 = drive(0.0, 25.0, tvs, wanted_lane=0, allow_change=False)
    assert d2.target_lane is None and math.isnan(d2.vxf)


def test_approach_by_the_driver_reaches_the_gap() -> None:
    # a kinematic SV driven by the decisions (TVs at constant speed) ends up planning
    x, v, t, dt = 0.0, 25.0, 0.0, 0.05
    base = np.array([30.0, -100.0, 0.0, 100.0])
    speeds = np.array([22.0, 28.0, 28.0, 28.0])
    planned = None
    while t < 40.0:
        tvs = scene(list(base + speeds * t), [1, 2, 2, 2], list(speeds))
        d = drive(x, v, tvs, wanted_lane=2)
        if d.plan_now:
            planned = d
            break
        v = max(v + d.accel * dt, 0.0)
        x += v * dt
        t += dt
    assert planned is not None and planned.gap is not None
    assert planned.gap.index in (1, 2)
    assert abs(v - planned.vxf) <= GAP.max_speed_change
    # the paper's manoeuvre from there (4 s, to the gap's speed) asks the new follower
    # for no more than b_safe and comes no closer to the new leader than its min gap
    from cosim.planning.interaction import LaneTraffic, check_follower
    from cosim.planning.trajectory import LaneChangeTrajectory

    tr = LaneChangeTrajectory(t0=t, tau=4.0, x0=x, y0=ROAD.lane_center(1), vx0=v,
                              vxf=planned.vxf, width=ROAD.lane_width)
    tv_now = base + speeds * t
    in_2 = np.array([False, True, True, True])
    check = check_follower(tr, L, LaneTraffic.of(tv_now, speeds, np.full(4, L), in_2), KRAUSS)
    assert check.follower == planned.gap.follower and check.safe
    tt = t + np.arange(0.0, 7.0, 0.05)
    sv_x, _ = tr.position(tt)
    lead = planned.gap.leader
    lead_rear = tv_now[lead] + speeds[lead] * (tt - t) - 0.5 * L
    assert np.min(lead_rear - (sv_x + 0.5 * L)) > KRAUSS.min_gap


def test_seeking_a_faster_lane_closes_up_to_the_own_leader() -> None:
    # the own leader 60 m ahead at 26.5 m/s holds the IDM (1.5 s time gap) below it;
    # lane 2 runs at 31.4 m/s, packed behind the SV (40 m apart), a gap ahead beyond
    # the own leader: seeking, the SV accelerates toward the lane's speed as SUMO's own
    # SV does (Krauss-safe behind its leader, up to its lane's limit)
    tvs = scene([62.0, -135.0, -95.0, -55.0, -15.0, 58.0], [1, 2, 2, 2, 2, 2],
                [26.5, 31.4, 31.4, 31.4, 31.4, 31.4])
    keep = drive(0.0, 27.0, tvs, wanted_lane=2, allow_change=False)
    assert keep.accel < 0.2  # the IDM alone barely moves toward the faster lane
    d = drive(0.0, 27.0, tvs, wanted_lane=2)
    assert d.target_lane == 2 and not d.plan_now
    assert d.accel == GAP.approach_accel
    # at the lane's limit it accelerates no more
    d_max = drive(0.0, ROAD.speed_bands[1][1], tvs, wanted_lane=2)
    assert d_max.accel <= 1e-9
    # 20 m behind its leader it brakes, whatever the target lane runs
    d_close = drive(42.0, 29.0, tvs, wanted_lane=2)
    assert d_close.accel < 0.0


def test_a_mandatory_change_asks_a_tv_that_can_still_fall_back_behind_the_sv() -> None:
    # the SV standing at its stop line (lane 1 here), lane 2 beside it: a TV 10 m behind
    # at 12 m/s cannot stop behind it at the courtesy's 2 m/s^2 (36 m), one 45 m behind
    # at 12 m/s can; a change by choice asks the nearest, a mandatory one the one that can
    from cosim.driving.gap.decision import can_fall_back, mandatory_config

    tvs = scene([-10.0, -45.0], [2, 2], [12.0, 12.0])
    sv = SVView(0.0, ROAD.lane_center(1), 0.0, L, 30.0)
    assert list(can_fall_back(sv, tvs, mandatory_config(GAP))) == [False, True]
    assert list(can_fall_back(sv, tvs, GAP)) == [True, True]  # ask_decel inf: everybody
    lanes = LaneLayout(ROAD)
    asked = {}
    for name, cfg in (("choice", GAP), ("mandatory", mandatory_config(GAP))):
        d = gap_decision(sv, tvs, lanes, GapRules(CFG, cfg, KRAUSS), Seeking(wanted_lane=2))
        assert d.target_lane == 2 and not d.plan_now and d.gap is None
        asked[name] = d.cooperate_with
    assert asked == {"choice": 0, "mandatory": 1}


def test_a_refused_follower_is_taken_only_with_a_margin() -> None:
    # a follower in lane 2 closing on the SV: find where its entry just passes (and is
    # not refused), then a follower just refused (`Seeking.wary`) is not taken there
    # while the same entry a few metres farther back passes the margin as well
    passes = []
    for back in np.arange(8.0, 60.0, 1.0):
        tvs = scene([-back], [2], [26.0])
        plain = drive(0.0, 25.0, tvs, wanted_lane=2)
        wary = drive(0.0, 25.0, tvs, wanted_lane=2, wary=np.array([True]))
        passes.append((back, plain.plan_now, wary.plan_now))
        if not plain.plan_now:
            assert plain.refused == 0  # its follower check refused it: the policy remembers
        if wary.plan_now:
            assert plain.plan_now and plain.follower == 0
    first_plain = min(b for b, p, _ in passes if p)
    first_wary = min(b for b, _, w in passes if w)
    assert first_wary >= first_plain + 1.0


def test_an_insisted_entry_gives_no_margin_to_a_tv_making_room() -> None:
    # a TV 23 m behind in lane 2, 3 m/s faster than the SV, braking at 2 m/s^2 for its
    # courtesy: the entry counting on that braking asks it for more than plan_decel
    # (insisting), and holds with it at its speed but not 1 m/s faster (the insist
    # margin); seen braking to make room (its openGap holds it behind the SV), it is
    # not given that margin and the SV goes (study_entry at 15 veh/km/lane: 0.25 s sooner)
    tvs = scene([200.0, -23.15], [1, 2], [28.0, 31.0])
    braking = np.array([0.0, 2.0])
    held = dict(wanted_lane=2, insist=True, yielding=braking)
    assert not drive(0.0, 28.0, tvs, **held).plan_now
    d = drive(0.0, 28.0, tvs, slowing=braking, **held)
    assert d.plan_now and d.follower == 1 and d.held is not None
    assert GAP.plan_decel < d.follower_decel <= GAP.insist_decel
    # only the TV seen braking is spared the margin
    assert not drive(0.0, 28.0, tvs, slowing=np.array([2.0, 0.0]), **held).plan_now


def test_a_change_announced_into_the_target_lane_is_in_it() -> None:
    # an automated vehicle in lane 0, 9 m ahead and 4.5 m/s slower, flies its change
    # into lane 1 (its broadcast C3), not yet across the line; the SV in lane 2 wants
    # lane 1 too: by position the lane is empty, with the announced change the partner
    # is its new leader, too close to take the gap ahead of it now
    tvs = TrafficView.arrays([9.0, -100.0, 100.0], [ROAD.lane_center(k) for k in (0, 1, 1)],
                             [14.8, 19.3, 19.3], np.full(3, L), np.full(3, 1.8),
                             ids=("p", "f", "l"))
    sv = SVView(0.0, ROAD.lane_center(2), 19.3, L, 30.0)
    rules = GapRules(CFG, GAP, KRAUSS)
    free = gap_decision(sv, tvs, LaneLayout(ROAD), rules, Seeking(wanted_lane=1))
    assert free.target_lane == 1 and free.plan_now
    assert tvs.announced({"q": 1}) is tvs  # nobody of this view announces one
    taken = gap_decision(sv, tvs.announced({"p": 1}), LaneLayout(ROAD), rules,
                         Seeking(wanted_lane=1))
    assert taken.target_lane == 1 and not taken.plan_now
