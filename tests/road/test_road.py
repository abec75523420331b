"""The road's refusals say where SUMO's network does what the frame cannot follow."""

from __future__ import annotations

from pathlib import Path

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
