"""Our two-track plant against CommonRoad's multi-body model (MB) on its vehicle2, with
our plant set up as MB is (`commonroad_cases`): small-slip yaw gain and step steer as
close to MB as CommonRoad's own single-track model (ST) is, braking in a turn on mu 1.0
and 0.4 within stated yaw-rate RMS differences (issue 15)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytest.importorskip("vehiclemodels")
sys.path.insert(0, str(Path(__file__).parent))
import commonroad_cases as cc  # noqa: E402

CASES = {m.name: m for m in cc.manoeuvres()}


@pytest.fixture(scope="module")
def mb_runs() -> dict:
    return {name: cc.run_mb(m) for name, m in CASES.items()}


def test_steady_yaw_gain_within_3_percent_of_mb(mb_runs) -> None:
    """0.01 rad at 80 km/h, 6 s: MB 0.0879 rad/s, ours 0.0861 (-2 %), ST 0.0862."""
    name = "steady yaw gain, 0.01 rad"
    ours, mb = cc.run_ours(CASES[name]), mb_runs[name]
    assert ours[-1, 1] == pytest.approx(mb[-1, 1], rel=0.03)
    assert cc.rms(ours, mb) < 0.004  # 0.0019 measured, ST 0.0018


def test_step_steer_as_close_to_mb_as_st(mb_runs) -> None:
    """A step to 1.5 m/s^2 (0.4 rad/s steering ramp): yaw-rate RMS against MB 0.0015
    rad/s, as ST's."""
    name = "step steer to 1.5 m/s^2"
    m = CASES[name]
    ours, mb, st = cc.run_ours(m), mb_runs[name], cc.run_st(m)
    assert cc.rms(ours, mb) < 0.004
    assert cc.rms(ours, mb) < 1.5 * cc.rms(st, mb) + 0.001


def test_braking_in_a_turn_on_mu_1(mb_runs) -> None:
    """80 km/h at 0.5 mu g, then 0.5 mu g of braking (66 % front) for 2 s: yaw-rate RMS
    against MB below 0.06 rad/s (0.040 measured; issue 15 found 0.175 with the
    friction-circle tyre). What else moves the gap: without our anti-lock logic (MB has
    none: its inner wheels lock) 0.081, with Table 1's roll split 0.55 instead of MB's
    0.514 0.056."""
    name = "braking in a turn, mu 1"
    m, mb = CASES[name], mb_runs[name]
    gap = cc.rms(cc.run_ours(m, cc.our_chassis(anti_lock=True)), mb)
    assert gap < 0.06
    no_abs = cc.rms(cc.run_ours(m, cc.our_chassis(anti_lock=False)), mb)
    other_split = cc.rms(cc.run_ours(m, cc.our_chassis(anti_lock=True, roll_share=0.55)), mb)
    assert no_abs > 1.5 * gap and other_split > 1.2 * gap


def test_braking_in_a_turn_on_mu_0_4(mb_runs) -> None:
    """The same on mu 0.4 (MB's p_dx1, p_dy1 x 0.4): nothing locks; RMS 0.0043 rad/s
    (ST 0.0057)."""
    name = "braking in a turn, mu 0.4"
    m, mb = CASES[name], mb_runs[name]
    assert cc.rms(cc.run_ours(m, cc.our_chassis(anti_lock=True)), mb) < 0.01
