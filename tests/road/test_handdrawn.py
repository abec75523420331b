"""A network drawn the way real ones come: coarse polylines that kink at single
vertices, a lane that ends, a road crossing over the route on a bridge (netconvert,
default connections)."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
import shapely

from cosim.errors import InputError
from cosim.road.frame import FrameLimits
from cosim.road.road import load_road
from cosim.traffic.network import netconvert_binary


def _arc(x0: float, y0: float, h0: float, radius: float, length: float, step: float):
    pts, h = [], h0
    n = int(round(length / step))
    for i in range(1, n + 1):
        h1 = h0 + (i * step) / radius
        pts.append((x0 + radius * (math.sin(h1) - math.sin(h0)),
                    y0 - radius * (math.cos(h1) - math.cos(h0))))
        h = h1
    return pts, h


def build(tmp: Path, step: float) -> Path:
    """A -> B straight 3 lanes; B -> C a left curve of R 2000 m drawn every `step` m with
    2 lanes (the rightmost lane ends at B); a road X1 -> X2 crossing A-B (a bridge)."""
    curve, _ = _arc(1000.0, 0.0, 0.0, 2000.0, 1000.0, step)
    cx, cy = curve[-1]
    (tmp / "n.nod.xml").write_text(
        "<nodes>"
        '<node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        f'<node id="C" x="{cx:.2f}" y="{cy:.2f}"/>'
        '<node id="X1" x="500" y="-200"/><node id="X2" x="500" y="200"/>'
        "</nodes>", encoding="utf-8")
    shape = " ".join(f"{x:.2f},{y:.2f}" for x, y in [(1000.0, 0.0), *curve])
    (tmp / "n.edg.xml").write_text(
        "<edges>"
        '<edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
        f'<edge id="BC" from="B" to="C" numLanes="2" speed="33.3" shape="{shape}"/>'
        '<edge id="X" from="X1" to="X2" numLanes="1" speed="13.9"/>'
        "</edges>", encoding="utf-8")
    out = tmp / "n.net.xml"
    subprocess.run([netconvert_binary(), "-n", "n.nod.xml", "-e", "n.edg.xml", "-o", out.name,
                    "--no-turnarounds", "true"], cwd=tmp, check=True, capture_output=True)
    return out


def test_kinks_a_lane_drop_and_a_bridge(tmp_path: Path) -> None:
    net = build(tmp_path, 50.0)  # 1.4 degree kinks, netconvert's 2-decimal coordinates
    road = load_road(net, ["AB", "BC"])
    assert road.frame.quality.max_deviation <= FrameLimits().max_deviation
    assert road.frame.quality.min_radius >= FrameLimits().min_radius
    assert road.frame.quality.max_kink == pytest.approx(math.radians(50 / 2000 * 180 / math.pi),
                                                        rel=0.05)
    # three lanes on AB, two on BC: one track ends at B, the other two run through
    through = [t for t in road.lanes if t.track.last_edge == 1]
    ended = [t for t in road.lanes if t.track.last_edge == 0]
    assert len(through) == 2 and len(ended) == 1
    assert ended[0].end == pytest.approx(1000.0, abs=15.0)  # where AB ends (junction apart)
    for table in road.lanes:
        s = np.concatenate([np.linspace(a, b, max(2, math.ceil((b - a) / 0.25)))
                            for a, b in zip(table.s_start, table.s_end, strict=True)])
        x, y, _ = road.frame.to_cartesian(s, table.centre(s))
        measured = shapely.hausdorff_distance(shapely.LineString(np.column_stack((x, y))),
                                              shapely.LineString(table.track.shape()),
                                              densify=0.05)
        assert measured <= table.deviation + 1e-3 <= FrameLimits().max_deviation + 1e-3
    # the bridge crosses the route: a vehicle on it has an (s, d) inside the lanes, but
    # its road is not the route's
    (x0, y0), (x1, y1) = road.route.net.getEdge("X").getLanes()[0].getShape()
    s, d = road.frame.to_frenet(0.5 * (x0 + x1), 0.5 * (y0 + y1))  # netconvert moved it
    assert 0.0 < s < 1000.0 and 0.0 < d < 10.0
    assert road.on_route(["X", "AB", ":B_0"]).tolist() == [False, True, True]


def test_a_coarse_curve_is_refused_with_the_number_that_fails(tmp_path: Path) -> None:
    net = build(tmp_path, 400.0)  # 11.5 degree kinks
    with pytest.raises(InputError, match=r"reference line radius = '\d+\.\d m'") as err:
        load_road(net, ["AB", "BC"], source="sc.toml")
    assert str(err.value).startswith("sc.toml: ")


def test_a_lane_cars_may_not_use_is_no_track(tmp_path: Path) -> None:
    (tmp_path / "w.nod.xml").write_text(
        '<nodes><node id="A" x="0" y="0"/><node id="B" x="500" y="0"/></nodes>',
        encoding="utf-8")
    (tmp_path / "w.edg.xml").write_text(
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="30">'
        '<lane index="0" allow="pedestrian" width="2.0"/></edge></edges>', encoding="utf-8")
    subprocess.run([netconvert_binary(), "-n", "w.nod.xml", "-e", "w.edg.xml", "-o",
                    "w.net.xml"], cwd=tmp_path, check=True, capture_output=True)
    road = load_road(tmp_path / "w.net.xml")
    assert [t.id for t in road.lanes] == [1, 2]  # SUMO's indices: the sidewalk is lane 0
    assert road.reference.name == "AB_1"
    assert road.lane(2).track.name == "AB_2"
    assert road.lane(1).centre(100.0) == pytest.approx(road.lane(1).track.pieces[0].width / 2)
