"""A route: the SUMO edges the SV drives, in order, read from a network with its
internal (junction) lanes.

The network is read once per process with sumolib (`withInternal=True`: the junction
lanes that connect one edge's lanes to the next are part of a track). A route is a
list of normal edge ids, each connected to the next by at least one SUMO connection
that a passenger car may use; on a network of one normal edge it may be left out.
Every fault is an `InputError` on one line naming the edge(s) concerned.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.road.driving_side import left_hand, left_hand_refusal
from cosim.road.network_numbers import RULE, network_numbers_problem
from cosim.validation import read_network_file

VCLASS = "passenger"  # lanes a car may use: sidewalks, bike and bus lanes are no tracks


@dataclass(frozen=True)
class Route:
    """The SV's route: normal edges of a SUMO network, each connected to the next."""

    path: Path  # the .net.xml
    net: Any  # sumolib.net.Net, read with internal lanes
    edges: tuple[str, ...]  # SUMO edge ids, in driving order

    def edge(self, k: int) -> Any:
        """The sumolib Edge of the route's k-th edge."""
        return self.net.getEdge(self.edges[k])


def read_network(path: Path | str) -> Any:
    """The sumolib network at `path` with its internal lanes (cached on path, mtime,
    size). Raises InputError if it is missing, too big or not a SUMO network."""
    return read_network_file(Path(path), _read)


@functools.lru_cache(maxsize=8)
def _read(path: str, mtime_ns: int, size: int) -> Any:
    del mtime_ns, size  # part of the cache key only
    import sumolib

    try:
        net = sumolib.net.readNet(path, withInternal=True)
    except Exception as exc:  # noqa: BLE001 - sumolib raises whatever its SAX handler meets
        return InputError(path, "network", f"{type(exc).__name__}: {exc}",
                          "a readable SUMO .net.xml file")
    edges = [e for e in net.getEdges(withInternal=False) if e.getFunction() in ("", "normal")]
    if not edges:
        return InputError(path, "network", "no edge found", "a SUMO network with an edge")
    if not normal_edges(net):
        # a race track or a bus network: the SV is a passenger car, as SUMO's traffic is
        allowed = sorted({c for e in edges for ln in e.getLanes() for c in ln.getPermissions()})
        return InputError(path, "network", f"no lane allows {VCLASS}",
                          f"a SUMO network with a lane a passenger car may use (its edges "
                          f"allow {_some(allowed) or 'no vehicle class'}; "
                          f"the SV is a passenger car)")
    if left_hand(path):
        return InputError(path, "network", 'lefthand="true"', left_hand_refusal(path))
    problem = network_numbers_problem(net)
    if problem is not None:
        return InputError(path, problem[0], problem[1],
                          f"a SUMO network with numbers SUMO can use: {RULE} "
                          f"({problem[0]} = {problem[1]})")
    return net


def normal_edges(net: Any) -> list[Any]:
    """The network's normal edges (no internal, crossing or walking areas) a car may use."""
    return [e for e in net.getEdges(withInternal=False)
            if e.getFunction() in ("", "normal") and any(ln.allows(VCLASS) for ln in e.getLanes())]


def make_route(network: Path | str, edges: Sequence[str] | None = None, *,
               source: str | None = None, key: str = "route") -> Route:
    """The route `edges` on `network`, checked: every id a normal edge of the network, each
    connected to the next (a car may drive from one to the next). `edges` None: the
    network's only edge (refused if it has more). `source` / `key` name the file and key
    an error is reported against (default: the network and "route")."""
    path = Path(network)
    net = read_network(path)
    src = source if source is not None else str(path)
    normal = normal_edges(net)
    if edges is None:
        if len(normal) != 1:
            raise InputError(src, key, None, f"a list of edge ids: the network {path.name} has "
                             f"{len(normal)} edges ({_some(e.getID() for e in normal)})")
        return Route(path, net, (normal[0].getID(),))
    ids = tuple(str(e) for e in edges)
    if not ids:
        raise InputError(src, key, [], "a non-empty list of edge ids")
    known = {e.getID() for e in normal}
    for edge in ids:
        if edge not in known:
            raise InputError(src, key, edge, f"an edge of {path.name} a car may use "
                             f"({_some(sorted(known))})")
    for a, b in zip(ids[:-1], ids[1:], strict=True):
        ea, eb = net.getEdge(a), net.getEdge(b)
        usable = [c for c in ea.getConnections(eb)
                  if c.getFromLane().allows(VCLASS) and c.getToLane().allows(VCLASS)]
        if not usable:
            onward = sorted({e.getID() for e in ea.getOutgoing()})
            raise InputError(src, key, f"{a} -> {b}",
                             f"consecutive edges connected in {path.name} ({a} leads to "
                             f"{_some(onward) if onward else 'no edge'})")
    return Route(path, net, ids)


def _some(names: Any, n: int = 8) -> str:
    items = list(names)
    shown = ", ".join(items[:n])
    return shown + (f", ... ({len(items)} in all)" if len(items) > n else "")
