"""Tracks: the physical lanes of a route, each followed through SUMO's connections.

SUMO numbers lanes per edge (0 the rightmost), so a lane added on the right renumbers
every lane beside it: SUMO's index of one physical lane changes along a route. A
*track* is one physical lane followed from edge to edge through SUMO's connections,
including the internal junction lanes between them (`Connection.getViaLaneID()`), so
it keeps its identity where the indices shift; SUMO's lane id and index are properties
of the track on each edge (its `pieces`).

Where consecutive edges have several connections between them, each lane continues
into at most one lane and each lane is continued from at most one: of a lane that
splits (one lane feeding two) or two lanes that merge into one, the pair with the
smallest lateral jump (the distance sideways from the end of one lane to the start of
the other) continues the track. A track starts at the route's first edge or where a
lane has no connection from the route's previous edge (a lane added), and ends where
its lane has no connection onward (an acceleration lane, a lane drop) or at the
route's end. A track that ends before the route's end *exits* when its last lane runs
on onto an edge the route does not take (the lane that leaves at a diverge, onto an
off-ramp), rather than ending or merging into a lane of the route's next edge.

The route's *carriageway edge* is the edge whose lanes are the SV's: its first edge,
unless no lane of the first edge runs to the route's last edge but one runs beside a lane
that does, from where that lane begins: a route that starts on an on-ramp (its lane runs
on as the acceleration lane beside the mainline, whose lanes begin on the edge that
carries it) or leaves over an off-ramp (the mainline's lanes run beside the
deceleration lane, which begins along the route and runs on onto the ramp). Then the
carriageway edge is where the first lane that runs to the route's end begins, and the
lane of the first edge beside it there is the reference's *lead-in* (`reference_tracks`).
The lead-in may itself begin along the route, led in by a lane of the first edge that
ends beside it: a two-lane on-ramp whose first edge's one lane runs on as its right lane,
which ends where the ramp narrows to its left lane, the one that becomes the
acceleration lane (SUMO's game/highway). The lane that ends is then one of the SV's
lanes too (a *ramp lane*: it must change out of it, as out of any lane that ends), on
the side of the lead-in it lies on where the lead-in begins. A ramp lane whose SV lane
is a lane of the carriageway edge that begins along the route (a route from an on-ramp
over an off-ramp: the acceleration lane ends, then the deceleration lane begins where
it would run on) *joins* that lane (`Track.joins`): the two are one SV lane, the ramp
lane up to its end, the other from its begin, never both at one s. A ramp lane that
would share an SV lane with any other lane of the carriageway edge has no carriageway
edge.

Track ids: the tracks present on the carriageway edge have SUMO's index there
(0 the rightmost: the paper's Lane 1/2/3 are tracks 0/1/2), one more for each ramp lane
on their right; the other tracks (a ramp lane that joins one of them too) are numbered on
from there, in driving order and right to left. On a one-edge network track id = SUMO lane index.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from cosim.errors import InputError
from cosim.road.route import VCLASS, Route

Point = tuple[float, float]


@dataclass(frozen=True)
class TrackPiece:
    """One SUMO lane of a track: a lane of a route edge or a junction lane between two."""

    edge: str  # SUMO edge id (":j2_0" for a junction's internal edge)
    lane: str  # SUMO lane id
    index: int  # SUMO's lane index on that edge
    internal: bool  # a junction lane (not on a route edge)
    route_index: int  # position of the edge in the route (a junction lane: the edge before it)
    shape: tuple[Point, ...]  # m, SUMO's lane centre polyline
    width: float  # m
    speed: float  # m/s, SUMO's speed limit of the lane
    length: float  # m, SUMO's lane length (lane positions run from 0 to it)


@dataclass(frozen=True)
class Track:
    """One physical lane followed along the route."""

    id: int  # see the module docstring
    pieces: tuple[TrackPiece, ...]  # in driving order
    exits: bool = False  # its last lane runs on off the route (see the module docstring)
    # a ramp lane that ends before the SV lane it carries on as begins: that lane's track
    # id (-1: none; see the module docstring)
    joins: int = -1

    @property
    def name(self) -> str:
        """SUMO's id of the lane where the track begins."""
        return self.pieces[0].lane

    @property
    def first_edge(self) -> int:
        """Route position of the edge the track begins on."""
        return self.pieces[0].route_index

    @property
    def last_edge(self) -> int:
        """Route position of the edge the track ends on."""
        return self.pieces[-1].route_index

    def piece_on(self, edge: str) -> TrackPiece | None:
        """The track's lane on `edge` (None: the track is not on it)."""
        for piece in self.pieces:
            if piece.edge == edge:
                return piece
        return None

    def shape(self) -> list[Point]:
        """m, the track's centre line: its pieces' shapes joined (repeated points once)."""
        points: list[Point] = []
        for piece in self.pieces:
            for p in piece.shape:
                if not points or math.dist(points[-1], p) > 1e-9:
                    points.append(p)
        return points


def _piece(lane: Any, route_index: int) -> TrackPiece:
    edge = lane.getEdge()
    return TrackPiece(
        edge=edge.getID(), lane=lane.getID(), index=lane.getIndex(),
        internal=edge.getFunction() == "internal", route_index=route_index,
        shape=tuple((float(x), float(y)) for x, y in lane.getShape()),
        width=float(lane.getWidth()), speed=float(lane.getSpeed()),
        length=float(lane.getLength()),
    )


def lateral_jump(from_lane: Any, to_lane: Any) -> float:
    """m, how far sideways the start of `to_lane` lies from the end of `from_lane`
    (across the last segment's direction of `from_lane`)."""
    shape = from_lane.getShape()
    (x0, y0), (x1, y1) = shape[-2], shape[-1]
    tx, ty = x1 - x0, y1 - y0
    norm = math.hypot(tx, ty) or 1.0
    qx, qy = to_lane.getShape()[0]
    return abs(tx * (qy - y1) - ty * (qx - x1)) / norm


def lane_turn(from_lane: Any, to_lane: Any) -> float:
    """rad, by how much the heading of `to_lane`'s first segment turns from that of
    `from_lane`'s last segment (0 to pi)."""
    (x0, y0), (x1, y1) = from_lane.getShape()[-2:]
    (x2, y2), (x3, y3) = to_lane.getShape()[:2]
    turn = math.atan2(y3 - y2, x3 - x2) - math.atan2(y1 - y0, x1 - x0)
    return abs(math.remainder(turn, 2.0 * math.pi))


def _continuations(net: Any, a: Any, b: Any) -> dict[int, tuple[int, list[Any]]]:
    """From-lane index -> (to-lane index, junction lanes between) for the lanes of edge
    `a` that continue on edge `b`: one-to-one, by the smallest lateral jump."""
    candidates = []
    for c in a.getConnections(b):
        fl, tl = c.getFromLane(), c.getToLane()
        if fl.allows(VCLASS) and tl.allows(VCLASS):
            candidates.append((lateral_jump(fl, tl), fl.getIndex(), tl.getIndex(), c))
    candidates.sort(key=lambda item: (item[0], item[1], item[2]))
    taken_from: dict[int, tuple[int, list[Any]]] = {}
    taken_to: set[int] = set()
    for _, i, j, c in candidates:
        if i in taken_from or j in taken_to:
            continue
        taken_from[i] = (j, via_chain(net, c))
        taken_to.add(j)
    return taken_from


def via_chain(net: Any, connection: Any) -> list[Any]:
    """The internal lanes a connection runs through, in order (an internal junction
    splits them in two)."""
    lanes: list[Any] = []
    via = connection.getViaLaneID()
    target = connection.getToLane().getID()
    while via and len(lanes) < 16:
        lane = net.getLane(via)
        lanes.append(lane)
        onward = [c for c in lane.getOutgoing() if c.getToLane().getID() == target]
        via = onward[0].getViaLaneID() if onward else ""
    return lanes


def follow_tracks(route: Route) -> tuple[Track, ...]:
    """The route's tracks (see the module docstring), ordered by id."""
    net = route.net
    first = route.edge(0)
    building: dict[int, list[TrackPiece]] = {}
    open_by_index: dict[int, int] = {}  # SUMO index on the current edge -> track id
    for lane in sorted(first.getLanes(), key=lambda ln: ln.getIndex()):
        if lane.allows(VCLASS):
            building[lane.getIndex()] = [_piece(lane, 0)]
            open_by_index[lane.getIndex()] = lane.getIndex()
    next_id = max(building) + 1 if building else 0
    for k in range(1, len(route.edges)):
        a, b = route.edge(k - 1), route.edge(k)
        cont = _continuations(net, a, b)
        now: dict[int, int] = {}
        for i, track in sorted(open_by_index.items()):
            if i not in cont:
                continue  # the lane ends here: so does its track
            j, vias = cont[i]
            building[track] += [_piece(v, k - 1) for v in vias]
            building[track].append(_piece(net.getEdge(b.getID()).getLane(j), k))
            now[j] = track
        # lanes of b no track reached: a track starts, numbered right to left
        for lane in sorted(b.getLanes(), key=lambda ln: ln.getIndex()):
            j = lane.getIndex()
            if j not in now and lane.allows(VCLASS):
                building[next_id] = [_piece(lane, k)]
                now[j] = next_id
                next_id += 1
        open_by_index = now
    tracks = [Track(tid, tuple(pieces), _exits(route, pieces[-1]))
              for tid, pieces in sorted(building.items())]
    k = carriageway(route, tracks)
    if k == 0:
        return tuple(tracks)
    # numbered by SUMO's index on the carriageway edge (up by the ramp lanes on its
    # right), the ramp lanes by their side, the others on from there
    on = {t.id: p.index for t in tracks if (p := t.piece_on(route.edges[k])) is not None}
    ramp = ramp_lanes(route, tracks, k)
    n = len(on)
    joined = {tid: lane for tid, lane in ramp.items() if 0 <= lane < n}
    beside = {tid: lane for tid, lane in ramp.items() if tid not in joined}
    below = -min(beside.values(), default=0)
    ids = {tid: lane + below for tid, lane in (on | beside).items()}
    next_id = max(ids.values()) + 1
    for t in tracks:
        if t.id not in ids:
            ids[t.id] = next_id
            next_id += 1
    by_lane = {lane: tid for tid, lane in on.items()}
    joins = {tid: ids[by_lane[lane]] for tid, lane in joined.items()}
    return tuple(sorted((replace(t, id=ids[t.id], joins=joins.get(t.id, -1)) for t in tracks),
                        key=lambda t: t.id))


def carriageway(route: Route, tracks: Sequence[Track]) -> int:
    """Route index of the carriageway edge (module docstring): 0 unless no lane of the
    first edge runs to the route's last edge and one of them runs beside a lane that
    does, from where that lane begins (the earliest such), directly or through lanes
    that begin along the route (`lead_chain`), its ramp lanes beside the carriageway
    edge's (`ramp_lanes`)."""
    last = len(route.edges) - 1
    through = [t for t in tracks if t.last_edge == last]
    if not through or any(t.first_edge == 0 for t in through):
        return 0
    k = min(t.first_edge for t in through)
    chain = lead_chain(route, tracks, k)
    if not chain:
        return 0
    return k if _ramp_lanes(route, tracks, k, chain) is not None else 0


def lead_chain(route: Route, tracks: Sequence[Track], k: int) -> list[tuple[Track, int]]:
    """The lead-in of the carriageway edge `k` and the lanes leading into it, each as
    (track, route index of the edge where the lane after it begins), from the
    carriageway edge back to a lane of the route's first edge: the lane nearest the
    reference's first lane on edge k among those beside it that begin before it (on a
    tie the right), one of the first edge if any; one that begins along the route led in
    the same way where it begins. Empty: none leads back to the first edge."""
    last = len(route.edges) - 1
    ref = min((t for t in tracks if t.first_edge == k and t.last_edge == last),
              key=lambda t: t.pieces[0].index, default=None)
    if ref is None:
        return []
    return _chain(route, tracks, ref, k)


def _chain(route: Route, tracks: Sequence[Track], after: Track, k: int
           ) -> list[tuple[Track, int]]:
    edge = route.edges[k]
    index = _on(after, edge).index
    beside = sorted((t for t in tracks if t.first_edge < k <= t.last_edge
                     and t.piece_on(edge) is not None),
                    key=lambda t: (abs(_on(t, edge).index - index), _on(t, edge).index))
    direct = [t for t in beside if t.first_edge == 0]
    if direct:
        return [(direct[0], k)]
    for t in beside:
        rest = _chain(route, tracks, t, t.first_edge)
        if rest:
            return [(t, k), *rest]
    return []


def ramp_lanes(route: Route, tracks: Sequence[Track], k: int) -> dict[int, int]:
    """Track id -> SV lane (SUMO's index on the carriageway edge `k`; -1: right of its
    rightmost lane) of the ramp lanes (module docstring): the lanes of the lead chain
    (`lead_chain`) that end before the carriageway edge; empty if none do. One whose SV
    lane is a lane of edge `k` joins it (that lane begins on edge `k`)."""
    return _ramp_lanes(route, tracks, k, lead_chain(route, tracks, k)) or {}


def _ramp_lanes(route: Route, tracks: Sequence[Track], k: int,
                chain: list[tuple[Track, int]]) -> dict[int, int] | None:
    """`ramp_lanes` of `chain`; None when a ramp lane would share an SV lane with
    another, or with a lane of the carriageway edge that does not begin there (which it
    then joins), or leave a gap beside the carriageway edge's lanes."""
    edge = route.edges[k]
    n = sum(1 for t in tracks if t.piece_on(edge) is not None)
    begins = {_on(t, edge).index for t in tracks if t.first_edge == k}
    first, _ = chain[0]
    lane = _on(first, edge).index
    out: dict[int, int] = {}
    for (after, _), (track, j) in zip(chain[:-1], chain[1:], strict=True):
        at = route.edges[j]
        lane += _on(track, at).index - _on(after, at).index
        if track.last_edge < k:
            out[track.id] = lane
    joined = [v for v in out.values() if 0 <= v < n]
    if len(set(joined)) < len(joined) or not begins.issuperset(joined):
        return None  # a ramp lane on a lane of the carriageway edge that runs beside it
    taken = sorted(v for v in out.values() if not 0 <= v < n)
    below, above = [v for v in taken if v < 0], [v for v in taken if v >= n]
    if (len(below) + len(above) < len(taken) or below != list(range(-len(below), 0))
            or above != list(range(n, n + len(above)))):
        return None  # a ramp lane among the carriageway edge's, on another, or apart
    return out


def _exits(route: Route, last: TrackPiece) -> bool:
    """Whether the lane `last` (a track's last, on a route edge) connects onto an edge
    the route does not take next: not a U-turn, a lane a car may use."""
    k = last.route_index
    if k + 1 >= len(route.edges):
        return False  # the route's end: the track runs through
    lane = route.net.getLane(last.lane)
    return any(c.getToLane().getEdge().getID() != route.edges[k + 1]
               and c.getDirection() != "t" and c.getToLane().allows(VCLASS)
               for c in lane.getOutgoing())


@dataclass(frozen=True)
class LeadIn:
    """The reference's lead-in: on a route whose carriageway edge is not its first, the
    lane beside the reference where the reference begins; before it the reference line
    runs `shift` m to the left of this track (a ramp's lane). A lead-in that begins
    along the route is itself led in (`before`) where it begins."""

    track: Track
    shift: float  # m, the reference's centre left of this track's on the carriageway edge
    edge: int  # route index of the carriageway edge (where the reference begins)
    # the lead-in of this one's track where it begins (a ramp lane ending beside it): its
    # `edge` that track's first, its `shift` the reference's centre left of its track
    before: LeadIn | None = None

    def pieces(self) -> tuple[TrackPiece, ...]:
        """Its pieces before the carriageway edge (junction lanes into it included), led
        in by `before`'s."""
        return tuple(p for p, _ in self.shifted_pieces())

    def shifted_pieces(self) -> tuple[tuple[TrackPiece, float], ...]:
        """(piece, m the reference line runs left of it) of `pieces`, in driving order."""
        return tuple((p, shift) for pieces, shift in self.runs() for p in pieces)

    def runs(self) -> tuple[tuple[tuple[TrackPiece, ...], float], ...]:
        """(pieces, shift) of each lead-in of the chain in driving order: its track's
        pieces before the edge where the next begins, and its `shift`."""
        own = (tuple(p for p in self.track.pieces if p.route_index < self.edge), self.shift)
        return (own,) if self.before is None else (*self.before.runs(), own)

    def chain(self) -> tuple[LeadIn, ...]:
        """This lead-in and those leading into it, from the carriageway edge back."""
        return (self,) if self.before is None else (self, *self.before.chain())


def reference_tracks(route: Route, tracks: tuple[Track, ...], source: str | None = None
                     ) -> tuple[Track, LeadIn | None]:
    """The frame's reference: the rightmost track that runs from the carriageway edge to
    the route's last; on a route whose carriageway edge is not its first, also its
    `LeadIn` (`lead_chain`: the nearest lane of the first edge beside it there, on a tie
    the right, or the lanes that lead back to one).
    Raises InputError if no lane runs through, saying why (`reference_track`)."""
    k = carriageway(route, tracks)
    if k == 0:
        return reference_track(route, tracks, source), None
    last = len(route.edges) - 1
    after = min((t for t in tracks if t.first_edge == k and t.last_edge == last),
                key=lambda t: t.pieces[0].index)
    ref, shift = after, 0.0
    links = []
    for track, j in lead_chain(route, tracks, k):
        edge = route.edges[j]
        shift += side_gap(route.net, edge, _on(track, edge).index, _on(after, edge).index)
        links.append((track, shift, j))
        after = track
    lead: LeadIn | None = None
    for track, gap, j in reversed(links):
        lead = LeadIn(track, gap, j, lead)
    return ref, lead


def _on(track: Track, edge: str) -> TrackPiece:
    piece = track.piece_on(edge)
    assert piece is not None
    return piece


def side_gap(net: Any, edge: str, i: int, j: int) -> float:
    """m, how far the centre of lane `j` of `edge` lies left of lane `i`'s (SUMO places
    an edge's lanes side by side)."""
    widths = {ln.getIndex(): float(ln.getWidth()) for ln in net.getEdge(edge).getLanes()}
    if i == j:
        return 0.0
    lo, hi = sorted((i, j))
    gap = 0.5 * widths[lo] + sum(widths[m] for m in range(lo + 1, hi)) + 0.5 * widths[hi]
    return gap if j > i else -gap


def reference_track(route: Route, tracks: tuple[Track, ...], source: str | None = None) -> Track:
    """The rightmost track that runs through the whole route: the road frame's reference
    on a route whose carriageway edge is its first (`reference_tracks` for any route).
    Raises InputError if no lane runs from the route's first edge to its last, saying
    why: the route leaves its first edge's lanes at a diverge with no deceleration lane
    beside them, or they end before a lane that runs on begins beside them."""
    through = [t for t in tracks if t.first_edge == 0 and t.last_edge == len(route.edges) - 1]
    if not through:
        raise InputError(source or str(route.path), "route", list(route.edges),
                         "a route along which at least one lane runs from the first edge to "
                         "the last, or from beside them (no lane of it does; "
                         f"{_why_none_runs_through(route, tracks)})")
    return min(through, key=lambda t: t.pieces[0].index)


def _why_none_runs_through(route: Route, tracks: tuple[Track, ...]) -> str:
    """Why none of the lanes of the route's first edge reaches its last edge, nor runs
    beside a lane that does where that lane begins, in words: where the last of them
    ends, they go on to another edge than the route's next (the route leaves them at a
    diverge), or they end there (an on-ramp's acceleration lane, a lane drop)."""
    first = [t for t in tracks if t.first_edge == 0]
    k = max((t.last_edge for t in first), default=0)
    here, onward = route.edges[k], route.edges[k + 1]
    elsewhere = sorted({c.getTo().getID()
                        for t in first if t.last_edge == k
                        for c in route.net.getLane(t.pieces[-1].lane).getOutgoing()
                        if c.getTo().getID() != onward and c.getToLane().allows(VCLASS)})
    if elsewhere:
        return (f"its lanes on {here} go on to {', '.join(elsewhere)}, and the route leaves "
                f"them there for {onward} with no lane beside them that runs on to it (a "
                "deceleration lane): end the route before the diverge (on "
                f"{here} at the latest)")
    return (f"the lanes of its first edge end on {here} before a lane that runs to the "
            f"route's last edge runs beside them: start the route on {here} or end it there")
