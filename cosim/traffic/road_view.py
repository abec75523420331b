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

from dataclasses import replace

import numpy as np

from cosim.road.frame import ArcFrame, StraightFrame
from cosim.traffic.snapshot import TrafficSnapshot


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
