"""A small motorway with an on-ramp and an off-ramp as netconvert connects them, for the
tests of routes that start on an on-ramp and leave over an off-ramp.

Along +x, two lanes of 3.75 m (the left borders at y = 7.5, lanes spread to the right):

    a (0-600) -> acc (600-800, 3 lanes) -> b (800-1500) -> dec (1500-1700, 3 lanes) -> c (-2500)
    onramp -> acc (lane 0, the acceleration lane: no connection onward)
    dec (lane 0, the deceleration lane, begins at x = 1500) -> offramp

The ramps are drawn as netconvert users draw them: a straight at 12 degrees and a curve of
R 500 m drawn every 10 m, tangent to the mainline at the gore (the on-ramp's lane runs on
as the acceleration lane, the deceleration lane runs on as the off-ramp's)."""

from __future__ import annotations

import math
from pathlib import Path

from handdrawn import netconvert

RADIUS = 500.0  # m, the ramps' curve
TURN = math.radians(12.0)  # rad, the ramps' angle to the mainline before the curve
LEAD = 150.0  # m, the ramps' straight
STEP = 10.0  # m, vertex spacing on the curves
SPEED = 33.33  # m/s, the mainline (120 km/h)
RAMP_SPEED = 22.22  # m/s, the ramps (80 km/h)


def _curve(x_gore: float, into: bool) -> list[tuple[float, float]]:
    """The ramp's left border from its far end to the gore at (x_gore, 0) (`into`: the
    on-ramp, else from the gore away: the off-ramp)."""
    n = int(round(RADIUS * TURN / STEP))
    phis = [TURN * i / n for i in range(n + 1)]
    arc = [(x_gore + (-1 if into else 1) * RADIUS * math.sin(p), -RADIUS * (1 - math.cos(p)))
           for p in phis]
    x, y = arc[-1]
    far = (x + (-1 if into else 1) * LEAD * math.cos(TURN), y - LEAD * math.sin(TURN))
    points = [*arc, far]
    return points[::-1] if into else points


def _mainline(eid: str, a: str, b: str, lanes: int, xs: dict[str, float], top: float) -> str:
    """A straight mainline edge from node a to node b (x from `xs`, y = top)."""
    return (f'<edge id="{eid}" from="{a}" to="{b}" numLanes="{lanes}" speed="{SPEED}" '
            f'width="3.75" spreadType="right" shape="{xs[a]:g},{top:g} {xs[b]:g},{top:g}"/>')


def _ramp(eid: str, a: str, b: str, points: list[tuple[float, float]], lanes: int = 1) -> str:
    """A ramp edge from node a to node b along `points`."""
    shape = " ".join(f"{x:.2f},{y:.2f}" for x, y in points)
    return (f'<edge id="{eid}" from="{a}" to="{b}" numLanes="{lanes}" speed="{RAMP_SPEED}" '
            f'width="3.75" spreadType="right" shape="{shape}"/>')


def _net(directory: Path, name: str, nodes: dict[str, tuple[float, float]], edges: str,
         links: list[tuple[str, str, list[tuple[int, int]]]]) -> Path:
    """`directory/name.net.xml` from its nodes (id -> x, y), edges and lane connections."""
    node_xml = "".join(f'<node id="{k}" x="{x:.2f}" y="{y:.2f}" type="priority"/>'
                       for k, (x, y) in nodes.items())
    cons = "".join(f'<connection from="{a}" to="{b}" fromLane="{i}" toLane="{j}"/>'
                   for a, b, pairs in links for i, j in pairs)
    (directory / f"{name}.con.xml").write_text(f"<connections>{cons}</connections>",
                                               encoding="utf-8")
    return netconvert(directory, f"<nodes>{node_xml}</nodes>", f"<edges>{edges}</edges>",
                      name, ("-x", f"{name}.con.xml"))


def build(directory: Path) -> Path:
    """`directory/ramps.net.xml`, built by netconvert."""
    top = 7.5
    xs = {"n0": 0.0, "g1": 600.0, "e1": 800.0, "d1": 1500.0, "g2": 1700.0, "n5": 2500.0}
    on, off = _curve(600.0, True), _curve(1700.0, False)
    nodes = {k: (x, top) for k, x in xs.items()} | {"r0": on[0], "r9": off[-1]}
    edges = "".join(_mainline(e, a, b, n, xs, top) for e, a, b, n in (
        ("a", "n0", "g1", 2), ("acc", "g1", "e1", 3), ("b", "e1", "d1", 2),
        ("dec", "d1", "g2", 3), ("c", "g2", "n5", 2)))
    edges += _ramp("onramp", "r0", "g1", on) + _ramp("offramp", "g2", "r9", off)
    links = [("a", "acc", [(0, 1), (1, 2)]), ("onramp", "acc", [(0, 0)]),
             ("acc", "b", [(1, 0), (2, 1)]), ("b", "dec", [(0, 1), (1, 2)]),
             ("dec", "c", [(1, 0), (2, 1)]), ("dec", "offramp", [(0, 0)])]
    return _net(directory, "ramps", nodes, edges, links)


def build_weave(directory: Path) -> Path:
    """`directory/weave.net.xml`: the ramps of `build` 100 m apart (b 800-900 m), so that
    a route from the on-ramp over the off-ramp (`onramp acc b dec offramp`) is short:
    the acceleration lane ends 100 m before the deceleration lane begins, both on the
    mainline's right (lane 0 of `acc` and of `dec`)."""
    top = 7.5
    xs = {"n0": 0.0, "g1": 600.0, "e1": 800.0, "d1": 900.0, "g2": 1100.0, "n5": 1400.0}
    on, off = _curve(600.0, True), _curve(1100.0, False)
    nodes = {k: (x, top) for k, x in xs.items()} | {"r0": on[0], "r9": off[-1]}
    edges = "".join(_mainline(e, a, b, n, xs, top) for e, a, b, n in (
        ("a", "n0", "g1", 2), ("acc", "g1", "e1", 3), ("b", "e1", "d1", 2),
        ("dec", "d1", "g2", 3), ("c", "g2", "n5", 2)))
    edges += _ramp("onramp", "r0", "g1", on) + _ramp("offramp", "g2", "r9", off)
    links = [("a", "acc", [(0, 1), (1, 2)]), ("onramp", "acc", [(0, 0)]),
             ("acc", "b", [(1, 0), (2, 1)]), ("b", "dec", [(0, 1), (1, 2)]),
             ("dec", "c", [(1, 0), (2, 1)]), ("dec", "offramp", [(0, 0)])]
    return _net(directory, "weave", nodes, edges, links)


DROP_AT = 450.0  # m, where the dropping ramp's one lane becomes the right lane of two


def build_dropped(directory: Path) -> Path:
    """`directory/dropped.net.xml`: the on-ramp of `build` with its last 150 m two lanes
    wide (edge `ramp2`, x 450-600, its left border on the gore's line y = 0): the ramp's
    one lane (`onramp`) runs on as ramp2's right lane, which ends at the gore (no
    connection onward); ramp2's left lane runs on as the acceleration lane acc_0, as on
    SUMO's game/highway ramp. The mainline as in `build`, to the end of b."""
    top = 7.5
    xs = {"n0": 0.0, "g1": 600.0, "e1": 800.0, "d1": 1500.0}
    on = [(x, y - 3.75) for x, y in _curve(DROP_AT, True)]
    nodes = {k: (x, top) for k, x in xs.items()} | {"r0": on[0], "r1": (DROP_AT, 0.0)}
    edges = "".join(_mainline(e, a, b, n, xs, top) for e, a, b, n in (
        ("a", "n0", "g1", 2), ("acc", "g1", "e1", 3), ("b", "e1", "d1", 2)))
    edges += (_ramp("onramp", "r0", "r1", on)
              + _ramp("ramp2", "r1", "g1", [(DROP_AT, 0.0), (600.0, 0.0)], lanes=2))
    links = [("a", "acc", [(0, 1), (1, 2)]), ("onramp", "ramp2", [(0, 0)]),
             ("ramp2", "acc", [(1, 0)]), ("acc", "b", [(1, 0), (2, 1)])]
    return _net(directory, "dropped", nodes, edges, links)
