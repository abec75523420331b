"""The plans log (plans.csv): its columns, what asked for each row (`Trigger`), and the
rows a policy writes to it, one per planner call (`plan_row`) or per scripted request
that did not go through the planner (`request_row`); and the planner as a policy calls
it (`PlannerCalls`, each call timed).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from enum import StrEnum
from typing import Any

from cosim.planning.planner import LANE_END


class Trigger(StrEnum):
    """What asked for a plan (plans.csv `trigger`)."""

    SCRIPTED = "scripted"  # a scripted request ([sv] lane_changes)
    DECISION = "decision"  # the policy's decision rule
    RETRY = "retry"  # a scripted request asked again after a failed plan
    MANDATORY = "mandatory"  # the SV's lane ends ahead (cosim.driving.lane_end)
    REPLAN = "replan"  # the re-check: a new plan to the target lane
    ABORT = "abort"  # the re-check: back to the origin lane
    BRAKE = "brake"  # the re-check: brake in the nearest lane


RESCUES = (Trigger.REPLAN, Trigger.ABORT, Trigger.BRAKE)  # the re-check's outcomes, in
# the order the metrics row counts them
NOT_ADJACENT = "not an adjacent lane"  # why a scripted request was dropped (`rejections`)

PLAN_COLUMNS: dict[str, str] = {
    "t_s": "simulation time of the planning request (s)",
    "trigger": "scripted | decision | retry | mandatory (the SV's lane ends ahead: "
    "cosim.planning.deadline) | replan | abort | brake (re-check outcomes)",
    "origin_lane": "lane the SV is in (SUMO index)",
    "target_lane": "lane requested (SUMO index)",
    "vx0_mps": "SV speed at the request (m/s)",
    "vxf_mps": "target speed at the end of the lane change (band rule) (m/s)",
    "n_candidates": "number of tau values on the grid",
    "tau_min_stable_s": "smallest stable tau (handling envelope) (s)",
    "stable_set_s": "stable tau set as intervals a-b;c-d (s)",
    "collision_free_set_s": "collision-free tau set (intervals) (s)",
    "tau_opt_s": "tau_opt of eq. 13 over the collision-free set (s)",
    "tau_s": "tau chosen (collision-free tau nearest tau_opt) (s; NaN: no plan)",
    "ok": "1: a plan was adopted, 0: no collision-free tau (the SV keeps its lane)",
    "rejected_unstable": "candidates rejected by the handling envelope",
    "rejected_collision": "candidates rejected for a collision",
    "rejections": "collisions per TV id, id:count;id:count, and 'lane end:count' for taus "
    "whose plan would end past the lane's end (or why the request was dropped)",
    "reason": "replan | abort | brake rows: why the plan under way was dropped (the re-check's "
    "first collision); else empty",
}


def _fmt_intervals(spans: list[tuple[float, float]]) -> str:
    return ";".join(f"{a:.2f}-{b:.2f}" for a, b in spans)


def plan_row(plan: Any, trigger: Trigger, vx0: float) -> dict[str, Any]:
    """One plans.csv row of a planner's Plan (see PLAN_COLUMNS)."""
    per_tv: dict[str, int] = {}
    n_unstable = n_late = 0
    for rej in plan.rejections:
        if rej.reason == "unstable":
            n_unstable += 1
        elif rej.reason == LANE_END:
            n_late += 1
        else:
            key = rej.vehicle_id or "?"
            per_tv[key] = per_tv.get(key, 0) + 1
    return {
        "t_s": plan.t,
        "trigger": trigger,
        "origin_lane": plan.origin_lane,
        "target_lane": plan.target_lane,
        "vx0_mps": vx0,
        "vxf_mps": plan.vxf,
        "n_candidates": int(plan.taus.size),
        "tau_min_stable_s": plan.tau_min,
        "stable_set_s": _fmt_intervals(plan.stable_intervals),
        "collision_free_set_s": _fmt_intervals(plan.collision_free_intervals),
        "tau_opt_s": plan.tau_opt,
        "tau_s": math.nan if plan.tau is None else float(plan.tau),
        "ok": int(plan.tau is not None),
        "rejected_unstable": n_unstable,
        "rejected_collision": sum(per_tv.values()),
        "rejections": ";".join([f"{k}:{v}" for k, v in sorted(per_tv.items())]
                               + ([f"{LANE_END}:{n_late}"] if n_late else [])),
        "reason": "",
    }


def request_row(t: float, origin: int, target: int, vx0: float, ok: int,
                why: str = "") -> dict[str, Any]:
    """A plans.csv row of a scripted request that did not go through the planner (one
    dropped, or one handed to SUMO's lane-change model)."""
    row = dict.fromkeys(PLAN_COLUMNS, math.nan)
    row.update(t_s=t, trigger=Trigger.SCRIPTED, origin_lane=origin, target_lane=target, vx0_mps=vx0,
               ok=ok, stable_set_s="", collision_free_set_s="", rejections=why)
    return row


class PlannerCalls:
    """The planner (cosim.planning.planner.LaneChangePlanner, or a double with its
    `plan` and `check`) as a policy calls it: each call timed into `wall` (s); the
    occupant's weight in eq. 13 (`occupant`) and the policy's longest manoeuvre
    (`max_tau`, s; inf: eq. 13 alone) given with every plan."""

    def __init__(self, planner: Any, occupant: float, max_tau: float = math.inf) -> None:
        self.planner = planner
        self.occupant = occupant
        self.max_tau = max_tau
        self.wall = 0.0  # s, wall time in the planner (and in a policy's own check)

    @contextmanager
    def timed(self) -> Iterator[None]:
        """Time the block into `wall`."""
        w0 = time.perf_counter()
        try:
            yield
        finally:
            self.wall += time.perf_counter() - w0

    def plan(self, t: float, state: Any, target: int, messages: list[Any], *,
             vxf: float | None = None, x_limit: float = math.inf,
             curvature: float = math.inf, max_tau: float | None = None,
             accel: float = math.inf) -> Any:
        """The planner's Plan from `state` (SVPlanState) to `target` at t (ending at `vxf`,
        m/s, None: the band rule's speed; at centre x <= `x_limit`, m; its path bending
        at most `curvature`, 1/m; at most `max_tau`, s, None: the policy's; accelerating
        at most `accel`, m/s^2)."""
        with self.timed():
            return self.planner.plan(t, state, target, messages, self.occupant, vxf=vxf,
                                     x_limit=x_limit, max_curvature=curvature, max_accel=accel,
                                     max_tau=self.max_tau if max_tau is None else max_tau)

    def check(self, trajectory: Any, t: float, messages: list[Any]) -> Any:
        """The planner's collision check of `trajectory` from t against fresh predictions:
        its first collision (a Rejection), None when there is none."""
        with self.timed():
            return self.planner.check(trajectory, t, messages)
