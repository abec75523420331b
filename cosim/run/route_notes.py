"""What our SV does not obey on its route, said before a run (`cosim run`, one line each on
stderr): traffic lights, and speed limits below its lanes' bands.

The SV is moved by moveToXY: it stops for no signal, and it drives its lane's speed band
(`[road] lane_speeds_kmh`, checked against the limits of its start edge only) wherever
the route's limit is lower; SUMO's vehicles obey both. A route is not refused for them
(SUMO's game/highway ramp route passes a ramp meter, and tests drive it): the user is
told where. Nothing is said where SUMO drives the SV (`sv.controller = "sumo"`)."""

from __future__ import annotations

from cosim.road.route import VCLASS
from cosim.scenario.model import KMH, Scenario
from cosim.traffic.route_lanes import RouteLanes, load_route_road

# m/s: a band's top above a limit by less is the same speed (netconvert writes 120 km/h
# as 33.33 m/s)
SPEED_TOLERANCE = 0.5 / KMH


def route_notes(sc: Scenario) -> list[str]:
    """One line per traffic light the SV passes from its start edge on (every connection
    a car may use between two route edges signalled) and per SV lane whose band's top
    is above the speed limit of a route edge it runs on from there."""
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
    for k, table in enumerate(RouteLanes(road).sv):
        top = sc.road.speed_bands[k][1]
        slow = {}
        for piece in table.track.pieces:
            if (not piece.internal and piece.route_index >= start
                    and piece.speed < top - SPEED_TOLERANCE):
                slow.setdefault(piece.edge, piece.speed)
        if slow:
            shown = ", ".join(f"{e} {v * KMH:.0f} km/h" for e, v in list(slow.items())[:3])
            more = f" and {len(slow) - 3} more" if len(slow) > 3 else ""
            notes.append(f"lane {k}'s band goes up to {top * KMH:.0f} km/h, above the speed "
                         f"limit of {shown}{more}: the SV keeps its band there (SUMO's "
                         "vehicles keep the limit)")
    return notes
