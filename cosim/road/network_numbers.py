"""The numbers of a SUMO network that SUMO and cosim can use, checked when it is read.

sumolib reads `length="nan"`, `speed="inf"` or a shape point `nan,0` as floats; SUMO
then stops at its start on some (raw "Error:" lines) and drives on others into
meaningless positions. So every lane of a network, internal ones included when read,
is held to one rule before anything else reads it:

- length, speed and width finite numbers >= 0, not subnormal (SUMO refuses to parse
  those: "Invalid Number Format"); the length of a lane of a normal edge and every width
  above 0 (internal lanes may be 0 m long; a speed of 0 is the road's own rules' business);
- every shape point and junction position finite and within MAX_COORDINATE of the
  origin: float64 keeps about 1e-7 m there, while near 1e15 m it keeps only 0.125 m, and
  positions computed from such coordinates drift by metres within seconds.
"""

from __future__ import annotations

import math
import sys
from typing import Any

# m, the largest |x|, |y| (or |z|) a network may have; far beyond any real place's
# distance from its projection's origin
MAX_COORDINATE = 1e9
SMALLEST_NORMAL = sys.float_info.min  # below it (and not 0): subnormal, SUMO cannot parse it
RULE = ("lane lengths and widths finite and > 0, speeds finite and >= 0, coordinates finite within "
        "1e9 m of the origin (netconvert --offset.x / --offset.y moves a network nearer it)")


def _usable(x: float) -> bool:
    return math.isfinite(x) and (x == 0.0 or abs(x) >= SMALLEST_NORMAL)


def network_numbers_problem(net: Any) -> tuple[str, str] | None:
    """The first number of the sumolib network `net` that breaks the module's rule, as
    (what it is, its value), e.g. ("lane 'a_1' length", "nan"); None when all hold."""
    for edge in net.getEdges(withInternal=True):
        internal = edge.getFunction() == "internal"
        for lane in edge.getLanes():
            name = f"lane {lane.getID()!r}"
            for what, value, least in (("length", lane.getLength(), not internal),
                                       ("speed", lane.getSpeed(), False),
                                       ("width", lane.getWidth(), True)):
                if not _usable(value) or value < 0 or (least and value == 0):
                    return f"{name} {what}", f"{value!r}"
            for point in lane.getShape3D():
                if not all(_usable(v) and abs(v) <= MAX_COORDINATE for v in point):
                    return f"{name} shape", ",".join(f"{v:g}" for v in point)
    for node in net.getNodes():
        coord = node.getCoord3D()
        if not all(_usable(v) and abs(v) <= MAX_COORDINATE for v in coord):
            return f"junction {node.getID()!r} position", ",".join(f"{v:g}" for v in coord)
    return None
