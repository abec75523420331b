"""Tests of cosim.run.metrics: IAE, gaps/TTC between rectangles, jerk, lane-change durations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.run.metrics import (
    gap_ttc,
    half_extents,
    iae,
    iae_row,
    jerk,
    lane_change_durations,
    max_abs,
    settle_time,
)


def test_iae_of_a_sine_over_a_period_is_four_over_omega() -> None:
    t = np.linspace(0.0, 2.0 * np.pi, 20001)
    assert iae(t, np.sin(t)) == pytest.approx(4.0, rel=1e-6)


def test_iae_of_a_constant_is_value_times_duration_and_sign_does_not_matter() -> None:
    t = np.linspace(0.0, 3.0, 61)
    assert iae(t, -0.5 * np.ones_like(t)) == pytest.approx(1.5)
    assert iae([0.0], [3.0]) == 0.0


def test_half_extents_of_a_turned_rectangle() -> None:
    hx, hy = half_extents(4.32, 1.8, 0.0)
    assert (hx, hy) == pytest.approx((2.16, 0.9))
    hx, hy = half_extents(4.32, 1.8, np.pi / 2)
    assert (hx, hy) == pytest.approx((0.9, 2.16))
    hx, hy = half_extents(4.0, 2.0, np.pi / 4)
    assert hx == pytest.approx(3.0 / np.sqrt(2.0))


def test_gap_and_ttc_to_a_slower_leader_and_a_faster_follower() -> None:
    hx, hy = half_extents(4.32, 1.8, 0.0)
    gap, ttc = gap_ttc(
        0.0, 0.0, 25.0, (hx, hy),
        tv_x=[20.0, -30.0, 10.0], tv_y=[0.2, -0.3, 3.75], tv_vx=[20.0, 30.0, 0.0],
        tv_half=([hx] * 3, [hy] * 3),
    )
    # leader: 20 m centre to centre minus one car length; closing at 5 m/s
    assert gap[0] == pytest.approx(20.0 - 4.32)
    assert ttc[0] == pytest.approx((20.0 - 4.32) / 5.0)
    # follower 30 m behind, 5 m/s faster
    assert gap[1] == pytest.approx(30.0 - 4.32)
    assert ttc[1] == pytest.approx((30.0 - 4.32) / 5.0)
    # the car in the next lane does not share the SV's strip: no gap, no TTC
    assert math.isinf(gap[2]) and math.isinf(ttc[2])


def test_ttc_is_infinite_when_opening_and_zero_when_overlapping() -> None:
    hx, hy = half_extents(4.32, 1.8, 0.0)
    gap, ttc = gap_ttc(0.0, 0.0, 20.0, (hx, hy), [10.0, 3.0], [0.0, 0.0], [25.0, 20.0],
                       ([hx, hx], [hy, hy]))
    assert math.isinf(ttc[0]) and gap[0] > 0
    assert gap[1] < 0 and ttc[1] == 0.0


def test_lateral_overlap_threshold_is_the_sum_of_half_widths() -> None:
    hx, hy = half_extents(4.32, 1.8, 0.0)
    gap, _ = gap_ttc(0.0, 0.0, 20.0, (hx, hy), [10.0, 10.0], [1.79, 1.81], [20.0, 20.0],
                     ([hx, hx], [hy, hy]))
    assert np.isfinite(gap[0]) and math.isinf(gap[1])


def test_jerk_of_a_linear_acceleration_ramp() -> None:
    t = np.linspace(0.0, 1.0, 11)
    j = jerk(t, 3.0 * t, 4.0 * t)
    assert j == pytest.approx(np.full(10, 5.0))
    assert max_abs([np.nan, -2.0, 1.0]) == 2.0
    assert max_abs([]) == 0.0


def test_lane_change_duration_is_time_to_settle_in_the_target_lane() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    tau = 4.0
    s = np.clip((t - 1.0) / tau, 0.0, 1.0)
    y = 3.75 * (6 * s**5 - 15 * s**4 + 10 * s**3)
    d = lane_change_durations(t, y, [1.0], [3.75], [10.0], tol=0.1)
    # the quintic comes within 0.1 m of W shortly before tau
    assert 0.8 * tau < d[0] <= tau
    # never reaching the target: NaN
    assert math.isnan(settle_time(t, y, 1.0, 7.5, 10.0))


def test_iae_row_uses_the_window_and_kilonewtons() -> None:
    t = np.linspace(0.0, 10.0, 101)
    trace = {
        "ex_mps": np.ones_like(t), "ye_m": np.ones_like(t), "phie_deg": np.ones_like(t),
        "delta_f_deg": np.ones_like(t), "fx_fl_n": 500.0 * np.ones_like(t),
        "fx_fr_n": -500.0 * np.ones_like(t), "fx_rl_n": 500.0 * np.ones_like(t),
        "fx_rr_n": 500.0 * np.ones_like(t),
    }
    row = iae_row(t, trace, 2.0, 4.0)
    assert row["iae_ye_m_s"] == pytest.approx(2.0)
    # sum of the wheels' |Fx|: 2 kN for 2 s (a braking wheel counts as much as a driving one)
    assert row["iae_fx_kn_s"] == pytest.approx(4.0)


# ---------------------------------------------------------------- follower_max_decel

def test_lane_entry_time_is_when_the_centre_crosses() -> None:
    from cosim.run.metrics import lane_entry_time

    t = np.arange(0.0, 10.0, 0.5)
    lane = np.where(t < 4.0, 1, 2)
    assert lane_entry_time(t, lane, 1.0, 2) == 4.0
    assert np.isnan(lane_entry_time(t, lane, 1.0, 0))  # never in lane 0
    assert np.isnan(lane_entry_time(t, lane, 1.0, 2, end=3.0))  # not within the window


def test_follower_max_decel_window_and_nan() -> None:
    from cosim.run.metrics import FOLLOWER_WINDOW, follower_max_decel

    dt = 0.1
    t = np.arange(0.0, 20.0 + 1e-9, dt)
    # the follower brakes at 2 m/s^2 from 5 to 6 s, at 5 m/s^2 from 12 to 12.5 s and
    # at 8 m/s^2 from 17 to 17.5 s
    a = np.where((t >= 5.0) & (t < 6.0), -2.0, 0.0)
    a = np.where((t >= 12.0) & (t < 12.5), -5.0, a)
    a = np.where((t >= 17.0) & (t < 17.5), -8.0, a)
    v = 30.0 + np.concatenate([[0.0], np.cumsum(a[:-1] * dt)])
    # entered at 4 s, settled at 8 s: window to 11 s sees the 2 m/s^2 only
    assert follower_max_decel(t, v, 4.0, 8.0) == pytest.approx(2.0)
    # settled at 10 s: the window reaches 13 s and the 5 m/s^2 braking
    assert follower_max_decel(t, v, 4.0, 10.0) == pytest.approx(5.0)
    assert FOLLOWER_WINDOW == 3.0
    # unsettled: watched to the end
    assert follower_max_decel(t, v, 4.0, np.nan) == pytest.approx(8.0)
    # entered after all the braking: it never brakes, 0 (not negative)
    assert follower_max_decel(t, v + 0.1 * t, 18.0, 18.5) == 0.0
    # no follower / unknown speeds: NaN
    assert np.isnan(follower_max_decel(t, v, np.nan, 8.0))
    assert np.isnan(follower_max_decel(t, np.full(t.size, np.nan), 4.0, 8.0))
    # a sample gap (vehicle briefly unknown) does not make a pair across it
    v_gap = v.copy()
    v_gap[(t > 5.35) & (t < 5.65)] = np.nan
    assert follower_max_decel(t, v_gap, 4.0, 8.0) == pytest.approx(2.0)
    v_gap[(t > 4.95) & (t < 6.05)] = np.nan  # the braking unseen: 5.0 -> 6.0 is no pair
    assert follower_max_decel(t, v_gap, 4.0, 8.0) == 0.0
    v_odd = v.copy()
    v_odd[::2] = np.nan  # no two consecutive known samples
    assert np.isnan(follower_max_decel(t, v_odd, 4.0, 8.0))


# ---------------------------------------------------------------- comfort


def test_longitudinal_comfort_measures_rms_jerk_and_chatter() -> None:
    from cosim.run.metrics import longitudinal_comfort

    t = np.arange(0.0, 1.0, 0.05)
    smooth = longitudinal_comfort(t, np.full(t.size, -2.0))
    assert smooth["rms_long_accel_mps2"] == pytest.approx(2.0)
    assert smooth["rms_long_jerk_mps3"] == 0.0 and smooth["max_long_jerk_mps3"] == 0.0
    assert smooth["long_accel_jump_share"] == 0.0
    # chatter as the two-track plant can show it: -6, +7, -6, ... every 0.05 s step
    chatter = longitudinal_comfort(t, np.where(np.arange(t.size) % 2, 7.0, -6.0))
    assert chatter["long_accel_jump_share"] == 1.0
    assert chatter["max_long_jerk_mps3"] == pytest.approx(13.0 / 0.05)
    assert chatter["rms_long_jerk_mps3"] == pytest.approx(13.0 / 0.05)
    nan = longitudinal_comfort(t[:1], [1.0])
    assert all(math.isnan(v) for v in nan.values())


def test_time_gap_to_the_nearest_tv_ahead() -> None:
    from cosim.run.metrics import time_gap

    # SV (4.8 m) at x = 100 m, 20 m/s; TVs (5 m) at 80 (behind), 130 and 160 m
    assert time_gap(100.0, 20.0, 4.8, [80.0, 160.0, 130.0], [5.0, 5.0, 5.0]) == pytest.approx(
        (30.0 - 4.9) / 20.0)
    assert time_gap(100.0, 20.0, 4.8, [80.0], [5.0]) == math.inf
    assert time_gap(100.0, 20.0, 4.8, [], []) == math.inf


def test_post_change_decel_and_request_time_windows() -> None:
    from cosim.run.metrics import post_change_max_decel, request_to_lane

    t = np.arange(0.0, 20.0, 0.05)
    ax = np.where((t > 9.0) & (t < 9.5), -4.0, np.where(t > 15.0, -6.0, 0.5))
    # entered at 5 s, settled at 6.5 s: watched until 9.5 s (the -4 m/s^2 at 9-9.5 s)
    assert post_change_max_decel(t, ax, 5.0, 6.5) == pytest.approx(4.0)
    assert post_change_max_decel(t, ax, 5.0, 5.5) == 0.0  # until 8.5 s: it only speeds up
    assert post_change_max_decel(t, ax, 5.0, math.nan) == 0.0  # unsettled: entry + 3 s
    assert math.isnan(post_change_max_decel(t, ax, math.nan, 6.5))
    lane = np.where(t >= 4.0, 2, 1)
    assert request_to_lane(t, lane, 2.0, 2) == pytest.approx(2.0)
    assert math.isnan(request_to_lane(t, lane, 2.0, 0))
    assert math.isnan(request_to_lane(t, lane, math.nan, 2))


def test_collision_seen_by_names_the_checks() -> None:
    from cosim.run.metrics import collision_seen_by

    assert [collision_seen_by(o, s) for o, s in ((0, 0), (1, 1), (2, 0), (0, 1))] == [
        "none", "both", "ours", "sumo"]


def test_lane_change_status_tells_unfinished_from_failed() -> None:
    from cosim.run.metrics import LaneChangeEnd, lane_change_status

    centres = np.array([1.875, 5.625, 9.375])
    nan = np.array([np.nan])

    def status(requests: int, completed: bool, durations: np.ndarray, ends: list[float],
               y_end: float) -> str:
        end = LaneChangeEnd(requests, completed, durations, ends, t_end=20.0, y_end=y_end)
        return lane_change_status(end, centres, 0.1)

    # a request, no start, the SV in its lane at the end: failed
    assert status(1, False, np.array([]), [], 5.6) == "failed"
    assert status(0, False, np.array([]), [], 5.6) == "none"
    assert status(1, True, np.array([3.0]), [20.0], 9.4) == "completed"
    # still between the lanes at the end
    assert status(1, False, nan, [20.0], 7.5) == "unfinished"
    # in the band of the target lane, but the settling window ran into the end
    assert status(1, False, nan, [20.0], 9.45) == "unfinished"
    # a change that did not settle before the next manoeuvre: failed, not cut short
    assert status(1, False, nan, [12.0], 5.6) == "failed"


@pytest.mark.sumo
def test_a_collision_only_sumo_counts_is_reported_as_such() -> None:
    """study_gap_sample's paper policy, density 40, seed 1: late in the run the SV,
    changing lanes at a few degrees, comes inside a TV's x extent (min gap below 0,
    TTC 0) without the rectangles touching; SUMO, which measures gaps along the lane
    without the SV's heading, reports a collision. The run ends before the lane change
    settles: unfinished, not failed (docs/run_results.md)."""
    from cosim.run.loop import simulate
    from cosim.scenario import load_scenario, project_root, with_overrides

    base = load_scenario(project_root() / "scenarios" / "study_density_base.toml")
    m = simulate(with_overrides(base, policy="paper", density=40, seed=1)).metrics
    assert (m["collisions"], m["sumo_collisions"], m["sumo_collision"]) == (0, 1, 1)
    assert m["collision_seen_by"] == "sumo" and m["collisions_sv"] == 0
    assert m["min_gap_m"] < 0.0 and m["min_ttc_s"] == 0.0  # SUMO's gap along the lane
    assert m["lane_change_status"] == "unfinished" and m["lane_change_unfinished"] == 1


def test_follower_max_decel_is_watched_from_the_change_start() -> None:
    # SUMO's own driver is in the target lane for its followers from the start of its
    # change: the follower brakes then, before the SV's centre crosses the line (issue
    # 22); the window opens at the start, for both drivers
    from cosim.run.metrics import follower_max_decel

    dt = 0.05
    t = np.arange(0.0, 12.0 + 1e-9, dt)
    a = np.where((t >= 2.0) & (t < 2.7), -4.5, 0.0)  # the SV's change starts at 2.0 s
    v = 31.0 + np.concatenate([[0.0], np.cumsum(a[:-1] * dt)])
    assert follower_max_decel(t, v, 2.0, 5.0) == pytest.approx(4.5)
    assert follower_max_decel(t, v, 3.5, 5.0) == 0.0  # from the crossing: unseen


def test_merge_crossing_stopped_time_and_start() -> None:
    """The merge columns' parts on a hand-made trace: the SV in lane 0, which
    ends at s = 190 m, crosses into lane 1 at t = 3 s (s = 75 m), having stood still for
    1 s; a crossing at or past the end is no merge."""
    from cosim.run.metrics import merge_crossing, merge_start, stopped_time

    t = np.arange(0.0, 6.0, 0.5)
    speed = np.array([0.0, 0.05, 5.0, 10, 20, 20, 20, 20, 20, 20, 20, 20])
    s = 20.0 + np.concatenate(([0.0], np.cumsum(speed[:-1] * 0.5)))
    lane = np.where(t >= 3.0, 1, 0)
    d = np.where(t < 2.0, -1.875, np.minimum(-1.875 + (t - 2.0) * 2.0, 1.875))
    cross, left, target = merge_crossing(t, s, lane, 190.0)
    assert cross == 3.0 and target == 1 and left == pytest.approx(190.0 - s[6])
    assert stopped_time(t, speed) == pytest.approx(1.0)
    assert merge_start(t, d, cross, -1.875) == pytest.approx(2.0)
    assert merge_crossing(t, s, np.zeros(12, dtype=int), 190.0)[2] == -1
    assert math.isnan(merge_crossing(t, s, lane, s[6])[0])  # crossed only at the end
    assert math.isnan(merge_crossing(t, s, lane, math.inf)[0])  # no lane end


def test_a_merge_is_watched_until_the_sv_leaves_the_lane_centre_again() -> None:
    """merge_end: the SV reaches lane 1's centre (1.875 m) at 4 s, an aborted change
    takes it 0.5 m off from 8.0 to 9.0 s and back; the merge's watch ends at 7.5 s, the
    last sample at the centre (a window ended only by a change crossing out ran on to
    the run's end). Staying: the last sample; never reaching the centre: the crossing
    out of the lane entered."""
    from cosim.run.metrics import merge_end

    t = np.arange(0.0, 12.0, 0.5)
    d = np.minimum(-1.875 + t, 1.875)
    lane = np.where(d > 0.0, 1, 0)
    aborted = d + np.where((t >= 8.0) & (t <= 9.0), 0.5, 0.0)
    assert merge_end(t, aborted, lane, 2.0, 1.875) == 7.5
    assert merge_end(t, d, lane, 2.0, 1.875) == 11.5
    passing = -1.875 + t  # on into lane 2 (d > 3.75) without settling in lane 1
    lanes = np.digitize(passing, [0.0, 3.75])
    assert merge_end(t, passing, lanes, 2.0, 1.875) == 6.0


def test_follower_needed_decel_brings_it_to_the_svs_speed_at_the_minimum_gap() -> None:
    from cosim.run.metrics import SUMO_MIN_GAP, follower_needed_decel

    # 30 -> 25 m/s over 12.5 - 2.5 = 10 m: v^2 = 25 + 2 a 10 -> a = 1.25 m/s^2
    assert follower_needed_decel(12.5, 30.0, 25.0) == pytest.approx(1.25, rel=1e-12)
    need = follower_needed_decel(40.0, 33.0, 20.0)
    # braking at that rate it reaches the SV's speed exactly at SUMO's minimum gap
    # (the SV keeping its speed): its closing distance is (v_f - v_sv)^2 / (2 a)
    assert 40.0 - (33.0 - 20.0) ** 2 / (2.0 * need) == pytest.approx(SUMO_MIN_GAP, abs=1e-9)
    assert follower_needed_decel(1.0, 25.0, 25.0) == 0.0  # not closing: nothing needed
    assert follower_needed_decel(2.0, 26.0, 25.0) == math.inf  # closing within 2.5 m


def test_window_min_takes_the_window_only() -> None:
    from cosim.run.metrics import window_min

    t = np.arange(0.0, 10.0 + 1e-9, 0.5)
    ttc = np.where(t < 2.0, 0.5, 10.0 - t)  # 0.5 s before the window, then falling
    assert window_min(t, ttc, 2.0, 3.0) == pytest.approx(5.0)
    assert window_min(t, ttc, 20.0, 3.0) == math.inf
    assert math.isnan(window_min(t, ttc, math.nan, 3.0))


def test_polyline_distance_and_lane_keeping_offset_against_shapely() -> None:
    import shapely

    from cosim.run.metrics import lane_keeping_offset, polyline_distance

    rng = np.random.default_rng(7)
    shape = np.cumsum(rng.uniform(-5.0, 20.0, size=(12, 2)), axis=0)
    points = rng.uniform(shape.min(axis=0) - 10.0, shape.max(axis=0) + 10.0, size=(300, 2))
    line = shapely.LineString(shape)
    expected = shapely.distance(line, shapely.points(points))
    assert np.allclose(polyline_distance(points, shape), expected, atol=1e-9, rtol=0.0)
    # the largest over the steps on a known lane that keep their lane only
    ids = np.where(np.arange(300) % 3 == 0, "other", "a_0")
    keeping = np.arange(300) % 2 == 0
    on = (ids == "a_0") & keeping
    assert lane_keeping_offset(points[:, 0], points[:, 1], ids.tolist(), keeping,
                               {"a_0": [tuple(p) for p in shape]}) == pytest.approx(
        expected[on].max(), abs=1e-9)
    assert math.isnan(lane_keeping_offset(points[:, 0], points[:, 1], ids.tolist(),
                                          np.zeros(300, dtype=bool), {"a_0": shape}))
