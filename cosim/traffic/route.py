"""The SUMO side of the route: the route ids SUMO's vehicles are added with."""

from __future__ import annotations

ROUTE_ID = "highway_route"  # SUMO's id of the whole route
