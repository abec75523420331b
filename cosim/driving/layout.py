"""The lanes as the driving layer sees them: which lane a lateral position is in, where
a lane's centre is, which lanes a vehicle's body touches, the nearest vehicles ahead
and behind along a lane, and each lane's speed band.

The policies, the decision rules and the gap choice ask a `LaneLayout` these questions
and never compare a lateral position with a lane width themselves: today it is backed by
the straight road's equal lanes (`cosim.params.RoadParams`, lane 0 the rightmost, SUMO's
index); a road frame (s, d) along a curved route can back the same questions later, d in
place of y and s in place of x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.driving.view import TrafficView
from cosim.params import RoadParams
from cosim.run.proximity import lane_neighbours

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Neighbours:
    """Nearest vehicles ahead and behind the SV in one lane (index -1: none)."""

    lane: int
    leader: int  # index into the TV arrays, -1: none
    gap_ahead: float  # m, bumper to bumper (inf: none)
    leader_speed: float  # m/s (nan: none)
    follower: int  # index, -1: none
    gap_behind: float  # m (inf: none)
    follower_speed: float  # m/s (nan: none)


def _floats(a: ArrayLike) -> Array:
    return np.ascontiguousarray(a, dtype=float)


@dataclass(frozen=True)
class LaneLayout:
    """The lanes of the road the SV drives (module docstring)."""

    road: RoadParams

    @property
    def n_lanes(self) -> int:
        return self.road.n_lanes

    def lane_of(self, y: float) -> int:
        """The lane whose strip holds lateral position y (m; clipped to the road)."""
        return self.road.lane_of(y)

    def centre(self, lane: int) -> float:
        """m, lateral position of a lane's centre line."""
        return self.road.lane_center(lane)

    def speed_limit(self, lane: int) -> float:
        """m/s, the top of a lane's speed band."""
        return self.road.speed_bands[lane][1]

    def end_s(self, lane: int) -> float:
        """m, s where a lane ends (inf: it runs to the end of the route)."""
        return self.road.lane_end(lane)

    def begin_s(self, lane: int) -> float:
        """m, s where a lane begins beside the others (-inf: at the route's start)."""
        return self.road.lane_begin(lane)

    def end_speed(self, origin: int, target: int) -> float:
        """m/s, the band rule's speed at the end of a change from `origin` to `target`
        (Section 3.1, Fig. 5)."""
        return self.road.target_speed(origin, target)

    def lanes_touched(self, y: ArrayLike, half_width: ArrayLike) -> tuple[Array, Array]:
        """Lowest and highest lane index each body's lateral extent (centre y, m, and
        half width, m) touches (a vehicle belongs to every lane it touches)."""
        road = self.road
        yy = np.asarray(y, dtype=float)
        hw = np.asarray(half_width, dtype=float)
        lo = np.floor((yy - hw - road.y_right) / road.lane_width)
        hi = np.floor((yy + hw - road.y_right) / road.lane_width)
        return lo, hi

    def neighbours(self, lane: int, sv_x: float, sv_length: float, traffic: TrafficView, *,
                   leaving: bool = False) -> Neighbours:
        """The leader and follower in `lane` (TVs touching that lane) of an SV at centre
        `sv_x` (m), the gaps bumper to bumper along the lane (a compiled loop:
        cosim.run.proximity).

        `leaving`: a TV whose centre is already in another lane and that moves away from
        `lane` (by its lateral speed, when known) does not count."""
        road = self.road
        v = _floats(traffic.speed)
        vy = traffic.lateral_speed if leaving else None
        use_vy = vy is not None
        i_lead, gap_ahead, i_foll, gap_behind = lane_neighbours(
            int(lane), float(sv_x), float(sv_length), _floats(traffic.x), _floats(traffic.y),
            _floats(traffic.length), _floats(traffic.width), float(road.y_right),
            float(road.lane_width), _floats(vy) if use_vy else np.zeros(0), use_vy)
        return Neighbours(
            lane=lane,
            leader=i_lead,
            gap_ahead=float(gap_ahead),
            leader_speed=float(v[i_lead]) if i_lead >= 0 else math.nan,
            follower=i_foll,
            gap_behind=float(gap_behind),
            follower_speed=float(v[i_foll]) if i_foll >= 0 else math.nan,
        )
