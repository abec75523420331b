"""The highway network: geometry as specified, reproducible from its plain-XML sources."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.traffic.network import (
    DEFAULT_NETWORK,
    NETWORK_DIR,
    build_network,
    load_highway,
    main,
)


def test_shipped_network_is_a_straight_three_lane_highway() -> None:
    hw = load_highway(DEFAULT_NETWORK)
    assert hw.n_lanes == 3
    assert hw.lane_width == pytest.approx(3.75)
    assert [v * 3.6 for v in hw.lane_speeds] == pytest.approx([90.0, 110.0, 120.0], abs=1e-4)
    assert hw.y_right == pytest.approx(0.0)
    assert hw.x_start == 0.0
    # 60 s at 120 km/h is 2 km: every shipped scenario ends far from the edge's end
    assert hw.length >= 5000.0
    road = hw.road()
    assert [road.lane_center(k) for k in range(3)] == pytest.approx([1.875, 5.625, 9.375])


def test_network_rebuilds_byte_for_byte(tmp_path: Path) -> None:
    for suffix in (".nod.xml", ".edg.xml"):
        shutil.copy(NETWORK_DIR / f"highway{suffix}", tmp_path)
    out = build_network(tmp_path)
    assert out.read_bytes() == DEFAULT_NETWORK.read_bytes()
    assert main(["--check"]) == 0


def test_missing_sources_and_networks_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="highway.nod.xml"):
        build_network(tmp_path)
    with pytest.raises(InputError, match="nothere.net.xml"):
        load_highway(tmp_path / "nothere.net.xml")
