"""Every vehicle, trip and flow of the user's demand checked as SUMO uses it over the
whole run, before anything runs.

SUMO builds a vehicle's departure only when it departs (a flow's vehicles one by one as
they come, a trip's route when it leaves): a vehicle that departs in minute ten with
`departLane="7"`, or a trip with no path, stops the whole simulation in minute ten, and
loading the demand at t = 0 (own_demand.dry_load) does not see it. So each vehicle, trip
and flow is read here against the network (sumolib), a flow once (its vehicles share its
attributes), and each fault is one InputError line naming the file, the element, the
attribute, its value and what is allowed:

- its route: the named route (each route of a routeDistribution: SUMO may draw any), its
  own `<route>`, or, for a trip or a flow given `from` / `to` (and `via`), the path SUMO
  finds for its vClass (none: refused); consecutive edges connected by a lane its vClass
  may use;
- `departLane` (a number): a lane of the route's first edge its vClass may use; without
  one, some lane of that edge it may use;
- `departPos`, `arrivalPos` (numbers): on the first / last edge (negative: counted from
  its end, as SUMO reads them); SUMO would otherwise put the vehicle at the lane's end,
  or never let it arrive;
- `departSpeed` (a number): finite, at most its vType's maxSpeed, and at most the
  departure lane's limit times its speedFactor when that factor has no spread (SUMO stops
  with "too high" otherwise); `arrivalSpeed` a finite number >= 0;
- `arrivalLane` (a number): a lane of the route's last edge.

Each vType of a vTypeDistribution is checked alike. Words SUMO reads in these attributes
("random", "free", "max", ...) are SUMO's business (the dry load refuses unknown ones).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from cosim.errors import InputError

VEHICLE_TAGS = ("vehicle", "trip", "flow")  # what enters the road as a vehicle
DEFAULT_TYPE = "DEFAULT_VEHTYPE"
# SUMO's built-in vTypes and their vClass
BUILT_IN_TYPES = {"DEFAULT_VEHTYPE": "passenger", "DEFAULT_BIKETYPE": "bicycle",
                  "DEFAULT_TAXITYPE": "taxi", "DEFAULT_RAILTYPE": "rail",
                  "DEFAULT_PEDTYPE": "pedestrian", "DEFAULT_CONTAINERTYPE": "ignoring"}
DEFAULT_CLASS = "passenger"  # a vType's vClass when it names none
# m/s, SUMO's default maxSpeed of a vType by vClass (SUMOVTypeParameter's defaults);
# every other road class has 200 km/h, a class missing here is not checked
DEFAULT_MAX_SPEED = {"truck": 130 / 3.6, "trailer": 130 / 3.6, "bus": 100 / 3.6,
                     "coach": 100 / 3.6, "moped": 60 / 3.6, "bicycle": 20 / 3.6}
ROAD_CLASSES = ("passenger", "private", "taxi", "emergency", "authority", "army", "vip",
                "hov", "delivery", "motorcycle", "evehicle", "custom1", "custom2",
                "ignoring")
ROAD_MAX_SPEED = 200 / 3.6  # m/s
SPEED_TOLERANCE = 1e-3  # m/s, a departSpeed this far above a limit is still the limit
_SPREAD = re.compile(r"\s*normc?\(\s*([^,()]+)\s*,\s*([^,()]+)")  # norm(mean, dev, ...)
# departLane words for which SUMO chooses among the allowed lanes (any may be chosen)
ANY_LANE = ("random", "free", "allowed", "best", "best_prob")


@dataclass(frozen=True)
class VehicleType:
    """What a departure needs to know of a vType."""

    vclass: str
    max_speed: float | None  # m/s; None: not known here (not checked)
    fixed_factor: float | None  # speedFactor when it has no spread, else None


@dataclass(frozen=True)
class _Demand:
    """The definitions the vehicles refer to, gathered over all files."""

    types: dict[str, tuple[VehicleType, ...]]  # vType or vTypeDistribution id -> members
    routes: dict[str, tuple[tuple[str, ...], ...]]  # route(Distribution) id -> edge lists


@dataclass(frozen=True)
class _Where:
    """Who is being checked, for the message."""

    source: str  # the scenario
    key: str  # the scenario key that names the file (traffic.routes[0], road.sumocfg)
    name: str  # the file's name
    who: str  # "flow 'cars'"

    def error(self, attr: str, value: str, allowed: str) -> InputError:
        return InputError(self.source, self.key, f"{self.name}: {self.who} {attr}={value!r}",
                          allowed)


def check_departures(source: str, files: Sequence[tuple[str, str, ET.Element]],
                     net: Any) -> None:
    """Check every vehicle, trip and flow of `files` (`(scenario key, file name, XML
    root)`, read by own_demand.check_demand) on the sumolib network `net`; InputError on
    the first fault (module docstring)."""
    demand = _definitions(files)
    paths: dict[tuple[str, str, str], tuple[str, ...] | None] = {}
    for key, name, root in files:
        for element in root.iter():
            if element.tag in VEHICLE_TAGS:
                where = _Where(source, key, name,
                               f"{element.tag} {element.get('id', '')!r}")
                _check_vehicle(where, element, demand, net, paths)


def _definitions(files: Sequence[tuple[str, str, ET.Element]]) -> _Demand:
    """The vTypes (by id: their members) and routes (by id: their edge lists) of `files`."""
    types: dict[str, tuple[VehicleType, ...]] = {
        ident: (_vehicle_type({"vClass": vclass}),) for ident, vclass in BUILT_IN_TYPES.items()}
    routes: dict[str, tuple[tuple[str, ...], ...]] = {}
    later: list[tuple[str, list[str]]] = []  # distributions naming members by id
    for _, _, root in files:
        for element in root.iter():
            ident = element.get("id", "")
            if element.tag == "vType" and ident:
                types[ident] = (_vehicle_type(element.attrib),)
            elif element.tag == "route" and ident:
                routes[ident] = (tuple(element.get("edges", "").split()),)
            elif element.tag in ("vTypeDistribution", "routeDistribution") and ident:
                members = element.get("vTypes" if element.tag == "vTypeDistribution"
                                      else "routes", "").split()
                nested = [c for c in element if c.tag in ("vType", "route")]
                if element.tag == "vTypeDistribution":
                    types[ident] = tuple(_vehicle_type(c.attrib) for c in nested)
                else:
                    routes[ident] = tuple(tuple(c.get("edges", "").split()) for c in nested
                                          if c.get("edges") is not None)
                later.append((f"{element.tag}:{ident}", members))
    for tagged, members in later:
        tag, _, ident = tagged.partition(":")
        if tag == "vTypeDistribution":
            types[ident] += tuple(t for m in members for t in types.get(m, ()))
        else:
            routes[ident] += tuple(r for m in members for r in routes.get(m, ()))
    return _Demand(types, routes)


def _vehicle_type(attrib: dict[str, str]) -> VehicleType:
    """A vType's class, maxSpeed (given, else its class's default) and fixed speedFactor."""
    vclass = attrib.get("vClass", DEFAULT_CLASS)
    max_speed = _number(attrib.get("maxSpeed"))
    if max_speed is None:
        max_speed = DEFAULT_MAX_SPEED.get(vclass, ROAD_MAX_SPEED if vclass in ROAD_CLASSES
                                          else None)
    factor_text = attrib.get("speedFactor", "1")
    mean = _number(factor_text)
    dev: float | None = None
    spread = _SPREAD.match(factor_text)
    if spread:
        mean, dev = _number(spread.group(1)), _number(spread.group(2))
    if "speedDev" in attrib:
        dev = _number(attrib["speedDev"])
    fixed = mean if dev == 0.0 and mean is not None else None
    return VehicleType(vclass, max_speed, fixed)


def _number(text: str | None) -> float | None:
    """`text` as SUMO reads a number, None if it is none (a word, absent)."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return None


def _check_vehicle(where: _Where, element: ET.Element, demand: _Demand, net: Any,
                   paths: dict[tuple[str, str, str], tuple[str, ...] | None]) -> None:
    """One vehicle, trip or flow, for each vType it may have and each route it may take."""
    attrib = element.attrib
    type_id = attrib.get("type", DEFAULT_TYPE)
    for vtype in demand.types.get(type_id, ()) or (_vehicle_type({}),):
        for edges in _routes_of(where, element, demand, net, vtype.vclass, paths):
            _check_route(where, edges, net, vtype.vclass)
            _check_depart(where, attrib, edges, net, vtype)
            _check_arrival(where, attrib, edges, net)


def _routes_of(where: _Where, element: ET.Element, demand: _Demand, net: Any, vclass: str,
               paths: dict[tuple[str, str, str], tuple[str, ...] | None]
               ) -> list[tuple[str, ...]]:
    """The edge lists the element may drive: its route (by id or nested), or the path SUMO
    finds from `from` over `via` to `to`; none for what is not checked here (TAZ,
    junctions, coordinates)."""
    attrib = element.attrib
    if "route" in attrib:
        return [r for r in demand.routes.get(attrib["route"], ()) if r]
    nested = [c for c in element if c.tag in ("route", "routeDistribution")]
    if nested:
        child = nested[0]
        if child.tag == "route":
            return [tuple(child.get("edges", "").split())] if child.get("edges") else []
        return [tuple(c.get("edges", "").split()) for c in child if c.get("edges")]
    if "from" in attrib and "to" in attrib:
        stops = [attrib["from"], *attrib.get("via", "").split(), attrib["to"]]
        edges: list[str] = [stops[0]]
        for a, b in zip(stops[:-1], stops[1:], strict=True):
            path = _path(net, a, b, vclass, paths)
            if path is None:
                onward = sorted(e.getID() for e in net.getEdge(a).getAllowedOutgoing(vclass))
                attr = "to" if b == stops[-1] else "via"
                raise where.error(attr, b, f"an edge a {vclass} can reach from {a!r} on the "
                                  f"network ({a!r} leads to {_some(onward) or 'no edge'}; "
                                  "SUMO finds no route for it)")
            edges += path[1:]
        return [tuple(edges)]
    return []


def _path(net: Any, a: str, b: str, vclass: str,
          paths: dict[tuple[str, str, str], tuple[str, ...] | None]) -> tuple[str, ...] | None:
    """The edges of the shortest path from `a` to `b` for `vclass` (cached per call of
    check_departures), None if there is none."""
    if (a, b, vclass) not in paths:
        if a == b:
            paths[a, b, vclass] = (a,)
        else:
            found, _ = net.getShortestPath(net.getEdge(a), net.getEdge(b), vClass=vclass)
            paths[a, b, vclass] = None if found is None else tuple(e.getID() for e in found)
    return paths[a, b, vclass]


def _check_route(where: _Where, edges: tuple[str, ...], net: Any, vclass: str) -> None:
    """Every edge of the network (already checked by own_demand), each connected to the
    next by a lane `vclass` may use."""
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        ea, eb = net.getEdge(a), net.getEdge(b)
        outgoing = ea.getAllowedOutgoing(vclass)
        if eb not in outgoing:
            onward = sorted(e.getID() for e in outgoing)
            raise where.error("edges", f"{a} {b}",
                              f"consecutive edges connected for a {vclass} ({a!r} leads to "
                              f"{_some(onward) or 'no edge'}; SUMO stops the run when the "
                              "vehicle departs)")


def _lanes(net: Any, edge: str) -> list[Any]:
    return sorted(net.getEdge(edge).getLanes(), key=lambda lane: lane.getIndex())


def _check_depart(where: _Where, attrib: dict[str, str], edges: tuple[str, ...], net: Any,
                  vtype: VehicleType) -> None:
    """departLane, departPos and departSpeed on the route's first edge."""
    first = edges[0]
    lanes = _lanes(net, first)
    allowed = [lane for lane in lanes if lane.allows(vtype.vclass)]
    lane_text = attrib.get("departLane", "first")
    lane_index = _integer(lane_text)
    if lane_index is not None:
        if not 0 <= lane_index < len(lanes) or not lanes[lane_index].allows(vtype.vclass):
            raise where.error("departLane", lane_text,
                              f"a lane of edge {first!r} (where it departs) a {vtype.vclass} "
                              f"may use: {_indices(allowed)}")
        departing = [lanes[lane_index]]
    elif not allowed:
        raise where.error("edges", " ".join(edges[:3]) + (" ..." if len(edges) > 3 else ""),
                          f"a route whose first edge has a lane a {vtype.vclass} may use "
                          f"(edge {first!r} has none)")
    else:
        departing = allowed if lane_text in ANY_LANE else allowed[:1]
    length = float(net.getEdge(first).getLength())
    _check_position(where, "departPos", attrib.get("departPos"), first, length)
    speed_text = attrib.get("departSpeed")
    speed = _number(speed_text)
    if speed is None or speed_text is None:
        return
    limits = []
    if vtype.max_speed is not None:
        limits.append((vtype.max_speed, "its vType's maxSpeed"))
    if vtype.fixed_factor is not None:
        slowest = min(departing, key=lambda lane: lane.getSpeed())
        limits.append((vtype.fixed_factor * float(slowest.getSpeed()),
                       f"lane {slowest.getID()!r}'s limit times its vType's speedFactor "
                       f"{vtype.fixed_factor:g} (which has no spread)"))
    top = min(limits, default=(math.inf, ""))
    if not (math.isfinite(speed) and 0.0 <= speed <= top[0] + SPEED_TOLERANCE):
        allowed_text = "a finite number >= 0 m/s"
        if top[1]:
            allowed_text = f"a speed in [0, {top[0]:.6g}] m/s ({top[1]}; SUMO stops the run " \
                           "when the vehicle departs faster)"
        raise where.error("departSpeed", speed_text, allowed_text)


def _check_arrival(where: _Where, attrib: dict[str, str], edges: tuple[str, ...],
                   net: Any) -> None:
    """arrivalLane, arrivalPos and arrivalSpeed on the route's last edge."""
    last = edges[-1]
    lane_text = attrib.get("arrivalLane")
    lane_index = _integer(lane_text)
    n_lanes = len(net.getEdge(last).getLanes())
    if lane_index is not None and not 0 <= lane_index < n_lanes:
        raise where.error("arrivalLane", str(lane_text),
                          f"a lane index 0..{n_lanes - 1} of edge {last!r} (where it arrives)")
    _check_position(where, "arrivalPos", attrib.get("arrivalPos"), last,
                    float(net.getEdge(last).getLength()))
    speed_text = attrib.get("arrivalSpeed")
    speed = _number(speed_text)
    if speed_text is not None and speed is not None and not (
            math.isfinite(speed) and speed >= 0.0):
        raise where.error("arrivalSpeed", speed_text, "a finite number >= 0 m/s")


def _check_position(where: _Where, attr: str, text: str | None, edge: str,
                    length: float) -> None:
    """A position given as a number lies on `edge` (negative: from its end)."""
    pos = _number(text)
    if text is None or pos is None:
        return
    on_edge = pos + length if pos < 0 else pos
    if not (math.isfinite(pos) and 0.0 <= on_edge <= length):
        raise where.error(attr, text,
                          f"a position on edge {edge!r} in [-{length:g}, {length:g}] m "
                          f"(it is {length:g} m long; negative counts from its end)")


def _integer(text: str | None) -> int | None:
    """A lane index as written (a whole number), None for a word or nothing."""
    if text is None or not re.fullmatch(r"\s*[+-]?\d+\s*", text):
        return None
    return int(text)


def _indices(lanes: list[Any]) -> str:
    return ", ".join(str(lane.getIndex()) for lane in lanes) or "none"


def _some(names: list[str], n: int = 6) -> str:
    shown = ", ".join(names[:n])
    return shown + (f", ... ({len(names)} in all)" if len(names) > n else "")
