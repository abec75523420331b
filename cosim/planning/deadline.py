"""Lanes that end: which lane a vehicle on an ending lane must change into,
from when that change is due, and the latest a manoeuvre out of the lane may end.

The road says where each lane ends along s (`RoadParams.lane_ends`, inf: it runs on).
A vehicle on a lane that ends must make a *mandatory* lane change towards the nearest
lane that runs on past that end (`continuing_lane`; one lane at a time, the nearer
side first, the right one on a tie).

When it is due: SUMO's LC2013 (src/microsim/lcmodels/MSLCM_LC2013.cpp, `_wantsChange`)
makes a strategic change urgent once the distance left on the lane, divided by the
number of lanes to cross, is below its look-ahead
laDist = v * LOOK_FORWARD (10 s) * lcLookaheadLeft (2 for a change to the left, 1 to
the right) + 2 (length + minGap) (`currentDistDisallows`); `look_ahead` is that law, with
the vehicle's speed now (LC2013 lets its look-ahead speed decay slowly instead).
An acceleration lane of 200 m is inside it from its start at any speed above ~4 m/s:
the change is due as soon as the vehicle is on it, as SUMO's drivers want it.

Urgency: u = 1 - remaining / look-ahead, 0 when the change becomes due, 1 at the end
(`LaneEnd.urgency`); what a policy makes of it is its own (the gap policy's law:
cosim.driving.gap.decision).

Deadline: a manoeuvre out of the lane ends with the vehicle's front at least
END_MARGIN before the lane's end (`LaneEnd.x_limit`, the latest centre x at its end):
the planner drops every tau whose plan ends past it (`LaneChangePlanner.plan`'s
`x_limit`), and a TV's predicted change (C2) lists only durations that end before it
(`cosim.planning.prediction`). A TV on an ending lane within FORCE_TIME of its end that
does not signal is predicted as if it signalled towards the continuing lane
(`merging_messages`).

Vehicles are arrays where there are many (`merging_messages`); no loop over TVs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.params import RoadParams
from cosim.traffic.v2v import V2VMessage

Array = NDArray[np.float64]

LOOK_FORWARD = 10.0  # s, LC2013's LOOK_FORWARD (strategic look-ahead time)
LOOKAHEAD_LEFT = 2.0  # -, LC2013's lcLookaheadLeft default (a change to the left looks
# twice as far ahead)
MIN_GAP = 2.5  # m, SUMO's minGap in LC2013's 2 (length + minGap)
END_MARGIN = 2.0  # m, a manoeuvre out of an ending lane ends with the front this far
# before the end
FORCE_TIME = 5.0  # s, a TV that does not signal is predicted to merge once its lane's end
# is this close (v FORCE_TIME + 2 (length + minGap) per lane to cross): SUMO's drivers
# signal a strategic change as soon as they want it, so this is the fallback for one that
# has not; LC2013's whole look-ahead would give many large C2 clusters in a dense lane
# tuned: docs/tuned_constants.md
FORCE_MIN_SPEED = 1.0  # m/s, nor a TV slower than this (one standing in a queue stays C1
# until it signals: a C2 cluster from a standstill makes the collision check slow)
# tuned: docs/tuned_constants.md


def end_positions(road: RoadParams) -> Array:
    """m, s where each lane ends (inf: it runs on), one entry per lane."""
    return np.array([road.lane_end(k) for k in range(road.n_lanes)], dtype=float)


def ends_ahead(ends: Sequence[float], begins: Sequence[float], s: float) -> tuple[float, ...]:
    """m, where each lane ends ahead of `s` (m): `ends` but for a lane in two (its begin
    past its end: RoadParams.lane_begins) once `s` is past its first part's end, inf."""
    return tuple(math.inf if b > e and s >= e else e
                 for e, b in zip(ends, begins, strict=True))


@dataclass(frozen=True)
class EndPhases:
    """The lanes' ends and continuing lanes along s, for many vehicles at once: one row
    per stretch of s between the ends of the lanes in two (RoadParams.lane_begins), a
    single row on every other road."""

    breaks: Array  # m, the ends of the lanes in two, sorted
    ends: Array  # m, (phases, lanes): where each lane ends ahead (`ends_ahead`)
    target: NDArray[np.int_]  # (phases, lanes): the neighbour to change into (-1: none)
    crossings: Array  # (phases, lanes): lanes to cross to the continuing lane (0: none)

    @classmethod
    def of(cls, road: RoadParams) -> EndPhases:
        n = road.n_lanes
        begins = [road.lane_begin(k) for k in range(n)]
        base = [road.lane_end(k) for k in range(n)]
        breaks = np.array(road.split_ends(), dtype=float)
        rows = [base] + [list(ends_ahead(base, begins, float(b))) for b in breaks]
        target = np.full((len(rows), n), -1, dtype=int)
        crossings = np.zeros((len(rows), n))
        for p, row in enumerate(rows):  # stretches and lanes, not vehicles
            for k in range(n):
                nxt = continuing_lane(row, k)
                if nxt is not None:
                    target[p, k], crossings[p, k] = nxt
        return cls(breaks, np.array(rows, dtype=float), target, crossings)

    def phase(self, s: ArrayLike) -> NDArray[np.int_]:
        """The row of each vehicle at `s` (m)."""
        return np.searchsorted(self.breaks, np.asarray(s, dtype=float), side="right")


def continuing_lane(ends: Sequence[float], lane: int) -> tuple[int, int] | None:
    """(neighbour to change into, lanes to cross) for a vehicle on `lane` whose end is
    ends[lane] (m): towards the nearest lane that runs on past that end (the right one
    on a tie); None when the lane does not end or no lane runs on past it."""
    end_s = ends[lane]
    if not math.isfinite(end_s):
        return None
    on = [k for k in range(len(ends)) if ends[k] > end_s + 1e-6]
    if not on:
        return None
    k = min(on, key=lambda j: (abs(j - lane), j))
    return lane + (1 if k > lane else -1), abs(k - lane)


def look_ahead(speed: ArrayLike, length: ArrayLike, left: ArrayLike,
               crossings: ArrayLike) -> Array:
    """m, LC2013's strategic look-ahead (module docstring) for `crossings` lanes to
    cross: within it the change is due."""
    v = np.maximum(np.asarray(speed, dtype=float), 0.0)
    factor = np.where(np.asarray(left, dtype=bool), LOOKAHEAD_LEFT, 1.0)
    per_lane = v * LOOK_FORWARD * factor + 2.0 * (np.asarray(length, dtype=float) + MIN_GAP)
    return np.asarray(crossings, dtype=float) * per_lane


@dataclass(frozen=True)
class LaneEnd:
    """A vehicle's lane ends ahead: where, which lane to change into, and how urgent."""

    lane: int  # the lane that ends
    target: int  # the neighbour to change into
    end_s: float  # m, s of the lane's end
    remaining: float  # m, from the vehicle's front to the end
    horizon: float  # m, the look-ahead within which the change is due

    @property
    def due(self) -> bool:
        """The mandatory change is due (within the look-ahead)."""
        return self.remaining <= self.horizon

    @property
    def urgency(self) -> float:
        """-, 0 when the change becomes due, growing linearly to 1 at the end."""
        return float(min(max(1.0 - self.remaining / self.horizon, 0.0), 1.0))

    def x_limit(self, length: float) -> float:
        """m, the latest centre x of a vehicle of `length` at the end of a manoeuvre out
        of the lane (its front END_MARGIN before the end)."""
        return self.end_s - END_MARGIN - 0.5 * length


def end_ahead(ends: Sequence[float], lane: int, x: float, speed: float,
              length: float) -> LaneEnd | None:
    """The end of `lane` ahead of a vehicle (centre x, m; speed, m/s; length, m) on it,
    or None when the lane runs on or no lane runs on past its end."""
    nxt = continuing_lane(ends, lane)
    if nxt is None:
        return None
    target, crossings = nxt
    end_s = float(ends[lane])
    return LaneEnd(lane=lane, target=target, end_s=end_s,
                   remaining=end_s - (x + 0.5 * length),
                   horizon=float(look_ahead(speed, length, target > lane, crossings)))


def fit_speed(room: float, vx0: float, tau: float) -> float:
    """m/s (>= 0), the highest end speed of a manoeuvre of duration `tau` from `vx0` that
    moves the vehicle's centre at most `room` m (eq. 2 from x'' = 0: x(tau) - x0 =
    (vx0 + vxf) tau / 2)."""
    return max(2.0 * room / tau - vx0, 0.0)


def merging_messages(messages: Sequence[V2VMessage], road: RoadParams,
                     t: float) -> list[V2VMessage]:
    """The messages with every TV that must leave its lane signalling it: a TV without a
    broadcast motion or intention, on a lane that ends ahead of it within FORCE_TIME
    (`look_ahead`'s law with FORCE_TIME for LOOK_FORWARD, no left factor), is given the
    intention towards the continuing lane (C2; its predicted change then ends before
    the lane's end: cosim.planning.prediction). Unchanged when no lane ends."""
    out = list(messages)
    if not road.lane_ends or not out:
        return out
    phases = EndPhases.of(road)
    n = road.n_lanes
    y = np.array([m.y for m in out])
    lane = np.clip(np.floor((y - road.y_right) / road.lane_width).astype(int), 0, n - 1)
    x = np.array([m.x + m.speed * (t - m.t) for m in out])
    v = np.array([m.speed for m in out])
    length = np.array([m.length for m in out])
    quiet = np.array([m.motion is None and m.intention == 0 for m in out])
    p = phases.phase(x)
    # direction of the change (0: none) and lanes to cross, per vehicle
    target = phases.target[p, lane]
    d = np.where(target >= 0, target - lane, 0)
    remaining = phases.ends[p, lane] - (x + 0.5 * length)
    near = phases.crossings[p, lane] * (np.maximum(v, 0.0) * FORCE_TIME
                                        + 2.0 * (length + MIN_GAP))
    due = quiet & (d != 0) & (remaining > 0.0) & (remaining <= near) & (v >= FORCE_MIN_SPEED)
    for i in np.flatnonzero(due):
        out[i] = replace(out[i], intention=int(d[i]))
    return out


def c2_deadline(x0: Array, v0: Array, vxf: Array, length: Array, end_s: Array,
                taus: Array) -> NDArray[np.bool_]:
    """(n, n_tau) which durations of each C2 TV's cluster (from centre x0, speed v0 to
    vxf, eq. 2 from x'' = 0) end with its front END_MARGIN before its lane's end at
    `end_s` (m; inf: all)."""
    x_end = x0[:, None] + 0.5 * (v0 + vxf)[:, None] * taus[None, :]
    return x_end + 0.5 * length[:, None] + END_MARGIN <= end_s[:, None]
