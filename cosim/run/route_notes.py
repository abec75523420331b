"""What our SV does not obey on its route, said before a run (`cosim run`, one line each on
stderr): traffic lights.

The SV is moved by moveToXY: it stops for no signal; SUMO's vehicles do. A route is not
refused for one (SUMO's game/highway ramp route passes a ramp meter, and tests drive
it): the user is told where. Nothing is said where SUMO drives the SV
(`sv.controller = "sumo"`). Speed limits below its lanes' bands it keeps
(cosim.driving.speed_limits)."""

from __future__ import annotations

from cosim.road.route import VCLASS
from cosim.scenario.model import Scenario
from cosim.traffic.route_lanes import load_route_road


def route_notes(sc: Scenario) -> list[str]:
    """One line per traffic light the SV passes from its start edge on (every connection
    a car may use between two route edges signalled)."""
    if sc.route is None or sc.sv.controller == "sumo":
        return []
    road = load_route_road(sc.network, sc.route)
    edges = road.route.edges
    start = edges.index(sc.sv.edge if sc.sv.edge is not None else edges[0])
    net = road.route.net
    notes = []
    for a, b in zip(edges[start:-1], edges[start + 1:], strict=True):
        usable = [c for c in net.getEdge(a).getConnections(net.getEdge(b))
                  if c.getFromLane().allows(VCLASS) and c.getToLane().allows(VCLASS)]
        if usable and all(c.getTLSID() for c in usable):
            notes.append(f"the SV passes traffic light {usable[0].getTLSID()!r} between "
                         f"{a} and {b} without stopping: it stops for no signal "
                         "(SUMO's vehicles do)")
    return notes
