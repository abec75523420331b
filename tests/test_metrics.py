"""Tests of cosim.metrics: IAE, gaps/TTC between rectangles, jerk, lane-change durations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.metrics import (
    count_onsets,
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
        0.0, 0.0, 25.0, hx, hy,
        tv_x=[20.0, -30.0, 10.0], tv_y=[0.2, -0.3, 3.75], tv_vx=[20.0, 30.0, 0.0],
        tv_hx=[hx] * 3, tv_hy=[hy] * 3,
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
    gap, ttc = gap_ttc(0.0, 0.0, 20.0, hx, hy, [10.0, 3.0], [0.0, 0.0], [25.0, 20.0],
                       [hx, hx], [hy, hy])
    assert math.isinf(ttc[0]) and gap[0] > 0
    assert gap[1] < 0 and ttc[1] == 0.0


def test_lateral_overlap_threshold_is_the_sum_of_half_widths() -> None:
    hx, hy = half_extents(4.32, 1.8, 0.0)
    gap, _ = gap_ttc(0.0, 0.0, 20.0, hx, hy, [10.0, 10.0], [1.79, 1.81], [20.0, 20.0],
                     [hx, hx], [hy, hy])
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


def test_count_onsets_counts_each_contact_once() -> None:
    flags = np.array([[0, 0], [1, 0], [1, 0], [0, 1], [1, 1]], dtype=bool)
    assert count_onsets(flags) == 3
    assert count_onsets(np.zeros(0, dtype=bool)) == 0


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
