"""The bench's loop transcription of the paper's procedure finds the planner's sets."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cosim.bench.planner import dense_situation, loop_plan, paper_situation
from cosim.planning.planner import LaneChangePlanner


def _coarse(planner: LaneChangePlanner) -> LaneChangePlanner:
    cfg = replace(planner.config, tau_step=0.25)  # a coarse grid keeps the loop quick
    return LaneChangePlanner(planner.vehicle, planner.road, cfg)


def _agree(sit: tuple) -> np.ndarray:  # type: ignore[type-arg]
    planner, t, sv, target, messages, occupant = sit
    planner = _coarse(planner)
    plan = planner.plan(t, sv, target, messages, occupant)
    on_grid = np.isin(np.round(plan.taus, 9), np.round(planner.grid, 9))
    loop = loop_plan(planner, t, sv, target, messages)
    np.testing.assert_array_equal(plan.collision_free[on_grid], loop)
    return loop


def test_loop_agrees_on_paper_case_1() -> None:
    free = _agree(paper_situation("paper_case1_overtaking"))
    assert free.any() and not free.all()


def test_loop_agrees_on_the_dense_case() -> None:
    planner, t, sv, target, messages, occupant = dense_situation()
    assert len(messages) == 20
    assert sum(m.intention != 0 for m in messages) == 5
    _agree((planner, t, sv, target, messages, occupant))


def test_loop_agrees_when_planning_mid_manoeuvre() -> None:
    """A start off the lane centre with lateral speed and accelerations: the general
    cluster, the envelope run directly (no map) and the unordered fallbacks."""
    from cosim.planning.planner import SVPlanState

    planner, t, sv, target, messages, occupant = paper_situation("paper_case1_overtaking")
    planner = _coarse(planner)
    mid = SVPlanState(sv.x, sv.y + 0.4, 0.02, sv.vx, 0.3, 0.5, 0.2, sv.lane)
    plan = planner.plan(t, mid, target, messages, occupant)
    assert plan.trajectory is not None
    assert plan.trajectory.vy0 == 0.5 and plan.trajectory.y_final == planner.road.lane_center(1)
    on_grid = np.isin(np.round(plan.taus, 9), np.round(planner.grid, 9))
    loop = loop_plan(planner, t, mid, target, messages)
    np.testing.assert_array_equal(plan.collision_free[on_grid], loop)
    assert loop.any() and not loop.all()


def test_step_loop_agrees_on_paper_case_2() -> None:
    """The loop with no vectorisation (time outer, TV inner, scalar tests) too."""
    from cosim.bench.planner import step_loop_plan

    planner, t, sv, target, messages, occupant = paper_situation("paper_case2_tv_lane_change")
    planner = _coarse(planner)
    free = step_loop_plan(planner, t, sv, target, messages)
    np.testing.assert_array_equal(free, loop_plan(planner, t, sv, target, messages))
    assert free.any() and not free.all()
