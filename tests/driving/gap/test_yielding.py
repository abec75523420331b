"""The braking of the TVs the SV asked to make room, as it sees it
(cosim.driving.gap.yielding)."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.driving.gap.yielding import MAX_YIELD_DECEL, MIN_YIELD_DECEL, YIELD_WINDOW, YieldWatch

DT = 0.05


def watch_steps(watch: YieldWatch, ids: tuple[str, ...], speeds: list[list[float]]
                ) -> np.ndarray:
    """Feed one row of speeds a step; return the last step's braking."""
    out = np.zeros(len(ids))
    for k, row in enumerate(speeds):
        out = watch.braking(k * DT, ids, np.array(row))
    return out


def test_only_the_asked_tvs_are_watched_over_the_window() -> None:
    w = YieldWatch()
    w.asked("b")
    ids = ("a", "b", "c")
    # a and c brake too, but were not asked; b brakes at 1.5 m/s^2 with dawdling on top
    rng = np.random.default_rng(1)
    rows = [[30.0 - 2.0 * DT * k, 30.0 - 1.5 * DT * k - 0.02 * rng.random(),
             25.0 - 3.0 * DT * k] for k in range(20)]
    b = watch_steps(w, ids, rows)
    assert b[0] == 0.0 and b[2] == 0.0
    assert b[1] == pytest.approx(1.5, abs=0.02 / YIELD_WINDOW + 1e-9)


def test_a_speeding_up_gently_braking_or_barely_seen_tv_counts_as_no_braking() -> None:
    w = YieldWatch()
    w.asked("a")
    assert watch_steps(w, ("a",), [[20.0], [19.9]])[0] == 0.0  # seen for 0.05 s only
    # cooperative V2V's 0.5 m/s^2 plus dawdling reads 0.75: not counted on
    gentle = YieldWatch()
    gentle.asked("a")
    assert watch_steps(gentle, ("a",), [[20.0 - 0.75 * DT * k] for k in range(10)])[0] == 0.0
    just = YieldWatch()
    just.asked("a")
    firm = MIN_YIELD_DECEL + 0.01
    b = watch_steps(just, ("a",), [[20.0 - firm * DT * k] for k in range(10)])
    assert b[0] == pytest.approx(firm, abs=1e-9)
    w2 = YieldWatch()
    w2.asked("a")
    assert watch_steps(w2, ("a",), [[20.0 + 0.1 * k] for k in range(10)])[0] == 0.0


def test_the_braking_counted_on_is_capped_and_a_gone_tv_forgotten() -> None:
    w = YieldWatch()
    w.asked("a")
    hard = watch_steps(w, ("a", "b"), [[30.0 - 6.0 * DT * k, 20.0] for k in range(10)])
    assert hard[0] == MAX_YIELD_DECEL
    assert w.braking(0.5, ("b",), np.array([20.0]))[0] == 0.0
    assert w.braking(0.55, ("a", "b"), np.array([10.0, 20.0]))[0] == 0.0  # watched no more


def test_making_room_follows_the_one_that_asked_until_it_is_in() -> None:
    """Asked for room by an automated vehicle beside it and a little ahead, it brakes
    (at most COURTESY_DECEL) to open ROOM_TIME_GAP behind it; nothing once that one is
    in its lane, behind it, gone or the time is up."""
    from cosim.driving.gap.yielding import ROOM_DURATION, MakingRoom
    from cosim.driving.layout import LaneLayout
    from cosim.driving.rule import DecisionConfig
    from cosim.driving.view import TrafficView
    from cosim.params import RoadParams
    from cosim.traffic.cooperation import COURTESY_DECEL

    road = RoadParams()
    lanes = LaneLayout(road)

    def scene(x: float, lane: int) -> TrafficView:
        return TrafficView.arrays([x], [road.lane_center(lane)], [25.0], [4.5], [1.8],
                                  ids=("a",))

    room = MakingRoom()
    room.asked(1.0, "a")
    cfg = DecisionConfig()
    a = room.accel(1.5, 100.0, 4.5, 25.0, 1, scene(106.0, 0), lanes, cfg)
    assert a == pytest.approx(-COURTESY_DECEL)  # 1 m apart: as hard as the courtesy brakes
    a = room.accel(1.5, 100.0, 4.5, 25.0, 1, scene(160.0, 0), lanes, cfg)
    assert -COURTESY_DECEL < a < 1.0  # far ahead: little or nothing to do
    assert room.requester == "a"
    assert room.accel(1.6, 100.0, 4.5, 25.0, 1, scene(106.0, 1), lanes, cfg) == np.inf
    assert room.requester is None  # it is in: the request is over
    room.asked(2.0, "a")
    assert room.accel(2.0, 100.0, 4.5, 25.0, 1, scene(95.0, 0), lanes, cfg) == np.inf
    room.asked(2.0, "a")
    assert room.accel(2.0 + ROOM_DURATION + 0.1, 100.0, 4.5, 25.0, 1, scene(106.0, 0),
                      lanes, cfg) == np.inf
