"""The new follower's reaction to the SV (cosim.planning.interaction), on hand-made
scenes without SUMO (tests/traffic/test_cooperation.py compares it with SUMO)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.errors import InputError
from cosim.planning.interaction import (
    B_SAFE,
    FollowerModel,
    entry_decel,
    follower_accel,
    krauss_safe_speed,
    predict_follower,
    secure_gap,
)

KRAUSS = FollowerModel()
IDM = FollowerModel(model="idm", decel=2.0, tau=1.5)
DT = 0.05
T = np.arange(0.0, 12.0 + 1e-9, DT)


def test_secure_gap_is_where_krauss_is_just_safe() -> None:
    v = np.array([0.0, 5.0, 20.0, 30.0, 30.0])
    vl = np.array([0.0, 5.0, 20.0, 25.0, 35.0])
    g = secure_gap(v, vl, KRAUSS)
    # at the secure gap v_safe is v itself (or the gap is min_gap and v_safe >= v)
    vs = krauss_safe_speed(g, vl, KRAUSS)
    np.testing.assert_allclose(vs[g > KRAUSS.min_gap], v[g > KRAUSS.min_gap], rtol=1e-12)
    assert np.all(vs >= v - 1e-9)
    # closer than that (where the secure gap is beyond min_gap), it must slow down
    a = follower_accel(0.8 * g, v, vl, KRAUSS, DT)
    binding = g > KRAUSS.min_gap
    assert binding.sum() == 3 and np.all(a[binding] < 0.0)
    # farther, it may accelerate (up to accel) and never brakes
    a_far = follower_accel(2.0 * g + 10.0, v, vl, KRAUSS, DT)
    assert np.all(a_far >= 0.0) and np.all(a_far <= KRAUSS.accel)


def test_entry_decel_grows_as_the_cut_in_gets_shorter() -> None:
    gaps = np.array([70.0, 60.0, 30.0, 15.0, 8.0, 4.0, 2.0])
    d = entry_decel(gaps, 30.0, 25.0, KRAUSS, DT)
    assert np.all(np.diff(d) >= 0.0)
    # 70 m at 30 behind 25 m/s is Krauss-safe (secure gap 63.1 m): no braking at all
    assert d[0] == 0.0
    assert d[-1] == KRAUSS.emergency_decel  # 2 m at 5 m/s closing: everything it has
    # where v_safe asks more than decel, SUMO brakes at decel at least: 3 m inside the
    # secure gap already costs the follower 4.5 m/s^2, SUMO's own help level (b_safe)
    g = float(secure_gap(30.0, 25.0, KRAUSS)) - 3.0
    assert entry_decel(g, 30.0, 25.0, KRAUSS, DT) == pytest.approx(KRAUSS.decel)
    assert KRAUSS.decel == B_SAFE == 4.5
    # IDM brakes smoothly instead: the same cut-in asks a few m/s^2
    assert 0.0 < entry_decel(g, 30.0, 25.0, IDM, DT) < 4.0


def test_accepted_gap_is_the_shortest_within_b_safe() -> None:
    from cosim.planning.interaction import accepted_gap

    v = np.array([10.0, 20.0, 30.0, 30.0, 25.0])
    vs = np.array([10.0, 18.0, 25.0, 32.0, 15.0])
    acc = accepted_gap(v, vs, KRAUSS)
    assert np.all(entry_decel(acc, v, vs, KRAUSS, DT) <= KRAUSS.b_safe + 1e-9)
    assert np.all(entry_decel(acc - 0.05, v, vs, KRAUSS, DT) > KRAUSS.b_safe)
    # shorter than the secure gap (it may brake, up to b_safe), longer with more closing
    assert np.all(acc <= secure_gap(v, vs, KRAUSS) + 1e-6)
    assert acc[4] > acc[0]
    # a stricter b_safe (MOBIL's 4 m/s^2, below Krauss's decel) asks for about the
    # secure gap (less what 4 m/s^2 over one 0.05 s step recovers)
    strict = accepted_gap(v, vs, FollowerModel(b_safe=4.0))
    assert np.all(strict > acc)
    np.testing.assert_allclose(strict, secure_gap(v, vs, KRAUSS), atol=2.0)


@pytest.mark.parametrize("m", [KRAUSS, IDM], ids=["krauss", "idm"])
def test_compiled_accepted_gap_equals_the_array_bisection(m: FollowerModel) -> None:
    """The compiled bisection gives, value for value, the numpy bisection it replaced
    (16 halvings of [0, 400] m on entry_decel), NaN and inf speeds included."""
    from cosim.planning.interaction import accepted_gap

    rng = np.random.default_rng(3)
    v = np.concatenate([rng.uniform(0.0, 40.0, 200), [30.0, 30.0, 0.0]])
    vs = np.concatenate([rng.uniform(0.0, 40.0, 200), [np.nan, np.inf, 0.0]])
    lo, hi = np.zeros(v.shape), np.full(v.shape, 400.0)
    for _ in range(16):
        mid = 0.5 * (lo + hi)
        ok = entry_decel(mid, v, vs, m, DT) <= m.b_safe + 1e-9
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
    np.testing.assert_array_equal(accepted_gap(v, vs, m, DT), hi)


@pytest.mark.parametrize("m", [KRAUSS, IDM], ids=["krauss", "idm"])
def test_follower_keeps_its_speed_until_the_sv_enters(m: FollowerModel) -> None:
    # SV 25 m ahead of the follower's front, slower (25 vs 30 m/s), enters at 3 s
    rear = 25.0 + 25.0 * T
    p = predict_follower(T, rear, np.full(T.size, 25.0), 3.0, 0.0, 30.0, m)
    before = T < 3.0 - 1e-9
    np.testing.assert_allclose(p.speed[before], 30.0)
    np.testing.assert_allclose(p.x[before], 30.0 * T[before], atol=1e-9)
    # at entry the gap is 10 m at 5 m/s closing: it brakes, falls back (below the SV's
    # speed) to its own safe gap and speeds up again, never reaching the SV
    assert p.max_decel > 1.0
    assert p.min_gap > 0.0
    assert p.speed.min() < 25.0
    assert p.speed[-1] > p.speed.min() + 0.5 and p.speed[-1] < 25.0 + 1e-6
    gap_end = rear[-1] - p.x[-1]
    assert gap_end > m.min_gap


def test_prediction_matches_the_closed_form_first_step() -> None:
    rear = 40.0 + 22.0 * T
    p = predict_follower(T, rear, np.full(T.size, 22.0), 0.0, 0.0, 30.0, KRAUSS)
    first = float(entry_decel(40.0, 30.0, 22.0, KRAUSS, DT))
    assert -p.accel[0] == pytest.approx(first, rel=1e-12)


def test_safe_entry_against_b_safe() -> None:
    # a far gap: the follower never brakes harder than b_safe and the MOBIL test passes
    rear_far = 80.0 + 28.0 * T
    far = predict_follower(T, rear_far, np.full(T.size, 28.0), 2.0, 0.0, 30.0, KRAUSS)
    assert far.safe(KRAUSS)
    # a cut-in 8 m ahead at 8 m/s slower: fails it
    rear_close = 8.0 + 22.0 * T
    close = predict_follower(T, rear_close, np.full(T.size, 22.0), 0.0, 0.0, 30.0, KRAUSS)
    assert not close.safe(KRAUSS)
    assert close.max_decel > KRAUSS.b_safe


def test_sv_braking_after_entry_is_followed() -> None:
    # the SV enters safely, then brakes to a standstill at 3 m/s^2: the follower stops
    # behind it without touching it (Krauss is collision-free by construction)
    t = np.arange(0.0, 25.0 + 1e-9, DT)
    v_sv = np.maximum(20.0 - 3.0 * np.maximum(t - 2.0, 0.0), 0.0)
    rear = 45.0 + np.concatenate([[0.0], np.cumsum(v_sv[1:] * DT)])
    p = predict_follower(t, rear, v_sv, 0.0, 0.0, 20.0, KRAUSS)
    assert p.min_gap > 0.0
    assert p.speed[-1] < 0.05
    assert rear[-1] - p.x[-1] >= KRAUSS.min_gap - 1e-6


def test_bad_model_is_rejected() -> None:
    with pytest.raises(InputError, match="model"):
        FollowerModel(model="gipps").check()
    with pytest.raises(InputError, match="emergency_decel"):
        FollowerModel(emergency_decel=3.0).check()
    with pytest.raises(InputError, match="b_safe"):
        FollowerModel(b_safe=math.nan).check()
    FollowerModel().check()
    with pytest.raises(ValueError):
        predict_follower(T, T[:-1], T, 0.0, 0.0, 1.0, KRAUSS)


def test_check_follower_of_a_planned_lane_change() -> None:
    from cosim.planning.interaction import LaneTraffic, check_follower
    from cosim.planning.trajectory import LaneChangeTrajectory

    # SV at x = 0 in lane 1 (y = 0) changing left into y = 3.75 over 4 s at 25 m/s;
    # target-lane TVs (centres): one far behind (index 0), one nearer behind (1), one
    # ahead (2), one in another lane (3)
    tr = LaneChangeTrajectory(t0=10.0, tau=4.0, x0=0.0, y0=0.0, vx0=25.0, vxf=25.0,
                              width=3.75)
    x = np.array([-150.0, -40.0, 60.0, -10.0])
    v = np.array([25.0, 28.0, 25.0, 25.0])
    length = np.full(4, 4.32)
    target = np.array([True, True, True, False])
    c = check_follower(tr, 4.32, LaneTraffic.of(x, v, length, target), KRAUSS)
    assert c.follower == 1  # the nearest behind in the target lane, not the one beside
    assert c.t_enter == pytest.approx(12.0, abs=0.051)  # half way through a symmetric change
    assert c.prediction is not None
    # 40 m behind, 3 m/s faster: at entry about 29 m, inside its secure gap (33 m): brakes
    assert c.max_decel > 0.0
    assert c.safe == (c.max_decel <= KRAUSS.b_safe)
    # a faster, closer follower: the MOBIL test fails
    close = check_follower(tr, 4.32, LaneTraffic.of([-25.0], [32.0], length[:1], [True]),
                           KRAUSS)
    assert not close.safe and close.max_decel > KRAUSS.b_safe
    # far behind at the same speed: it cruises at the speed it drives (its desired
    # speed), it does not speed up to the model's cap and then brake for the SV
    far = check_follower(tr, 4.32, LaneTraffic.of([-120.0], [25.0], length[:1], [True]),
                         KRAUSS)
    assert far.follower == 0 and far.max_decel == 0.0 and far.prediction is not None
    np.testing.assert_allclose(far.prediction.speed, 25.0)
    # nobody behind: nothing asked
    free = check_follower(tr, 4.32, LaneTraffic.of(x[2:3], v[2:3], length[:1], [True]), KRAUSS)
    assert free.follower == -1 and free.safe and free.max_decel == 0.0
    # a lane keeping "change" (width 0) never enters another lane
    keep = check_follower(LaneChangeTrajectory(0.0, 1.0, 0.0, 0.0, 20.0, 20.0, 0.0), 4.32,
                          LaneTraffic.of(x, v, length, target), KRAUSS)
    assert keep.follower == -1 and math.isnan(keep.t_enter)


@pytest.mark.parametrize("m", [KRAUSS, IDM], ids=["krauss", "idm"])
def test_a_yielding_follower_brakes_on_until_the_sv_enters(m: FollowerModel) -> None:
    # braking at 2 m/s^2 from 30 m/s until the SV enters at 3 s: 24 m/s and 81 m then,
    # exactly (SUMO's Euler update: v then x), and down to a standstill, never below
    rear = 60.0 + 25.0 * T
    p = predict_follower(T, rear, np.full(T.size, 25.0), 3.0, 0.0, 30.0, m,
                         accel_before=-2.0)
    k = int(round(3.0 / DT))
    assert p.speed[k] == pytest.approx(24.0, abs=1e-9)
    assert p.x[k] == pytest.approx(sum(30.0 - 2.0 * DT * i for i in range(1, k + 1)) * DT,
                                   abs=1e-9)
    stop = predict_follower(T, 1e3 + 0.0 * T, np.zeros(T.size), 20.0, 0.0, 3.0, m,
                            accel_before=-2.0)
    assert stop.speed.min() == 0.0 and stop.x[-1] == pytest.approx(stop.x[40], abs=1e-12)
    # what it is asked is its braking after the SV enters, not the yielding before
    assert p.max_decel < 2.0


def test_check_follower_counts_on_a_yielding_tv_only_when_told() -> None:
    from cosim.planning.interaction import LaneTraffic, check_follower
    from cosim.planning.trajectory import LaneChangeTrajectory

    # the SV cuts in 3.45 s from 27.65 to 32.8 m/s in front of a TV 22.6 m behind at
    # 31.4 m/s (density study, 20 veh/km/lane, seed 3): at its own speed the TV would
    # brake harder than SUMO's decel; braking on at 2 m/s^2 until the SV enters (the
    # courtesy the SV asked of it) it has room and is asked nothing beyond
    tr = LaneChangeTrajectory(t0=0.0, tau=3.45, x0=0.0, y0=0.0, vx0=27.65, vxf=32.8,
                              width=3.75)
    x, v, length, lane = (np.array([-22.6]), np.array([31.4]), np.array([5.0]),
                          np.array([True]))
    keeps = check_follower(tr, 5.0, LaneTraffic.of(x, v, length, lane), KRAUSS)
    assert keeps.max_decel > 4.5
    yields = check_follower(tr, 5.0, LaneTraffic.of(x, v, length, lane, [2.0]), KRAUSS)
    assert yields.follower == 0 and yields.safe and yields.max_decel < 1.0
    assert yields.prediction is not None
    k = int(np.argmax(yields.prediction.t >= yields.t_enter - 1e-9))
    assert yields.prediction.speed[k] == pytest.approx(31.4 - 2.0 * yields.t_enter, abs=1e-9)
    # zero braking is the TV keeping its speed
    same = check_follower(tr, 5.0, LaneTraffic.of(x, v, length, lane, np.zeros(1)), KRAUSS)
    assert same.max_decel == keeps.max_decel


def test_the_sv_enters_with_the_side_of_its_body() -> None:
    from cosim.planning.interaction import LaneTraffic, check_follower
    from cosim.planning.trajectory import LaneChangeTrajectory

    # SUMO's continuous lane change puts the SV into the target lane (its shadow lane)
    # as soon as its side crosses the line: the follower (20 m behind, 2 m/s slower)
    # sees it then, before the centre crosses, nearer by what the SV gains meanwhile
    tr = LaneChangeTrajectory(t0=0.0, tau=4.0, x0=0.0, y0=0.0, vx0=10.0, vxf=10.0,
                              width=3.75)
    tvs = LaneTraffic.of([-20.0], [8.0], [5.0], [True])
    centre = check_follower(tr, 5.0, tvs, KRAUSS)
    side = check_follower(tr, 5.0, tvs, KRAUSS, sv_width=1.8)
    assert side.t_enter < centre.t_enter - 0.3
    assert side.prediction is not None and centre.prediction is not None
    assert side.prediction.entry_gap < centre.prediction.entry_gap - 0.5
    assert side.prediction.entry_gap == pytest.approx(
        15.0 + 2.0 * side.t_enter, abs=0.2)  # centres 20 m apart, half lengths 5 m


def test_the_entry_rule_keeps_the_follower_min_gap_behind_and_within_its_need() -> None:
    from cosim.planning.interaction import LaneTraffic, check_follower
    from cosim.planning.trajectory import LaneChangeTrajectory

    # a follower that would close to within SUMO's minimum gap (2.5 m) of the SV, or
    # needs more than b_safe of constant braking to stay that far behind, is refused
    # even where its Krauss prediction brakes within b_safe; with a reaction it closes
    # on before it brakes
    tr = LaneChangeTrajectory(t0=0.0, tau=3.0, x0=0.0, y0=0.0, vx0=10.0, vxf=10.0,
                              width=3.75)
    m = FollowerModel(reaction=0.1)
    for x_tv, v_tv in ((-14.5, 12.0), (-9.0, 10.0), (-30.0, 16.0)):
        c = check_follower(tr, 5.0, LaneTraffic.of([x_tv], [v_tv], [5.0], [True]), m,
                           sv_width=1.8)
        p = c.prediction
        assert p is not None
        expected = (p.max_decel <= m.b_safe + 1e-9 and p.needed_decel <= m.b_safe + 1e-9
                    and p.min_gap >= m.min_gap - 1e-6)
        assert c.safe == expected
    # nearer than the min gap at the entry: refused whatever its braking
    near = check_follower(tr, 5.0, LaneTraffic.of([-7.0], [10.0], [5.0], [True]), m,
                          sv_width=1.8)
    assert near.prediction is not None and near.prediction.entry_gap < 2.5 and not near.safe
    # the reaction: it keeps its speed for `reaction` after the entry
    p = predict_follower(T, 12.0 + 10.0 * T, np.full(T.size, 10.0), 1.0, 0.0, 14.0,
                         FollowerModel(reaction=0.2))
    k = int(round(1.0 / DT))
    np.testing.assert_allclose(p.speed[: k + 5], 14.0)
    assert p.speed[k + 6] < 14.0


def test_a_wary_follower_is_asked_less_and_kept_farther() -> None:
    w = KRAUSS.limited(2.0).wary(0.7, 1.0)
    assert w.b_safe == pytest.approx(1.4) and w.min_gap == pytest.approx(3.5)
    with pytest.raises(InputError, match="reaction"):
        FollowerModel(reaction=-0.1).check()
