"""The curved motorway: rebuilt byte for byte from its generated plain XML; its
geometry as specified (4-6 km, three lanes of 3.75 m, radii 750-1500 m, an S-bend, a
lane added on the right)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from cosim.road.build import EDGES, NAME, PROFILE, build, main, profile_length, stale
from cosim.road.route import read_network
from cosim.traffic.network import NETWORK_DIR

sys.path.insert(0, str(Path(__file__).parent))
from handdrawn import assert_rebuilt  # noqa: E402


def test_the_shipped_network_is_up_to_date(tmp_path: Path) -> None:
    assert_rebuilt(tmp_path, NAME, build, stale, main)


def test_a_stale_file_is_named(tmp_path: Path) -> None:
    build(tmp_path)
    (tmp_path / f"{NAME}.con.xml").write_text("<connections/>\n", encoding="utf-8")
    assert stale(tmp_path) == [f"{NAME}.con.xml"]


def test_geometry_as_specified() -> None:
    assert 4000.0 <= profile_length() <= 6000.0
    radii = [1.0 / abs(k) for _, k in PROFILE if k]
    assert min(radii) >= 750.0 and max(radii) <= 1500.0
    # an S-bend: a right curve straight into a left one
    signs = [np.sign(k) for _, k in PROFILE]
    assert any(a < 0 < b for a, b in zip(signs[:-1], signs[1:], strict=True))
    net = read_network(NETWORK_DIR / f"{NAME}.net.xml")
    lanes = [net.getEdge(e).getLaneNumber() for e, _ in EDGES]
    assert lanes == [3, 3, 4, 3] and len(lanes) >= 3
    widths = {ln.getWidth() for e, _ in EDGES for ln in net.getEdge(e).getLanes()}
    assert widths == {3.75}
    # dense shape points: no kink above one degree inside an edge
    for e, _ in EDGES:
        shape = np.array(net.getEdge(e).getShape())
        v = np.diff(shape, axis=0)
        turn = np.abs(np.diff(np.unwrap(np.arctan2(v[:, 1], v[:, 0]))))
        assert turn.max() < math.radians(1.0)
