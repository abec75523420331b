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

