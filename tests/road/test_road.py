"""The road's refusals say where SUMO's network does what the frame cannot follow."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sumo

from cosim.road.frame import kappa_max
from cosim.road.road import load_road

# SUMO's shipped on-ramp scenario (the eclipse-sumo wheel's tools/game)
GAME_RAMP = Path(sumo.SUMO_HOME) / "tools" / "game" / "ramp" / "ramp.net.xml"


ON_RAMP = ["gneE15", "gneE17", "gneE18", "gneE13", "gneE14", "gneE7", "gneE8", "gneE11"]
OFF_RAMP = ["gneE2", "offramp", "gneE4", "gneE16", "gneE18", "gneE9"]


@pytest.fixture(scope="module")
def game_ramp_roads() -> tuple:
    return load_road(GAME_RAMP, ON_RAMP), load_road(GAME_RAMP, OFF_RAMP)


def test_game_ramps_corners_are_rounded_within_half_a_lane_of_sumos(game_ramp_roads) -> None:
    """game/ramp's on-ramp route (its ramp's lane meets the acceleration lane at 43
    degrees within junction gneJ4's 4.3 m, after corners at gneJ14 and gneJ6) and its
    off-ramp route (gneJ3, gneJ5, gneJ6): each junction drawn as a corner is rounded by a
    fillet (clothoid, arc, clothoid) whose lane stays within half a lane (1.6 m) of
    SUMO's corner, its arc at least RADIUS_SHARE of the arc alone's (R 20.5-63 m), the lanes
    within the 5 cm target of SUMO's elsewhere, and outside the corners the frame is all
    but straight (the corners' curve speed is theirs, not the mainline's)."""
    on, off = game_ramp_roads
    assert [c.junction for c in on.corners] == ["gneJ14", "gneJ6", "gneJ4"]
    assert [c.junction for c in off.corners] == ["gneJ3", "gneJ5", "gneJ6"]
    for road in (on, off):
        assert road.max_deviation < 0.05
        for c in road.corners:
            assert c.deviation <= 1.6 + 1e-9
            assert c.lane_radius >= 16.0 and c.spiral > 5.0
            # the line bends there as its fillet, within the smoothing's few per cent
            assert 1.0 / kappa_max(road.frame, c.s_lo, c.s_hi) > 0.9 * c.radius
        kappa, _ = road.curvature_bound()
        assert 1.0 / kappa > 900.0
    # the on-ramp's three corners lie less than 50 m apart: one slow stretch, at its
    # tightest arc (gneJ4's R 16.5 m); the off-ramp's gneJ6 lies 80 m past gneJ5
    ((lo, hi, radius),) = on.corner_zones()
    assert lo < on.corners[0].s_lo and hi > on.corners[-1].s_hi
    assert radius == pytest.approx(16.5, abs=0.1)
    assert len(off.corner_zones()) == 2
    assert on.carriageway == 5  # gneE7: its acceleration lane is lane 0


def test_a_corner_with_no_room_for_a_radius_its_lane_allows_gets_no_fillet() -> None:
    """A corner whose edges' straight ends (1 m each, a right angle) cannot hold the
    smallest fillet its lane allows (the SV's turning circle plus half the lane) gets
    none: load_road refuses the route naming the junction."""
    from cosim.road.corners import CornerSite, rounding

    site = CornerSite((0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (1.0, 1.0), "J", 13.9, 3.2, 0.0,
                      0.0)
    (rounded,) = rounding([site], 2.0, 3.7)
    assert all(math.isnan(v) for v in rounded)


GAME_HIGHWAY = Path(sumo.SUMO_HOME) / "tools" / "game" / "highway" / "highway.net.xml"


def test_bremens_lanes_stepping_4_8_m_at_a_junction_shift_the_frame() -> None:
    """game/highway's edge 153177809 spreads its lanes centred where 191842213 spread
    them right of its line: every lane steps 4.8 m sideways at junction 1658939360. The
    frame shifts with them over 234 m (its 160 km/h want R 988 m), its lanes within the
    route's coarse-curve bound of SUMO's elsewhere."""
    road = load_road(GAME_HIGHWAY, ["191842213", "153177809", "153177820"])
    (shift,) = road.shifts
    assert shift.jump == pytest.approx(4.79, abs=0.01)
    assert shift.s == pytest.approx(827.8, abs=0.5)  # the end of 191842213, 827.6 m long
    assert road.frame.quality.min_radius > 900.0
    assert road.max_deviation < 0.5  # measured 0.39 m: the kinks of 153177820, coarse


@pytest.mark.sumo
def test_bremens_ramp_route_is_driven_from_its_ramp_lane_through_its_step_to_the_merge(
        tmp_path: Path) -> None:
    """game/highway's `ramp` route from its first edge 153180751, a loop drawn as chords
    turning 6-18 degrees at its vertices (rounded as corners), whose one lane runs on as
    the right lane of the two-lane 201283198, which ends on 201283198.145 (a ramp lane:
    the SV's lane 0); the left lane steps 1.13 m sideways at junction J1 where it runs
    on as E0's acceleration lane (lane 1), so the frame shifts with it over 113 m. The
    SV, 55 m along the ramp lane on 201283198, changes out of it (mandatory), keeps its
    lane through the shift and merges (mandatory) into the mainline. It starts at 70 km/h,
    over the lane's 19.44 m/s by less than the network's rounding (which the scenario
    allows) but more than SUMO's insertion allows: inserted at the limit instead."""
    from cosim.run.loop import simulate
    from cosim.scenario.load import scenario_from_dict

    route = ["153180751", "201283198", "201283198.145", "201283198.145.16", "E0",
             "191842213"]
    road = load_road(GAME_HIGHWAY, route)
    assert road.carriageway == 4 and road.ramp_lanes == {0}  # E0_0 is lane 1
    (shift,) = road.shifts
    assert shift.jump == pytest.approx(1.13, abs=0.01)
    loop = [c for c in road.corners if c.junction.startswith("153180751 vertex")]
    assert len(loop) == 8 and all(c.deviation <= 1.6 + 1e-9 for c in loop)
    assert road.max_deviation < 0.05
    doc = {"scenario": {"name": "bremen_ramp", "duration_s": 12.0, "seed": 1},
           "road": {"network": str(GAME_HIGHWAY), "route": route, "mu": 0.6,
                    "lane_speeds_kmh": [[90, 120], [110, 140], [130, 160]]},
           "sv": {"edge": "201283198", "lane": 0, "position_m": 55.0, "speed_kmh": 70.0,
                  "decision": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "bremen_ramp.toml"))
    m, tr = result.metrics, result.trace
    assert [p["trigger"] for p in result.plans[:2]] == ["mandatory", "mandatory"]
    assert m["lane_changes"] == 2 and m["lane_change_status"] == "completed"
    assert m["merge_success"] == 1 and m["final_lane"] == 2 and m["lane_end_reached"] == 0
    assert m["collisions"] == 0 and m["sumo_events"] == 0
    assert {"201283198", "E0"} <= set(result.edges)
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.03


@pytest.mark.sumo
def test_the_sv_slows_for_game_ramps_corner_and_keeps_its_lane_through_it(
        tmp_path: Path) -> None:
    """game/ramp's ramp meets the acceleration lane at the 43-degree corner gneJ4: the
    SV, 35 m before it at 40 km/h, brakes to the corner's curve speed (its lane's arc
    R 16.5 m at 2 m/s^2: 5.7 m/s) before its fillet's first clothoid, holds it through
    the fillet, keeps its lane within half a lane of SUMO's corner (lateral error within
    4 cm) onto the acceleration lane, never leaving its route."""
    from cosim.run.loop import simulate
    from cosim.scenario.load import scenario_from_dict

    route = ["gneE13", "gneE14", "gneE7", "gneE8", "gneE11"]
    doc = {"scenario": {"name": "game_ramp_corner", "duration_s": 9.0, "seed": 1},
           "road": {"network": str(GAME_RAMP), "route": route, "mu": 1.0,
                    "lane_speeds_kmh": [[100, 120], [110, 120]]},
           "sv": {"edge": "gneE13", "lane": 0, "position_m": 5.0, "speed_kmh": 40.0,
                  "decision": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "corner.toml"))
    m, tr = result.metrics, result.trace
    road = load_road(GAME_RAMP, route)
    (corner,) = road.corners
    ((lo, hi, radius),) = road.corner_zones()
    v_c = math.sqrt(2.0 * radius)
    s, v = np.asarray(tr["s_m"]), np.asarray(tr["vx_mps"])
    inside = (s + 2.4 >= lo) & (s - 2.4 <= hi)  # the SV's body within the corner
    assert inside.any() and s[-1] > corner.s_hi  # through the fillet
    assert float(v[inside].max()) < v_c + 0.3
    assert float(v[0]) > 11.0  # it came in at 40 km/h
    assert m["collisions"] == 0 and m["sumo_events"] == 0
    assert 0.5 < m["lane_keeping_max_offset_m"] <= 1.6
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.05
    assert {"gneE14", ":gneJ4_0", "gneE7"} <= set(result.edges)
