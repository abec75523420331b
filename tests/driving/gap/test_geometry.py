"""Gap choice and approach (cosim.driving.gap.geometry) on hand-made target lanes, without SUMO."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from cosim.driving.gap.geometry import (
    GapConfig,
    OwnLane,
    TargetLane,
    approach_speed,
    choose_gap,
    lane_gaps,
    reach_time,
)
from cosim.driving.view import SVView
from cosim.planning.interaction import (
    FollowerModel,
    LaneTraffic,
    accepted_gap,
    entry_decel,
    secure_gap,
)

CFG = GapConfig(horizon=20.0)  # gaps up to 20 s away (the default, 8 s, leaves some out)
KRAUSS = FollowerModel()
SV_LEN = 4.32


def lane(xs: list[float], speed: float | list[float], lane_speed: float = 30.0):
    x = np.array(xs, dtype=float)
    v = np.broadcast_to(np.asarray(speed, dtype=float), x.shape).copy()
    tvs = LaneTraffic.of(x, v, np.full(x.size, 4.32), np.ones(x.size, bool))
    return lane_gaps(SV_LEN, TargetLane(tvs, lane_speed), CFG, KRAUSS)


def sv(speed: float, x: float = 0.0) -> SVView:
    """The SV at x (m) driving `speed` (m/s), wanting 30 m/s."""
    return SVView(x, 0.0, speed, SV_LEN, 30.0)


def bang_bang(offset: float, u: float, a: float, dt: float = 1e-4) -> float:
    """Simulated time-optimal transfer (reference for reach_time)."""
    p, t = -offset, 0.0
    while abs(p) > 1e-3 or abs(u) > 1e-2:
        s = p + u * abs(u) / (2 * a)
        w = -a if s > 0 else a
        u += w * dt
        p += u * dt
        t += dt
        if t > 100:
            break
    return t


@pytest.mark.parametrize("offset,u", [(10.0, 0.0), (-10.0, 0.0), (0.0, 2.0), (5.0, -3.0),
                                      (-20.0, 4.0)])
def test_reach_time_is_the_time_optimal_transfer(offset: float, u: float) -> None:
    assert float(reach_time(offset, u, 1.5)) == pytest.approx(bang_bang(offset, u, 1.5),
                                                              abs=0.02)
    assert float(reach_time(10.0, 0.0, 1.0)) == pytest.approx(2.0 * math.sqrt(10.0))


def test_slots_keep_the_secure_gap_ahead_and_the_accepted_gap_behind() -> None:
    g = lane([-100.0, 0.0, 100.0], 25.0)
    assert g.follower.tolist() == [-1, 0, 1, 2] and g.leader.tolist() == [0, 1, 2, -1]
    # every gap moves at its leader's speed, the open lane ahead at the band's
    np.testing.assert_allclose(g.speed, [25.0, 25.0, 25.0, 30.0])
    sg = float(secure_gap(25.0, 25.0, CFG.sv_model()))  # min gap + v * headway
    assert sg == pytest.approx(2.5 + 25.0 * CFG.headway)
    half = 0.5 * (SV_LEN + 4.32)
    # ahead: the SV's own secure gap behind the leader
    np.testing.assert_allclose(g.hi[:3], np.array([-100.0, 0.0, 100.0]) - half - sg)
    # behind: the shortest gap at which the follower brakes no harder than the slot's
    # entry_decel (the plan's check allows up to b_safe)
    slot = replace(KRAUSS, b_safe=CFG.entry_decel)
    acc = float(accepted_gap(25.0, 25.0, slot))
    assert float(entry_decel(acc, 25.0, 25.0, KRAUSS, 0.05)) <= CFG.entry_decel + 1e-9
    assert float(entry_decel(acc - 0.05, 25.0, 25.0, KRAUSS, 0.05)) > CFG.entry_decel
    assert float(accepted_gap(25.0, 25.0, KRAUSS)) < acc  # b_safe would let it closer
    assert acc < float(secure_gap(25.0, 25.0, KRAUSS))  # it may brake a little
    np.testing.assert_allclose(g.lo[1:3], np.array([-100.0, 0.0]) + half + acc)
    assert g.lo[0] == -math.inf and g.hi[3] == math.inf
    # the open lane ahead moves at the band's speed; a faster follower needs more room:
    # what it closes before the SV enters (half the speed difference over entry_delay)
    g2 = lane([0.0], 30.0, lane_speed=25.0)
    assert g2.speed[1] == 25.0
    assert g2.lo[1] == pytest.approx(half + float(accepted_gap(30.0, 25.0, slot))
                                     + 0.5 * 5.0 * CFG.entry_delay)


def test_alongside_gap_is_reachable_at_its_speed() -> None:
    g = lane([-100.0, 100.0], 25.0)
    c = choose_gap(sv(25.0), g, CFG, KRAUSS)
    assert c is not None
    assert (c.index, c.relation, c.offset, c.reachable) == (1, "alongside", 0.0, True)
    assert c.speed == 25.0 and c.target_speed == 25.0
    # 4 m/s faster: the change ends at 25 m/s, and at 27 m/s on entry the SV is still
    # 41 m (its secure gap) behind the leader: reachable
    c_27 = choose_gap(sv(29.0), g, CFG, KRAUSS)
    assert c_27 is not None and c_27.index == 1 and c_27.reachable
    # more than max_speed_change faster: slow down first
    c_fast = choose_gap(sv(25.0 + CFG.max_speed_change + 1.0), g, CFG, KRAUSS)
    assert c_fast is not None and c_fast.index == 1 and not c_fast.reachable
    # inside the slot at the gap's speed but too close to the leader at the SV's speed
    g_near = lane([-100.0, 30.0], 25.0)
    # (held to 29 m/s in its own lane: the open lane ahead of the leader, at 30 m/s, is
    # out of reach; without that limit the gap ahead, which asks no braking, ranks first)
    c_near = choose_gap(sv(29.0), g_near, CFG, KRAUSS, OwnLane(max_speed=29.0))
    assert c_near is not None and c_near.index == 1 and c_near.relation == "alongside"
    assert not c_near.reachable and c_near.target_speed < 25.0  # falls back first


def test_blocked_alongside_faster_sv_goes_ahead_slower_goes_behind() -> None:
    g = lane([-100.0, 0.0, 100.0], 25.0)  # a TV right beside the SV
    ahead = choose_gap(sv(27.0), g, CFG, KRAUSS)
    behind = choose_gap(sv(23.0), g, CFG, KRAUSS)
    assert ahead is not None and behind is not None
    assert (ahead.index, ahead.relation) == (2, "ahead")
    assert (behind.index, behind.relation) == (1, "behind")
    # aimed inside the slot by a quarter of its length (more than the 2 m minimum)
    margin = CFG.margin_share * (g.hi[2] - g.lo[2])
    assert margin > CFG.margin
    assert ahead.offset == pytest.approx(g.lo[2] + margin)
    assert behind.offset == pytest.approx(g.hi[1] - margin)
    assert ahead.target_speed > 25.0 and behind.target_speed < 25.0
    assert not ahead.reachable and not behind.reachable


def test_own_leader_bars_gaps_beyond_it() -> None:
    g = lane([-100.0, 0.0, 100.0], 25.0)
    # the SV's own leader 20 m ahead at 20 m/s: the gap ahead (aim ~34 m) is out of reach
    c = choose_gap(sv(27.0), g, CFG, KRAUSS, OwnLane(20.0 - 0.5 * SV_LEN - 2.5, 20.0))
    assert c is not None and c.index == 1 and c.relation == "behind"


def test_short_or_closing_gaps_are_not_candidates() -> None:
    # 25 m between bumpers at 25 m/s: shorter than the SV and both gaps it needs; no
    # other gap here is reachable within the horizon because the lane is a long platoon
    xs = list(np.arange(-400.0, 401.0, 29.32))
    g = lane(xs, 25.0)
    assert np.all(g.hi[1:-1] < g.lo[1:-1])
    c = choose_gap(sv(25.0), g, CFG, KRAUSS)
    assert c is None or c.index in (0, len(xs))  # only the platoon's ends remain
    assert c is None or c.reach_time <= CFG.horizon


def test_approach_speed_brakes_to_the_gap_speed_on_arrival() -> None:
    e = np.array([-50.0, -5.0, -0.5, 0.0, 0.5, 5.0, 50.0])
    v = approach_speed(e, 25.0, CFG)
    assert np.all(np.diff(v) > 0.0)
    assert v[3] == 25.0
    np.testing.assert_allclose(v - 25.0, -(v[::-1] - 25.0))  # symmetric
    assert v[4] - 25.0 == pytest.approx(0.5 / CFG.approach_time)  # near: e / T
    assert v[5] - 25.0 == pytest.approx(5.0 / CFG.approach_time)
    assert v[-1] - 25.0 == pytest.approx(CFG.max_rel_speed)  # far: bounded
    # with a gentle approach acceleration the braking curve binds in between
    soft = GapConfig(approach_accel=0.5)
    mid = float(approach_speed(20.0, 25.0, soft)) - 25.0
    assert mid == pytest.approx(math.sqrt(2.0 * 0.5 * 20.0))
    assert approach_speed(-100.0, 2.0, CFG) == 0.0  # never below a standstill


def test_following_the_target_speed_reaches_the_gap() -> None:
    # a kinematic SV at the chosen target speed (within +-1.5 m/s^2) behind a blocked
    # alongside slot: it must become reachable, in about the estimated time
    xs = np.array([-100.0, 0.0, 100.0])
    x, v, t, dt = 0.0, 27.0, 0.0, 0.05
    first = None
    while t < 30.0:
        tv_x = xs + 25.0 * t
        g = lane(list(tv_x), 25.0)
        c = choose_gap(sv(v, x), g, CFG, KRAUSS)
        assert c is not None and c.index == 2  # the choice holds while approaching
        if first is None:
            first = c.reach_time
        if c.reachable:
            break
        v += float(np.clip((c.target_speed - v) / dt, -1.5, 1.5)) * dt
        x += v * dt
        t += dt
    assert c.reachable
    assert first is not None and t < 2.0 * first + 3.0


def test_seeking_closes_up_to_the_krauss_safe_speed_behind_its_leader() -> None:
    from cosim.driving.gap.geometry import seeking_accel
    from cosim.planning.interaction import krauss_safe_speed

    cfg = GapConfig()
    # far behind a slower leader: toward the target speed at the approach acceleration
    assert seeking_accel(27.0, 31.0, 30.6, 200.0, 26.0, cfg) == cfg.approach_accel
    # no leader: up to the lane's limit, not beyond it
    assert seeking_accel(30.6, 35.0, 30.6, math.inf, math.inf, cfg) == 0.0
    assert seeking_accel(31.6, 35.0, 30.6, math.inf, math.inf, cfg) < 0.0
    # a leader 60 m ahead at 26.5 m/s: Krauss (SUMO's tau 1 s, decel 4.5) allows ~30.8 m/s
    v_safe = float(krauss_safe_speed(60.0, 26.5, cfg.follow_model()))
    assert 30.0 < v_safe < 31.5
    assert seeking_accel(v_safe - 1.0, 33.0, 40.0, 60.0, 26.5, cfg) > 0.0
    assert seeking_accel(v_safe + 0.5, 33.0, 40.0, 60.0, 26.5, cfg) < 0.0
    # close behind it: brakes, within the follow decel
    a = seeking_accel(30.0, 33.0, 40.0, 5.0, 20.0, cfg)
    assert a == -cfg.follow_decel


def test_seeking_brakes_to_a_slower_target_lane_within_the_approach_decel() -> None:
    from cosim.driving.gap.geometry import seeking_accel

    cfg = GapConfig()
    # 24.6 m/s toward a target lane at 18 m/s (40 veh/km/lane): firmer than the IDM's
    # comfortable b, never beyond the approach limit, within ACC's 3.5 m/s^2
    a = seeking_accel(24.6, 18.0, 30.6, math.inf, math.inf, cfg)
    assert a == -cfg.approach_decel
    assert cfg.comfort_decel < cfg.approach_decel <= 3.5
    # near the approach speed: gently, in proportion
    assert -cfg.approach_decel < seeking_accel(18.5, 18.0, 30.6, math.inf, math.inf, cfg) < 0.0
