"""A vehicle driven along a track's centre with moveToXY: SUMO's edge and lane follow
the track, its lane index changing where SUMO renumbers the lanes (real libsumo)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.road.road import load_road
from cosim.traffic.network import NETWORK_DIR
from cosim.traffic.sumo import front_from_centre, sumo_angle

CURVED = NETWORK_DIR / "curved_motorway.net.xml"
ROUTE = ("e1", "e2", "e3", "e4")
STEP = 0.1  # s
SPEED = 33.0  # m/s
L = 4.32  # m


@pytest.mark.sumo
def test_sumo_follows_a_track_driven_with_move_to_xy() -> None:
    import libsumo as api
    import sumolib

    road = load_road(CURVED, ROUTE)
    lane = road.lane(1)  # e1_1 -> e2_1 -> e3_2 -> e4_1
    bounds = np.concatenate((lane.s_start, lane.s_end))
    api.start([sumolib.checkBinary("sumo"), "-n", str(CURVED), "--step-length", str(STEP),
               "--no-step-log", "true", "--no-warnings", "true",
               "--collision.action", "warn"])
    try:
        api.route.add("r", list(ROUTE))
        api.vehicle.add("sv", "r", departLane="1", departPos="10", departSpeed="0")
        api.vehicle.setSpeedMode("sv", 0)
        api.vehicle.setLaneChangeMode("sv", 0)
        s = 20.0  # m, the centre's s
        seen: list[tuple[str, str, int]] = []
        checked = 0
        while s + 0.5 * L < lane.end - 5.0:
            x, y, h = road.frame.to_cartesian(s, lane.centre(s))
            xf, yf = front_from_centre(x, y, h, L)
            s_front = s + 0.5 * L  # d is constant: the front's s is the centre's + L/2
            piece = lane.piece_at(s_front)
            api.vehicle.moveToXY("sv", piece.edge, piece.index, xf, yf, sumo_angle(h),
                                 keepRoute=2)
            api.simulationStep()
            assert api.vehicle.getPosition("sv") == pytest.approx((xf, yf), abs=1e-6)
            if np.abs(bounds - s_front).min() > 0.5:  # SUMO's lane at a boundary: either
                got = api.vehicle.getLaneID("sv")
                assert got == piece.lane, (s_front, got, piece.lane)
                checked += 1
                if not seen or seen[-1][1] != got:
                    seen.append((api.vehicle.getRoadID("sv"), got,
                                 api.vehicle.getLaneIndex("sv")))
            s += SPEED * STEP
        assert checked > 1000
        # the track's lanes in order, SUMO's index 1 -> 2 -> 1 (a lane added on the right
        # at j2, ended at j3), through the junction lanes longer than a step's travel
        # (j2's and j3's 8 m; j1's is 0.3 m)
        long = [p.lane for p, a, b in zip(lane.track.pieces, lane.s_start, lane.s_end,
                                          strict=True) if b - a > SPEED * STEP + 1.0]
        assert [g[1] for g in seen] == long
        assert ":j2_0_1" in long and ":j3_0_1" in long
        assert [g[2] for g in seen if not g[0].startswith(":")] == [1, 1, 2, 1]
        assert api.vehicle.getRoute("sv") == ROUTE
    finally:
        api.close()


def test_frame_pose_heading_matches_the_lane_direction() -> None:
    """The frame's heading at a track's centre is SUMO's lane direction there (within
    the polyline's own kinks, 0.8 degrees)."""
    from sumolib.geomhelper import polyLength, positionAtShapeOffset

    road = load_road(CURVED, ROUTE)
    for piece in road.lane(2).track.pieces:
        if piece.internal:
            continue
        shape = list(piece.shape)
        for frac in (0.25, 0.5, 0.75):
            off = frac * polyLength(shape)
            p0 = positionAtShapeOffset(shape, off - 1.0)
            p1 = positionAtShapeOffset(shape, off + 1.0)
            s, _ = road.frame.to_frenet(*positionAtShapeOffset(shape, off))
            h = road.frame.heading(s)
            sumo = math.atan2(p1[1] - p0[1], p1[0] - p0[0])
            assert abs(math.remainder(h - sumo, 2 * math.pi)) < math.radians(0.8)
