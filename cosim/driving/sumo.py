"""The SUMO-driven SV's policy (controller "sumo", the baseline): scripted requests
become lane changes SUMO makes (the `change_lane` port, with SUMO's safety checks),
SUMO's own lane-change model decides the rest (`[sv] decision`); the car-following
values are computed for the trace only. Its lane changes are read off the path."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cosim.driving.base import DrivingContext, Manoeuvres, Messages, PolicyStatus
from cosim.driving.following import CarFollowing
from cosim.driving.layout import LaneLayout
from cosim.driving.plans import RESCUES, request_row
from cosim.driving.registry import register
from cosim.run.metrics import SETTLE_TOL

if TYPE_CHECKING:
    from cosim.traffic.world import Scene, SVState

Array = NDArray[np.float64]

SIDEWAYS_SPEED = 0.05  # m/s, the SUMO-driven SV moving sideways faster is changing lanes


@register("sumo")
class SumoPolicy:
    """The module docstring's policy."""

    listens = False
    needs_planner = False
    asks_for_gaps = False
    prediction = None

    def __init__(self, ctx: DrivingContext) -> None:
        self.lanes = ctx.lanes
        self.change_lane = ctx.ports.change_lane
        self.decision = ctx.sv.decision
        self.following = CarFollowing(ctx, ctx.decision)
        self.pending = list(ctx.sv.lane_changes)
        self.plans: list[dict[str, object]] = []
        self.requests = 0
        self.wall = 0.0

    def status(self, sv: SVState) -> PolicyStatus:
        # no plan: moving sideways is its lane change
        return PolicyStatus(target_lane=None, changing=False,
                            manoeuvring=abs(sv.vy) > SIDEWAYS_SPEED,
                            leader_gap=self.following.leader_gap,
                            idm_accel=self.following.accel)

    def gaps_held(self, sv: SVState) -> bool:
        """No planned change (`asks_for_gaps` false): always true."""
        return True

    def update(self, t: float, scene: Scene, messages: Messages) -> None:
        sv = scene.sv
        lane = self.lanes.lane_of(sv.y)
        while self.pending and self.pending[0].at <= t + 1e-9:
            target = self.pending.pop(0).target_lane
            if target == lane:
                continue
            self.requests += 1
            self.change_lane(target)
            self.plans.append(request_row(t, lane, target, sv.vx, 1))
            break
        # the gap to the leader, for the trace (SUMO's own model follows it)
        self.following.v_ref = sv.vx
        self.following.update(sv, scene, allow_change=False)

    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
        """Lane changes read off the path; with `[sv] decision` SUMO's own model decided,
        and each change it made beyond the scripted ones was its request."""
        starts, targets, ends = excursions(t, y, self.lanes)
        requests = self.requests
        if self.decision:
            requests += max(len(starts) - self.requests, 0)
        return Manoeuvres(
            lane_changes=[], starts=starts, targets=targets, ends=ends, requests=requests,
            planner_calls=0, outcomes=dict.fromkeys(RESCUES, 0),
            first_start=None, plans=self.plans)


def excursions(t: Array, y: Array, lanes: LaneLayout) -> tuple[list[float], list[float],
                                                               list[float]]:
    """Lane changes read off a path: each time the SV leaves one lane centre band
    (|y - centre| < SETTLE_TOL) and next enters another's. Returns starts, target
    centres and window ends: the next change's start, the run's end for the last (as a
    manoeuvre log has them: a change followed by another is read as never settled, its
    run as failed)."""
    centres = np.array([lanes.centre(k) for k in range(lanes.n_lanes)])
    dist = np.abs(y[:, None] - centres[None, :])
    at = np.flatnonzero(dist.min(axis=1) < SETTLE_TOL)  # samples in a centre band
    home = dist[at].argmin(axis=1)
    moved = np.flatnonzero(home[1:] != home[:-1])  # the last sample in the old band
    starts: list[float] = np.asarray(t, dtype=float)[at[moved]].tolist()
    targets: list[float] = centres[home[moved + 1]].tolist()
    ends = [*starts[1:], float(t[-1])] if starts else []
    return starts, targets, ends
