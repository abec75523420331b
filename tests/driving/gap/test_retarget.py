"""The end speed of a change under way re-targeted to a new leader that slowed
(cosim.driving.gap.retarget), on hand-made numbers."""

from __future__ import annotations

import pytest

from cosim.driving.gap.retarget import (
    RETARGET_DECEL,
    RETARGET_MEAN_DECEL,
    RETARGET_MIN_TIME,
    end_speed,
)


def braking_after(v: float, vx: float, left: float, gap: float, v_l: float) -> float:
    """m/s^2, the constant braking that matches v_l from end speed v (1 s, 2.5 m kept)."""
    room = gap + v_l * left - 0.5 * (vx + v) * left - (2.5 + v_l)
    return (v - v_l) ** 2 / (2.0 * room)


def test_a_leader_that_slowed_close_ahead_re_targets_the_end_speed() -> None:
    # the merge's case: the plan ends at 27.9 m/s, a leader 45 m ahead at 20.3 m/s
    v = end_speed(27.9, 25.0, 0.0, 3.0, 45.0, 20.3, 1.0, 2.5)
    assert v is not None and 20.3 < v < 27.9
    # the highest end speed the car following settles within RETARGET_DECEL
    assert braking_after(v, 25.0, 3.0, 45.0, 20.3) == pytest.approx(RETARGET_DECEL)
    # with little time left, no lower than the mean braking allows
    assert end_speed(27.9, 27.0, 0.0, 1.0, 20.0, 20.3, 1.0, 2.5) == pytest.approx(
        27.0 - RETARGET_MEAN_DECEL * 1.0)
    # no room at all: the leader's speed
    assert end_speed(27.9, 21.0, 0.0, 3.0, 5.0, 20.3, 1.0, 2.5) == pytest.approx(20.3)


def test_a_gap_the_car_following_settles_gently_keeps_the_plan() -> None:
    assert braking_after(27.9, 25.0, 2.0, 70.0, 20.3) <= RETARGET_DECEL
    assert end_speed(27.9, 25.0, 0.0, 2.0, 70.0, 20.3, 1.0, 2.5) is None
    assert end_speed(27.9, 25.0, 0.0, 2.0, 30.0, 27.6, 1.0, 2.5) is None  # barely slower
    assert end_speed(27.9, 25.0, 0.0, RETARGET_MIN_TIME - 0.1, 30.0, 20.3, 1.0, 2.5) is None
