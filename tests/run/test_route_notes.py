"""The notes `cosim run` gives before a run on what our SV does not obey on its route:
a traffic light ahead of it (a speed limit below its lane's band it keeps: no note)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from cosim.run.route_notes import route_notes
from cosim.scenario import project_root, scenario_from_dict
from tests.road.handdrawn import netconvert

ROOT = project_root()


def test_a_signal_ahead_is_named_and_none_behind(tmp_path: Path) -> None:
    net = netconvert(tmp_path, '<nodes><node id="A" x="0" y="0"/>'
                     '<node id="B" x="800" y="0" type="traffic_light"/>'
                     '<node id="C" x="1400" y="0"/><node id="D" x="3000" y="0"/></nodes>',
                     '<edges><edge id="AB" from="A" to="B" numLanes="2" speed="27.78"/>'
                     '<edge id="BC" from="B" to="C" numLanes="2" speed="22.22"/>'
                     '<edge id="CD" from="C" to="D" numLanes="2" speed="27.78"/></edges>')
    doc = tomllib.loads((ROOT / "tests" / "data" / "route_curved.toml").read_text())
    doc["road"].pop("lane_width_m")
    doc["road"].update(network=str(net), route=["AB", "BC", "CD"],
                       lane_speeds_kmh=[[60, 80], [80, 100]])
    doc["sv"].update(lane=0, position_m=300.0, speed_kmh=80.0, lane_changes=[])
    doc.pop("tv")
    notes = route_notes(scenario_from_dict(doc, tmp_path / "sc.toml"))
    assert notes == [
        "the SV passes traffic light 'B' between AB and BC without stopping: it stops for "
        "no signal (SUMO's vehicles do)"]  # BC's lower limit the SV keeps
    # past the signal and the slow edge, or driven by SUMO: nothing to say
    doc["sv"].update(edge="CD", position_m=100.0)
    assert route_notes(scenario_from_dict(doc, tmp_path / "sc.toml")) == []
    doc["sv"].update(edge="AB", position_m=300.0, controller="sumo")
    assert route_notes(scenario_from_dict(doc, tmp_path / "sc.toml")) == []
