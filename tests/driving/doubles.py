"""Test doubles the policy tests share (tests/driving): the V2V inbox, the real planner
with forced outcomes, and the SV flown exactly along its reference."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

from cosim.planning.planner import LaneChangePlanner, Rejection
from cosim.traffic.world import SVState


@dataclass
class Inbox:
    """The policy's messages; `reads` counts how often it read them."""

    messages: list[Any] = field(default_factory=list)
    reads: int = 0

    def read(self) -> list[Any]:
        self.reads += 1
        return list(self.messages)


@dataclass
class Forced:
    """The real planner, with forced outcomes: `collide` makes the next re-checks report
    a collision; a target lane in `no_tau` gets a plan without a trajectory."""

    real: LaneChangePlanner
    collide: int = 0
    no_tau: set[int] = field(default_factory=set)
    calls: list[tuple[str, int]] = field(default_factory=list)

    def plan(self, t: float, state: Any, target: int, messages: list[Any], occupant: float,
             vxf: float | None = None, x_limit: float = math.inf,
             max_curvature: float = math.inf, max_tau: float = math.inf,
             max_accel: float = math.inf) -> Any:
        self.calls.append(("plan", target))
        plan = self.real.plan(t, state, target, messages, occupant, vxf, x_limit=x_limit,
                              max_curvature=max_curvature, max_tau=max_tau,
                              max_accel=max_accel)
        if target in self.no_tau:
            return replace(plan, tau=None, trajectory=None)
        return plan

    def check(self, trajectory: Any, t: float, messages: list[Any]) -> Rejection | None:
        self.calls.append(("check", -1))
        if self.collide:
            self.collide -= 1
            return Rejection(tau=trajectory.tau, reason="collision", vehicle_id="tv",
                             time=t + 1)
        return None


def fly(reference: Any, t: float) -> SVState:
    """The SV exactly where the policy's `reference` trajectory says at time t: its
    position, heading and speed along it (no plant)."""
    x, y = reference.position(t)
    xd, yd = reference.derivative(t, 1)
    return SVState(float(x), float(y), math.atan2(float(yd), float(xd)), float(xd), 0.0, 0.0)
