"""How hard the TVs the SV asked to make room brake, as the SV sees them; and an
automated vehicle making room for another that asked it (`MakingRoom`).

A TV asked to yield (the traffic's courtesy or cooperative V2V, cosim.traffic.cooperation)
brakes to open a gap behind the SV. The gap policy may start its change while such a TV
is still braking, counting on it to go on until the SV is in its lane (the courtesy
held, `GapDecision.held`), as SUMO's own informed followers do for SUMO's lane
changers: its entry test then predicts that TV at the braking seen here
(cosim.planning.interaction.check_follower). What is seen, not what was asked: a TV
that did not honour a request, or already has its gap, shows no braking.
"""

from __future__ import annotations

import functools
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig, idm_acceleration
from cosim.driving.view import TrafficView
from cosim.traffic.cooperation import COURTESY_DECEL

YIELD_WINDOW = 0.25  # s, the braking is the mean over this long (a single step's speed
# change carries SUMO's dawdling, up to 0.52 m/s^2, which a braking Krauss car adds to
# its braking)
# tuned: docs/tuned_constants.md
MIN_YIELD_DECEL = 1.0  # m/s^2, less is not counted on: a TV that yields that gently stops
# braking once it has its openGap headway (the SV speeds up away from it), and its
# Krauss braking at the SV's entry flips from ~0 to its decel within 1 m/s of speed
# tuned: docs/tuned_constants.md
MAX_YIELD_DECEL = COURTESY_DECEL  # m/s^2, no more is counted on (what courtesy brakes at most)


@dataclass
class YieldWatch:
    """The speeds of the TVs asked to yield over the last YIELD_WINDOW."""

    window: float = YIELD_WINDOW
    _seen: dict[str, deque[tuple[float, float]]] = field(default_factory=dict)

    def asked(self, tv_id: str) -> None:
        """`tv_id` was asked to make room: watch it from now on."""
        self._seen.setdefault(tv_id, deque())

    def braking(self, t: float, ids: tuple[str, ...], speed: NDArray[np.float64]
                ) -> NDArray[np.float64]:
        """m/s^2 (>= 0, one per TV of `ids` with speeds `speed` at time t): the mean braking
        of each watched TV over the window, capped at MAX_YIELD_DECEL; 0 below
        MIN_YIELD_DECEL, for the TVs not watched and for a TV seen for less than half
        the window. Records this step's speeds."""
        out = np.zeros(len(ids))
        for tv_id in list(self._seen):  # the few TVs asked, not the traffic
            if tv_id not in ids:  # gone from the scene
                del self._seen[tv_id]
                continue
            k = ids.index(tv_id)
            seen = self._seen[tv_id]
            seen.append((t, float(speed[k])))
            while seen[0][0] < t - self.window - 1e-9:
                seen.popleft()
            t0, v0 = seen[0]
            if t - t0 >= 0.5 * self.window - 1e-9:
                b = min((v0 - seen[-1][1]) / (t - t0), MAX_YIELD_DECEL)
                out[k] = b if b >= MIN_YIELD_DECEL else 0.0
        return out


ROOM_TIME_GAP = 2.0  # s, the headway an automated vehicle asked for room (V2V) opens to the
# one that asked, as SUMO's drivers do for the courtesy (cosim.traffic.cooperation)
ROOM_DURATION = 10.0  # s, how long it makes room at most (the courtesy's duration)


@dataclass
class MakingRoom:
    """An automated vehicle asked by another (over V2V, cosim.run.announcements) to make
    room: while it keeps its lane (and seeks no gap itself: the gap policy's `_drive`)
    it follows the one that asked as its leader, at
    ROOM_TIME_GAP and braking at most COURTESY_DECEL, as SUMO's drivers follow the SV
    for the traffic's courtesy; until that one is in its lane or behind it, gone, or
    ROOM_DURATION has passed."""

    requester: str | None = None
    until: float = -np.inf  # s

    def asked(self, t: float, vehicle_id: str) -> None:
        self.requester, self.until = vehicle_id, t + ROOM_DURATION

    def accel(self, t: float, x: float, length: float, speed: float, lane: int,
              traffic: TrafficView, lanes: LaneLayout, cfg: DecisionConfig) -> float:
        """m/s^2, the most it accelerates now to make room (inf: nothing to make room for;
        the request ends then)."""
        vid = self.requester
        if vid is None:
            return np.inf
        k = traffic.ids.index(vid) if vid in traffic.ids else -1
        if (t > self.until or k < 0 or float(traffic.x[k]) <= x
                or lanes.lane_of(float(traffic.y[k])) == lane):
            self.requester = None  # gone, behind it, or in its lane (its leader now)
            return np.inf
        gap = float(traffic.x[k] - 0.5 * traffic.length[k]) - (x + 0.5 * length)
        a = idm_acceleration(speed, np.inf, gap, float(traffic.speed[k]),
                             _room_config(cfg))
        return max(a, -COURTESY_DECEL)


@functools.lru_cache(maxsize=8)
def _room_config(cfg: DecisionConfig) -> DecisionConfig:
    return replace(cfg, idm_time_gap=ROOM_TIME_GAP)
