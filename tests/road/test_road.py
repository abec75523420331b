"""The road's refusals say where SUMO's network does what the frame cannot follow."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sumo

from cosim.errors import InputError
from cosim.road.road import load_road

# SUMO's shipped on-ramp scenario (the eclipse-sumo wheel's tools/game)
GAME_RAMP = Path(sumo.SUMO_HOME) / "tools" / "game" / "ramp" / "ramp.net.xml"


def test_a_ramp_joining_at_a_junction_drawn_as_a_corner_is_refused_naming_it() -> None:
    """game/ramp's on-ramp meets its acceleration lane at 43 degrees within the
    junction's 4.3 m: SUMO follows the corner, the frame across three lanes cannot."""
    with pytest.raises(InputError) as err:
        load_road(GAME_RAMP, ["gneE14", "gneE7", "gneE8", "gneE11"])
    said = str(err.value)
    assert "\n" not in said
    assert "reference line radius = '7.0 m'" in said
    assert ("at junction gneJ4 between edges gneE14 and gneE7, across which SUMO's lane "
            "steps 0.8 m sideways, a corner: SUMO's junction turns the lane by 43 degrees "
            "within 4.3 m (R 5.7 m), which SUMO's vehicles follow along its shape, having "
            "no turning circle") in said



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
def test_bremens_on_ramp_is_driven_from_the_ramp_through_its_step_to_the_merge(
        tmp_path: Path) -> None:
    """game/highway's ramp route from its two-lane edge 201283198: the ramp's left lane
    steps 1.13 m sideways at junction J1 where it runs on as E0's acceleration lane, so
    the frame shifts with it over 113 m; the SV drives the ramp from 60 m up it, keeps
    its lane through the shift and merges (a mandatory change) into the mainline."""
    from cosim.run.loop import simulate
    from cosim.scenario.load import scenario_from_dict

    route = ["201283198", "201283198.145", "201283198.145.16", "E0", "191842213"]
    road = load_road(GAME_HIGHWAY, route)
    assert road.carriageway == 3  # E0: the acceleration lane E0_0 is lane 0
    (shift,) = road.shifts
    assert shift.jump == pytest.approx(1.13, abs=0.01)
    assert road.max_deviation < 0.2
    doc = {"scenario": {"name": "bremen_ramp", "duration_s": 11.0, "seed": 1},
           "road": {"network": str(GAME_HIGHWAY), "route": route, "mu": 0.6,
                    "lane_speeds_kmh": [[90, 120], [110, 140], [130, 160]]},
           "sv": {"edge": "201283198", "lane": 1, "position_m": 60.0, "speed_kmh": 70.0,
                  "decision": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "bremen_ramp.toml"))
    m, tr = result.metrics, result.trace
    assert m["merge_success"] == 1 and m["lane_change_completed"] == 1
    assert m["final_lane"] == 1
    assert m["collisions"] == 0 and m["sumo_events"] == 0
    assert {"201283198", "E0"} <= set(result.edges)
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.02
