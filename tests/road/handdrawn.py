"""Hand-drawn SUMO networks for tests, the way real ones come from netconvert: plain
node and edge XML, curves drawn as coarse polylines that kink at every vertex,
netconvert's default 2-decimal output (used by tests/road and tests/test_own_network)."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from cosim.traffic.network import NETWORK_DIR, netconvert_binary


def arc(x0: float, y0: float, h0: float, radius: float, length: float,
        step: float) -> list[tuple[float, float]]:
    """The vertices, every `step` m, of a left curve of `radius` and `length` from
    (x0, y0) at heading h0 (the start itself not included)."""
    n = int(round(length / step))
    return [(x0 + radius * (math.sin(h0 + i * step / radius) - math.sin(h0)),
             y0 - radius * (math.cos(h0 + i * step / radius) - math.cos(h0)))
            for i in range(1, n + 1)]


def netconvert(tmp: Path, nodes: str, edges: str, name: str = "n",
               options: tuple[str, ...] = ()) -> Path:
    """`tmp/<name>.net.xml` built by netconvert from the <nodes> and <edges> documents
    (with netconvert's `options` added)."""
    (tmp / f"{name}.nod.xml").write_text(nodes, encoding="utf-8")
    (tmp / f"{name}.edg.xml").write_text(edges, encoding="utf-8")
    out = tmp / f"{name}.net.xml"
    subprocess.run([netconvert_binary(), "-n", f"{name}.nod.xml", "-e", f"{name}.edg.xml",
                    "-o", out.name, "--no-turnarounds", "true", *options], cwd=tmp, check=True,
                   capture_output=True)
    return out


def curved_route(tmp: Path, step: float, *, radius: float = 2000.0, length: float = 1000.0,
                 curve_lanes: int = 2, bridge_x: float = 500.0, speed: float = 33.3) -> Path:
    """A -> B straight (1 km, 3 lanes); B -> C a left curve of `radius` and `length` drawn
    every `step` m with `curve_lanes` lanes (2: the rightmost lane ends at B); a road
    X1 -> X2 crossing A-B at x = `bridge_x` (a bridge: no junction)."""
    curve = arc(1000.0, 0.0, 0.0, radius, length, step)
    cx, cy = curve[-1]
    shape = " ".join(f"{x:.2f},{y:.2f}" for x, y in [(1000.0, 0.0), *curve])
    return netconvert(
        tmp,
        "<nodes>"
        '<node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        f'<node id="C" x="{cx:.2f}" y="{cy:.2f}"/>'
        f'<node id="X1" x="{bridge_x:g}" y="-200"/><node id="X2" x="{bridge_x:g}" y="200"/>'
        "</nodes>",
        "<edges>"
        f'<edge id="AB" from="A" to="B" numLanes="3" speed="{speed:g}"/>'
        f'<edge id="BC" from="B" to="C" numLanes="{curve_lanes}" speed="{speed:g}" '
        f'shape="{shape}"/>'
        '<edge id="X" from="X1" to="X2" numLanes="1" speed="13.9"/>'
        "</edges>")


def ramp_curve(tmp: Path, radius: float, turn_deg: float = 90.0, speed: float = 11.1,
               name: str = "ramp_curve") -> Path:
    """A one-lane ramp: A -> B straight (200 m), B -> C a left curve of `radius` turning
    `turn_deg` drawn every 2 m, C -> D straight (200 m); edges AB, BC, CD."""
    turn = math.radians(turn_deg)
    curve = arc(200.0, 0.0, 0.0, radius, radius * turn, 2.0)
    cx, cy = curve[-1]
    dx, dy = cx + 200.0 * math.cos(turn), cy + 200.0 * math.sin(turn)
    shape = " ".join(f"{x:.2f},{y:.2f}" for x, y in [(200.0, 0.0), *curve])
    return netconvert(
        tmp,
        '<nodes><node id="A" x="0" y="0"/><node id="B" x="200" y="0"/>'
        f'<node id="C" x="{cx:.2f}" y="{cy:.2f}"/><node id="D" x="{dx:.2f}" y="{dy:.2f}"/>'
        "</nodes>",
        f'<edges><edge id="AB" from="A" to="B" numLanes="1" speed="{speed:g}"/>'
        f'<edge id="BC" from="B" to="C" numLanes="1" speed="{speed:g}" shape="{shape}"/>'
        f'<edge id="CD" from="C" to="D" numLanes="1" speed="{speed:g}"/></edges>',
        name=name)


def corners_in_lanes(result: Any, grow: float = 0.02) -> bool:
    """The SV's four corners inside the union of SUMO's lanes of the run's route (each
    lane shape buffered by half its width, the union grown by `grow` m) at every step."""
    lanes = shapely.union_all([
        shapely.LineString(p.shape).buffer(0.5 * p.width, cap_style="flat")
        for t in result.route_road.tracks for p in t.pieces]).buffer(grow)
    tr, veh = result.trace, result.scenario.vehicle
    c, s = np.cos(np.radians(tr["psi_deg"])), np.sin(np.radians(tr["psi_deg"]))
    for a, b in ((0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)):
        x = tr["x_m"] + a * veh.length * c - b * veh.width * s
        y = tr["y_m"] + a * veh.length * s + b * veh.width * c
        if not shapely.contains(lanes, shapely.points(np.column_stack([x, y]))).all():
            return False
    return True


def assert_rebuilt(tmp: Path, name: str, build: Any, stale: Any, main: Any) -> None:
    """A shipped network's builder writes networks/<name>.* byte for byte, and its
    staleness check and `--check` agree."""
    out = build(tmp)
    for suffix in (".nod.xml", ".edg.xml", ".con.xml", ".net.xml"):
        assert (tmp / f"{name}{suffix}").read_bytes() == \
            (NETWORK_DIR / f"{name}{suffix}").read_bytes(), suffix
    assert out.name == f"{name}.net.xml"
    assert stale() == []
    assert main(["--check"]) == 0


def weave(tmp: Path, name: str = "weave") -> Path:
    """A two-lane mainline (120 km/h) A -> B -> C -> D; an on-ramp (80 km/h) drawn straight
    up to B at 11.3 degrees adds lane 0 of BC (300 m), which leaves at C as the off-ramp,
    drawn straight away at 11.3 degrees (a weaving section); edges AB, BC, CD, on, off."""
    nodes = ('<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
             '<node id="C" x="1300" y="0"/><node id="D" x="2500" y="0"/>'
             '<node id="R0" x="600" y="-80"/><node id="R1" x="1700" y="-80"/></nodes>')
    edges = ('<edges><edge id="AB" from="A" to="B" numLanes="2" speed="33.33"/>'
             '<edge id="BC" from="B" to="C" numLanes="3" speed="33.33"/>'
             '<edge id="CD" from="C" to="D" numLanes="2" speed="33.33"/>'
             '<edge id="on" from="R0" to="B" numLanes="1" speed="22.22"/>'
             '<edge id="off" from="C" to="R1" numLanes="1" speed="22.22"/></edges>')
    (tmp / f"{name}.con.xml").write_text(
        '<connections><connection from="on" to="BC" fromLane="0" toLane="0"/>'
        '<connection from="AB" to="BC" fromLane="0" toLane="1"/>'
        '<connection from="AB" to="BC" fromLane="1" toLane="2"/>'
        '<connection from="BC" to="off" fromLane="0" toLane="0"/>'
        '<connection from="BC" to="CD" fromLane="1" toLane="0"/>'
        '<connection from="BC" to="CD" fromLane="2" toLane="1"/></connections>',
        encoding="utf-8")
    return netconvert(tmp, nodes, edges, name, ("-x", f"{name}.con.xml"))
