"""An OpenStreetMap motorway for tests, imported the way users import theirs: OSM XML
(nodes in lat / lon, the motorway split into several ways, a curve drawn as a coarse
polyline with a node every 60 m, an on-ramp and an off-ramp as motorway_link ways, a
road crossing on a bridge) through netconvert's OSM import with the options of SUMO's
OSM tutorial (ramps guessed: netconvert adds an acceleration and a deceleration lane)."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

from cosim.traffic.network import netconvert_binary

LAT0, LON0, EARTH_RADIUS = 52.5, 13.4, 6378137.0  # deg, deg, m
# the motorway edges netconvert makes of the ways (the ramps guessed split way 101)
ROUTE = ["100", "101-AddedOnRampEdge", "101", "101-AddedOffRampEdge", "103"]


def _lat_lon(x: float, y: float) -> tuple[float, float]:
    return (LAT0 + math.degrees(y / EARTH_RADIUS),
            LON0 + math.degrees(x / (EARTH_RADIUS * math.cos(math.radians(LAT0)))))


def motorway_osm(step: float = 60.0, radius: float = 1200.0) -> str:
    """OSM XML: 1.2 km straight, a left curve of `radius` over 1.5 km with a node every
    `step` m, 0.6 km straight; three lanes, 120 km/h; an on-ramp joining 900 m in, an
    off-ramp leaving in the curve; a primary road crossing at x = 600 m on a bridge."""
    pts = [(i * step, 0.0) for i in range(int(1200 / step) + 1)]
    arc = 1500.0
    pts += [(1200 + radius * math.sin(i * step / radius),
             radius * (1 - math.cos(i * step / radius))) for i in range(1, int(arc / step) + 1)]
    (ax, ay), h = pts[-1], arc / radius
    pts += [(ax + i * step * math.cos(h), ay + i * step * math.sin(h)) for i in range(1, 11)]
    nodes = {k + 1: p for k, p in enumerate(pts)}
    j_on, j_off = 16, 46
    (ox, oy), (fx, fy) = nodes[j_on], nodes[j_off]
    hf = math.atan2(nodes[j_off + 1][1] - fy, nodes[j_off + 1][0] - fx)
    nodes |= {910: (ox - 400, oy - 45), 911: (ox - 200, oy - 12),
              920: (fx + 200 * math.cos(hf) + 15 * math.sin(hf),
                    fy + 200 * math.sin(hf) - 15 * math.cos(hf)),
              921: (fx + 400 * math.cos(hf) + 60 * math.sin(hf),
                    fy + 400 * math.sin(hf) - 60 * math.cos(hf)),
              900: (600, -300), 901: (600, 300)}
    motorway = ('<tag k="highway" v="motorway"/><tag k="lanes" v="3"/>'
                '<tag k="oneway" v="yes"/><tag k="maxspeed" v="120"/>')
    link = '<tag k="highway" v="motorway_link"/><tag k="oneway" v="yes"/><tag k="lanes" v="1"/>'
    bridge = '<tag k="highway" v="primary"/><tag k="bridge" v="yes"/><tag k="layer" v="1"/>'
    cuts = [1, j_on, 30, j_off, len(pts)]
    ways = [(100 + w, list(range(cuts[w], cuts[w + 1] + 1)), motorway) for w in range(4)]
    ways += [(300, [910, 911, j_on], link), (301, [j_off, 920, 921], link),
             (200, [900, 901], bridge)]
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="cosim">']
    out += [f'<node id="{k}" lat="{la:.7f}" lon="{lo:.7f}" version="1"/>'
            for k, (x, y) in nodes.items() for la, lo in [_lat_lon(x, y)]]
    out += [f'<way id="{w}" version="1">' + "".join(f'<nd ref="{r}"/>' for r in refs)
            + tags + "</way>" for w, refs, tags in ways]
    return "\n".join([*out, "</osm>", ""])


def import_osm(tmp: Path, osm: str, name: str = "osm") -> Path:
    """`tmp/<name>.net.xml` from OSM XML by netconvert's OSM import."""
    (tmp / f"{name}.osm").write_text(osm, encoding="utf-8")
    out = tmp / f"{name}.net.xml"
    subprocess.run([netconvert_binary(), "--osm-files", f"{name}.osm", "-o", out.name,
                    "--geometry.remove", "--ramps.guess", "--junctions.join",
                    "--keep-edges.by-vclass", "passenger", "--output.original-names"],
                   cwd=tmp, check=True, capture_output=True)
    return out
