"""When a policy keeping its lane decides again: at a bounded rate, or at once on an event.

A policy's decision while it keeps its lane (the gap policy's: the lane it wants, the gap
there, the entry test of a change started now, the speed it drives) is most of an
automated vehicle's cost per step, and it changes little from one 0.05 s step to the
next while nothing around changes. An automated vehicle of the fleet (cosim.run.fleet)
therefore holds its last decision (its car-following acceleration, cosim.driving.following)
and decides again only

- once DECIDE_INTERVAL has passed since its last decision, or at once when
- its leader or its follower in its lane is another vehicle (one cut in, one left),
- its leader's speed is LEADER_SPEED_EVENT off the one at the last decision (it brakes),
- the gap to its leader is GAP_EVENT off the one the last decision predicted (the two
  speeds held),
- the speed the held acceleration takes the reference to crosses the speed it wants.

A lane change under way, a failed plan's wait, a request (a scripted change, a lane
that ends) and an acceleration still ramping to the one decided (its jerk limit,
cosim.driving.following) are the policy's own: it decides every step then. The SV decides every step
(no cadence): its outputs are those of a policy without one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cosim.driving.layout import Neighbours

# s, the longest a policy keeping its lane holds its decision (SUMO's drivers decide at
# their actionStepLength the same way); the events below catch what cannot wait
# tuned: docs/tuned_constants.md
DECIDE_INTERVAL = 0.5
LEADER_SPEED_EVENT = 0.5  # m/s, the leader's speed change since the decision that re-decides
# (a leader braking at 2 m/s^2 is seen within 0.25 s, at 5 m/s^2 within 0.1 s)
# tuned: docs/tuned_constants.md
GAP_EVENT = 1.0  # m, the gap's error against its prediction at the held speeds
# tuned: docs/tuned_constants.md


@dataclass(frozen=True)
class CadenceConfig:
    """How often a policy keeping its lane decides (module docstring)."""

    interval: float = DECIDE_INTERVAL  # s
    leader_speed: float = LEADER_SPEED_EVENT  # m/s
    gap: float = GAP_EVENT  # m


class Cadence:
    """One policy's last decision: when, and its neighbours then."""

    def __init__(self, cfg: CadenceConfig) -> None:
        self.cfg = cfg
        self.t = -math.inf  # s, the last decision
        self.leader = ""  # its leader's id then ("": none)
        self.follower = ""
        self.leader_speed = math.nan  # m/s
        self.gap = math.inf  # m
        self.speed = math.nan  # m/s, its own speed then

    def decided(self, t: float, speed: float, own: Neighbours, ids: tuple[str, ...]) -> None:
        """A decision at t, at `speed` (m/s), with these neighbours (`ids`: the TVs')."""
        self.t, self.speed = t, speed
        self.leader = ids[own.leader] if own.leader >= 0 else ""
        self.follower = ids[own.follower] if own.follower >= 0 else ""
        self.leader_speed, self.gap = own.leader_speed, own.gap_ahead

    def due(self, t: float, own: Neighbours, ids: tuple[str, ...]) -> bool:
        """Whether to decide again at t (the module docstring's rate and events)."""
        cfg = self.cfg
        if t - self.t >= cfg.interval - 1e-9:
            return True
        leader = ids[own.leader] if own.leader >= 0 else ""
        follower = ids[own.follower] if own.follower >= 0 else ""
        if leader != self.leader or follower != self.follower:
            return True
        if not leader:
            return False
        if abs(own.leader_speed - self.leader_speed) > cfg.leader_speed:
            return True
        predicted = self.gap + (self.leader_speed - self.speed) * (t - self.t)
        return abs(own.gap_ahead - predicted) > cfg.gap
