"""The traffic in road coordinates: a snapshot's Cartesian poses turned into the road
frame's (s, d) (cosim.road.frame), the form every part between SUMO and the plant
works in (the policy, the planner, V2V, the recorder's gaps).

In a snapshot seen this way `x` is s (m along the route's reference line), `y` is d
(m left of the reference track's right border), `heading` is relative to the road's
tangent at s, and `speed` / `accel` are along s: a car following its lane at offset d
covers ds = v dt / q with q = 1 - kappa (d - d_offset), the frame's stretch there
(the planner's straight-road method then holds in (s, d) as it did in (x, y); the
controller turns its reference speed back with the same q,
cosim.control.reference.frame_path_errors). The Cartesian poses stay beside them
(`cx`, `cy`, `ch`) for the exact overlap check and the x-y figures.

On a one-edge straight road at the origin (StraightFrame, x0 = y0 = 0) the view is the
identity and the snapshot is returned as it is.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from cosim.road.frame import ArcFrame, StraightFrame
from cosim.road.tracks import via_chain
from cosim.traffic.snapshot import TrafficSnapshot

if TYPE_CHECKING:
    from cosim.road.road import Road
    from cosim.traffic.route_lanes import Upstream


def is_identity(frame: StraightFrame | ArcFrame) -> bool:
    """The frame maps (x, y) to itself (s = x, d = y, heading and speed unchanged)."""
    return isinstance(frame, StraightFrame) and frame.x0 == 0.0 and frame.y0 == 0.0


def stretch(frame: StraightFrame | ArcFrame, s: np.ndarray | float,
            d: np.ndarray | float, kappa: np.ndarray | float | None = None
            ) -> np.ndarray | float:
    """-, q = 1 - kappa(s) (d - d_offset): a path at offset d is q times as long as the
    reference line over the same s (`kappa`: the line's curvature at s, if known)."""
    offset = getattr(frame, "d_offset", 0.0)
    k = frame.curvature(s) if kappa is None else kappa
    return 1.0 - k * (np.asarray(d) - offset)


def road_view(snap: TrafficSnapshot, frame: StraightFrame | ArcFrame,
              s_hint: float | None) -> TrafficSnapshot:
    """The snapshot in road coordinates (module docstring); `s_hint` (m): where to start
    the search along the line (e.g. the SV's s a step ago). A vehicle the frame does not
    reach (far inside a bend, on another road) gets NaN."""
    if is_identity(frame) or not len(snap):
        return snap
    if isinstance(frame, ArcFrame):  # one compiled pass (ArcFrame.view)
        s, d, rel, q = frame.view(snap.x, snap.y, snap.heading, s_hint)
    else:
        s, d = frame.to_frenet(snap.x, snap.y, s_hint=s_hint)
        s, d = np.asarray(s, dtype=np.float64), np.asarray(d, dtype=np.float64)
        theta, kappa = frame.tangent(s)
        rel = (snap.heading - theta + np.pi) % (2.0 * np.pi) - np.pi  # into [-pi, pi)
        q = stretch(frame, s, d, kappa)
    return replace(snap, x=s, y=d, heading=rel, speed=snap.speed / q, accel=snap.accel / q,
                   cx=snap.x, cy=snap.y, ch=snap.heading)


def cartesian_pose(frame: StraightFrame | ArcFrame, s: float, d: float,
                   heading: float) -> tuple[float, float, float, float]:
    """(x, y, heading, q) of a pose given in road coordinates (heading relative to the
    road): the inverse of `road_view` for one vehicle."""
    if is_identity(frame):
        return s, d, heading, 1.0
    x, y, theta = frame.to_cartesian(s, d)
    return float(x), float(y), float(theta) + heading, float(stretch(frame, s, d))


@dataclass(frozen=True)
class UpstreamLane:
    """A lane before the carriageway edge of a route from an on-ramp that feeds one of
    its through tracks (the mainline beside the ramp, cosim.traffic.route_lanes.Upstream):
    the frame there runs along the ramp, so a vehicle on it is placed by its lane
    position instead, as if the track ran on back along it."""

    track: int  # the track it feeds
    begin: float  # m, s where that track begins
    junction: float  # m, SUMO's length of the junction's lanes between the two
    d: float  # m, d of the track's centre there
    length: float  # m, SUMO's length of the lane
    shape: np.ndarray  # m, SUMO's centre line of the lane, (n, 2)


def upstream_lanes(route_road: Road, upstream: Mapping[int, Upstream]
                   ) -> dict[str, UpstreamLane]:
    """SUMO lane id -> `UpstreamLane` of the lanes feeding the through tracks of a route
    whose carriageway edge is not its first (`upstream`: RouteLanes.upstream); empty on
    every other route (their vehicles are read by their pose alone)."""
    if route_road.lead_in is None:
        return {}
    out = {}
    for track, up in upstream.items():
        if up.joins == 0:
            continue
        table = route_road.lane(track)
        net = route_road.route.net
        lane = net.getLane(f"{up.edge}_{up.index}")
        into = [c for c in lane.getOutgoing()
                if c.getToLane().getID() == table.track.pieces[0].lane]
        junction = sum(float(v.getLength()) for v in via_chain(net, into[0])) if into else 0.0
        out[lane.getID()] = UpstreamLane(track, table.begin, junction,
                                         float(table.centre(table.begin)), up.length,
                                         np.asarray(lane.getShape(), dtype=float))
    return out


def place_upstream(seen: TrafficSnapshot, frame: StraightFrame | ArcFrame, api: ModuleType,
                   lanes: Mapping[str, UpstreamLane], skip: str) -> TrafficSnapshot:
    """`seen` (a `road_view`) with the vehicles on `lanes` placed by their lane position:
    s = the track's begin less the junction, the rest of the lane to its end and half the
    vehicle (where its pose puts it once its front is in the junction), d =
    the track's centre there plus the vehicle's offset from its lane's centre, heading
    relative to the lane, speed along it (SUMO's own). Only vehicles whose track is one
    of those lanes' and whose s lies near or before that track's begin are asked for their
    lane (`skip`: a vehicle never on them, the SV)."""
    if not lanes or not len(seen):
        return seen
    begins: dict[int, float] = {}
    for up in lanes.values():
        begins[up.track] = max(begins.get(up.track, -np.inf), up.begin)
    rows = [i for i, (vid, k) in enumerate(zip(seen.ids, seen.lane.tolist(), strict=True))
            if vid != skip and k in begins and seen.x[i] <= begins[k] + UPSTREAM_REACH]
    if not rows:
        return seen
    x, y, heading = seen.x.copy(), seen.y.copy(), seen.heading.copy()
    speed, accel = seen.speed.copy(), seen.accel.copy()
    vehicle = api.vehicle
    for i in rows:
        up = lanes.get(vehicle.getLaneID(seen.ids[i]))
        if up is None:
            continue
        front = float(vehicle.getLanePosition(seen.ids[i]))
        q = float(stretch(frame, x[i], y[i]))
        speed[i], accel[i] = speed[i] * q, accel[i] * q  # SUMO's own, along the lane
        x[i] = up.begin - up.junction - (up.length - front) - 0.5 * float(seen.length[i])
        y[i] = up.d + float(vehicle.getLateralLanePosition(seen.ids[i]))
        assert seen.ch is not None
        heading[i] = (float(seen.ch[i]) - _lane_angle(up, front) + np.pi) % (2 * np.pi) - np.pi
    return replace(seen, x=x, y=y, heading=heading, speed=speed, accel=accel)


UPSTREAM_REACH = 10.0  # m, past a track's begin a vehicle's pose may still be on the lane
# before it (the junction between): such a vehicle is asked for its lane too


def _lane_angle(up: UpstreamLane, offset: float) -> float:
    """rad, the direction of the lane's centre line `offset` m from its start (SUMO's
    lane positions stretched onto its shape)."""
    seg = np.diff(up.shape, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    cum = np.cumsum(lengths)
    at = offset * cum[-1] / up.length if up.length > 0 else offset
    k = min(int(np.searchsorted(cum, at)), len(seg) - 1)
    return float(np.arctan2(seg[k, 1], seg[k, 0]))
