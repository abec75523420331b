"""The SUMO side of the route's road (cosim.road.road.Road): which of its tracks are the
SV's lanes, where a point (track, s) lies in SUMO's terms (edge, lane index, lane
position), which track a Cartesian point is in (the moveToXY hint), and the planner's
RoadParams of the road.

A *through track* runs the whole route, from its first edge to its last. The SV's lanes
("lane k" in scenarios, the policy and RoadParams) are the tracks present on the route's
first edge, k their track id (SUMO's lane index there): each runs through or ends on the
route (an acceleration lane on the right, a lane dropped on the left or right), and
RoadParams.lane_ends says where. On networks/curved_motorway.net.xml they are tracks 0,
1, 2 (all through); on networks/onramp.net.xml along `acc main1 main2` tracks 0-3, track
0 the acceleration lane that ends after 194.5 m; on a route from a ramp whose lane ends
before the acceleration lane, that ramp lane too (cosim.road.tracks: lane 0, right of
the acceleration lane); on a route from an on-ramp over an off-ramp the ramp's lane and
the deceleration lane are one SV lane (the ramp lane *joins* it: `joined_lane`), the one
up to the acceleration lane's end, the other from its begin. Tracks that begin later (a
lane added along the route) carry traffic but are no SV lanes (the snapshot's lane -1).
What is refused (`check_lanes`): no lane running through, an SV lane ending between two
that run on, lanes of different widths. The scenario's speed bands are per through
track, in track id order; an SV lane that ends takes the band of the through lane beside
it, any other track the band of the SV lane next to it (nearest by SUMO's lane index on
the track's first route edge; on a tie the one on its right, the slower).

On a one-edge straight road the track id is SUMO's lane index and every conversion is
the exact arithmetic of the old one-edge code (s = x - x0, lane position = s - s of the
lane's start), so results on it do not change.
"""

from __future__ import annotations

import bisect
import functools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from cosim.errors import InputError
from cosim.params import RoadParams
from cosim.road.frame import StraightFrame
from cosim.road.lanes import LaneTable
from cosim.road.road import Road, load_road
from cosim.road.tracks import TrackPiece

ROUTE_ID = "highway_route"  # SUMO's id of the whole route (of the rest from edge k: @k)
# m/s: a band's top above a limit by less is the same speed (netconvert writes 120 km/h
# as 33.33 m/s)
SPEED_TOLERANCE = 0.5 / 3.6
SAMPLE_STEP = 2.0  # m, lane positions sampled along a curved lane to map s to them


@dataclass(frozen=True)
class Place:
    """Where a point of a track lies in SUMO's terms."""

    edge: str  # SUMO edge id (a route edge: never a junction's internal edge)
    index: int  # SUMO lane index on it
    position: float  # m, lane position (from the lane's start, as SUMO counts it)
    route_index: int  # the edge's position in the route


def load_route_road(network: Path | str, route: Sequence[str] | None = None,
                    source: str | None = None) -> Road:
    """The Road of `route` on `network` (cosim.road.road.load_road), built once per
    process for a file as it is (cached on its path, modification time and size); an
    InputError names `source` (e.g. the scenario) if given."""
    path = Path(network)
    try:
        st = path.stat()
    except (OSError, ValueError):  # load_road says what is wrong with it, in one line
        return _load_road_as_scenario(network, route, source)
    try:
        return _cached_route_road(str(path.resolve()), st.st_mtime_ns, st.st_size,
                                  None if route is None else tuple(route))
    except InputError:
        if source is None:
            raise
        return _load_road_as_scenario(network, route, source)  # raises, naming `source`


# load_road's keys for the road's geometry: a scenario knows them as road.route (or
# road.network, for a network's only edge)
ROAD_SHAPE_KEYS = ("route", "reference lane", "reference line radius",
                   "reference line deviation", "lane deviation")


def _load_road_as_scenario(network: Path | str, route: Sequence[str] | None,
                           source: str | None) -> Road:
    """load_road; a fault of the road's shape is told under the scenario's key."""
    try:
        return load_road(network, route, source=source)
    except InputError as exc:
        if source is None or exc.key not in ROAD_SHAPE_KEYS:
            raise
        key, value = (("road.route", list(route)) if route is not None
                      else ("road.network", str(network)))
        what = "" if exc.key == "route" else f" ({exc.key}: {exc.value})"
        raise InputError(exc.source, key, value, exc.allowed + what) from None


@functools.lru_cache(maxsize=8)
def _cached_route_road(path: str, mtime_ns: int, size: int,
                       route: tuple[str, ...] | None) -> Road:
    del mtime_ns, size  # part of the cache key only
    return load_road(path, route)


def through_tracks(route_road: Road) -> tuple[LaneTable, ...]:
    """The tracks that run from the route's carriageway edge to its last, in track id
    order (of an SV lane a ramp lane joins, the lane it joins: from where it begins)."""
    last = len(route_road.route.edges) - 1
    return tuple(table for t in sv_tracks(route_road)
                 if (table := route_road.lane(t.id)).track.last_edge == last)


def sv_tracks(route_road: Road) -> tuple[LaneTable, ...]:
    """The SV's lanes: the tracks present on the route's carriageway edge (its first
    edge, or where the mainline begins on a route from an on-ramp or the deceleration
    lane on one that leaves over an off-ramp: cosim.road.tracks), running through or
    ending on the route, and the ramp lanes that end before it beside them (a ramp's
    lane dropped before the acceleration lane), in track id order (SUMO's lane index on
    that edge, up by the ramp lanes on its right)."""
    k = route_road.carriageway
    joined = route_road.joined
    return tuple(joined_lane(joined[t.id], t) if t.id in joined else t
                 for t in route_road.lanes
                 if (t.track.first_edge <= k <= t.track.last_edge
                     or t.id in route_road.ramp_lanes)
                 and not t.track.pieces[0].internal)


def joined_lane(ramp: LaneTable, lane: LaneTable) -> LaneTable:
    """One SV lane of a ramp lane that ends and the lane it joins, which begins further
    on (cosim.road.tracks: an acceleration lane, then a deceleration lane): its pieces
    the ramp lane's then the other's, its id the other's (RoadParams.lane_ends: where
    the ramp lane ends, RoadParams.lane_begins: where the other begins)."""
    return LaneTable(
        replace(lane.track, pieces=ramp.track.pieces + lane.track.pieces),
        *(np.concatenate([getattr(ramp, f), getattr(lane, f)])
          for f in ("s_start", "s_end", "d_start", "d_end", "width", "speed")),
        max(ramp.deviation, lane.deviation))


def _feeding(route_road: Road, tracks: Sequence[LaneTable]) -> Iterator[tuple[LaneTable, Any]]:
    """(track, sumolib connection) of each connection SUMO makes into the first lane of
    each of `tracks` from the edges before the track's first edge (the route's first
    edge, or the carriageway edge where the mainline begins beside an on-ramp's lane)
    that are not on the route, in SUMO's order (none on a route that starts where the
    network does)."""
    for table in tracks:
        first = route_road.route.edge(table.track.first_edge)
        lane = table.track.pieces[0].lane
        for edge in first.getIncoming():
            if edge.getID() in route_road.route.edges:
                continue
            for conn in edge.getConnections(first):
                if conn.getToLane().getID() == lane:
                    yield table, conn


def upstream_lanes(route_road: Road, tracks: Sequence[LaneTable]) -> dict[str, int]:
    """SUMO lane id -> track id of the lanes (and their junction lanes) that SUMO
    connects into the first lane of each of `tracks` from the edges before the route's
    first edge (`_feeding`)."""
    feeds: dict[str, int] = {}
    for table, conn in _feeding(route_road, tracks):
        feeds.setdefault(conn.getFromLane().getID(), table.id)
        via = conn.getViaLaneID()
        if via:
            feeds.setdefault(via, table.id)
    return feeds


@dataclass(frozen=True)
class Upstream:
    """The lane before the route's first edge that feeds a through track's first lane
    (the mainline's upstream edge): where the random traffic enters the road, so that it
    comes up from behind the SV's horizon instead of appearing beside the route's start
    (where an SV starting on an acceleration lane would plan its merge with nobody behind
    it, and see the inflow appear close behind it)."""

    edge: str  # SUMO edge id
    index: int  # SUMO lane index on it
    length: float  # m, SUMO's length of the lane
    joins: int = 0  # route index of the edge it feeds (the track's first)


def upstream_entries(route_road: Road, tracks: Sequence[LaneTable]) -> dict[int, Upstream]:
    """Track id -> the `Upstream` lane feeding it, for each of `tracks` fed from an edge
    before the route's first edge (the first connection `_feeding` gives)."""
    entries: dict[int, Upstream] = {}
    for table, conn in _feeding(route_road, tracks):
        if table.id not in entries:
            source = conn.getFromLane()
            entries[table.id] = Upstream(source.getEdge().getID(), source.getIndex(),
                                         float(source.getLength()), table.track.first_edge)
    return entries


def lane_width(route_road: Road, source: str | None = None) -> float:
    """m, the SV lanes' common width (InputError, one line, if they differ, naming the
    SUMO lanes of the less common width: a lane's own width, an edge's width)."""
    lanes = [(p.lane, round(float(w), 6)) for t in sv_tracks(route_road) for w, p in
             zip(t.width, t.track.pieces, strict=True) if not p.internal]
    widths = sorted({w for _, w in lanes})
    if len(widths) != 1:
        counts = {w: sum(1 for _, v in lanes if v == w) for w in widths}
        usual = max(widths, key=lambda w: (counts[w], w))
        odd = [f"{lane} {w:g} m" for lane, w in lanes if w != usual]
        named = ", ".join(odd[:3]) + (f" and {len(odd) - 3} more" if len(odd) > 3 else "")
        raise InputError(source or str(route_road.route.path), "lane widths", widths,
                         "lanes of one width along the route (the planner's lanes "
                         f"are one width; these are {', '.join(f'{w:g}' for w in widths)} m: "
                         f"SUMO's lanes {named}, the others {usual:g} m; a lane or edge "
                         "width of its own is not supported)")
    return widths[0]


def expand_bands(route_road: Road, bands: tuple[tuple[float, float], ...]
                 ) -> tuple[tuple[float, float], ...]:
    """One speed band per SV lane from `bands`, one per through lane (the scenario's):
    an SV lane that ends takes its nearest through lane's band. `bands` of another
    length are returned as they are (one per SV lane already, or a count the scenario
    rules refuse)."""
    lanes = sv_tracks(route_road)
    through = [t.id for t in through_tracks(route_road)]
    if len(bands) != len(through) or len(lanes) == len(through):
        return bands
    rank = {tid: k for k, tid in enumerate(through)}
    out = []
    for t in lanes:
        nearest = min(through, key=lambda tid: (abs(tid - t.id), tid))
        out.append(bands[rank[t.id if t.id in rank else nearest]])
    return tuple(out)


def road_params(route_road: Road, base: RoadParams | None = None,
                source: str | None = None) -> RoadParams:
    """The planner's view of the road in (s, d): one lane per SV lane (`sv_tracks`), their
    width, y_right the d of lane 0's right border (d = 0 is the reference track's right
    border: 0 unless lanes that end lie right of it, an acceleration lane: -width),
    lane_ends where each ends (s, m; () when none does), speed bands (`base`'s, one per
    through lane, `expand_bands`) and mu from `base`."""
    base = base or RoadParams()
    width = lane_width(route_road, source)
    lanes = sv_tracks(route_road)
    through = {t.id for t in through_tracks(route_road)}
    below = sum(1 for t in lanes if t.id < route_road.reference.id)
    # a lane a ramp lane joins ends, for the SV, where the ramp lane does, and begins again
    # where it begins (RoadParams.lane_ends)
    joined = route_road.joined
    ends = tuple(joined[t.id].end if t.id in joined else math.inf if t.id in through
                 else t.end for t in lanes)
    # the SV changes lanes nowhere in a corner (cosim.road.corners): a lane beginning in
    # one begins for it where the corner ends
    zones = route_road.corner_zones()
    own = [route_road.lane(t.id) for t in lanes]  # a joined lane: from its own begin
    begins = tuple(max([t.begin] + [hi for lo, hi, _ in zones if lo <= t.begin <= hi])
                   if t.track.first_edge > 0 else -math.inf for t in own)
    bands = expand_bands(route_road, base.speed_bands)
    limits = speed_limits(lanes, bands)
    return RoadParams(lane_width=width, speed_bands=bands,
                      mu=base.mu, y_right=-below * width if below else 0.0,
                      lane_ends=ends if any(math.isfinite(e) for e in ends) else (),
                      lane_begins=begins if any(math.isfinite(b) for b in begins) else (),
                      corners=route_road.corner_zones(),
                      speed_limits=limits if any(limits) else ())


def speed_limits(lanes: Sequence[LaneTable], bands: Sequence[tuple[float, float]]
                 ) -> tuple[tuple[tuple[float, float, float], ...], ...]:
    """Per SV lane, the (s_lo m, s_hi m, v m/s) of its route edges whose SUMO limit v is
    below the top of its band by SPEED_TOLERANCE or more (junction lanes take the limits
    of the edges either side). Lanes without a band of their own (a count the scenario
    rules refuse) have none."""
    if len(bands) != len(lanes):
        return ()
    out = []
    for table, (_, top) in zip(lanes, bands, strict=True):
        out.append(tuple((float(lo), float(hi), float(v)) for lo, hi, v, p in zip(
            table.s_start, table.s_end, table.speed, table.track.pieces, strict=True)
            if not p.internal and v < top - SPEED_TOLERANCE))
    return tuple(out)


def exit_lanes(route_road: Road) -> tuple[int, ...]:
    """The SV lanes (k, as in RoadParams) whose end is an exit: the lane runs on off the
    route at a diverge (cosim.road.tracks) rather than ending. To the planner both end
    where RoadParams.lane_ends says (the SV must have left the lane by then to stay on
    its route); the figures tell them apart."""
    return tuple(k for k, t in enumerate(sv_tracks(route_road)) if t.track.exits)


class RouteLanes:
    """The route's tracks as SUMO sees them (see the module docstring)."""

    def __init__(self, route_road: Road) -> None:
        self.route_road = route_road
        self.through = through_tracks(route_road)
        self.sv = sv_tracks(route_road)  # the SV's lanes (through or ending on the route)
        self.straight = isinstance(route_road.frame, StraightFrame)
        # SUMO lane id -> SV-lane (track) id, junction lanes included (the snapshot's lane)
        self.sv_lane: dict[str, int] = {
            p.lane: t.id for t in self.sv for p in t.track.pieces}
        # ... and the lanes feeding the through lanes from before the route's first edge
        # (the mainline's upstream edge): the traffic coming up behind an SV that starts
        # near the route's start (on an acceleration lane: its new follower) is
        # seen at s < 0 on the frame's straight extension; not a ramp feeding a lane that
        # ends (it joins at an angle: off the frame's extension)
        # (and of the SV lanes that begin along the route without running through: the
        # mainline beside an on-ramp's lane on a route that leaves it over an off-ramp)
        through = {t.id for t in self.through}
        fed = self.through + tuple(t for t in self.sv if t.track.first_edge > 0
                                   and t.id not in through)
        self.sv_lane |= upstream_lanes(route_road, fed)
        self.upstream = upstream_entries(route_road, fed)  # where the inflow enters
        # the lanes of route edges, with their tracks (a TV's band changes only there)
        self.edge_lanes: tuple[tuple[str, int], ...] = tuple(
            (p.lane, t.id) for t in route_road.lanes for p in t.track.pieces if not p.internal)
        self._s_end = {t.id: t.s_end.tolist() for t in route_road.lanes}
        # m, every track's begin and end: which tracks exist changes only there
        self._bounds = sorted({b for t in route_road.lanes for b in (t.begin, t.end)})
        self._added: set[int] = set()  # route indices whose rest-of-route SUMO has
        self.extra_routes: set[str] = set()  # other routes added to SUMO (on-ramp traffic)
        self._sampled: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}

    @property
    def length(self) -> float:
        """m, the stretch of s every through track covers."""
        return min(t.end for t in self.through) - max(t.begin for t in self.through)

    @functools.cached_property
    def band_index(self) -> dict[int, int]:
        """Track id -> index of its speed band in RoadParams.speed_bands (an SV lane's
        own; any other track: its neighbouring SV lane's)."""
        index = {t.id: k for k, t in enumerate(self.sv)}
        for table in self.route_road.lanes:
            if table.id in index:
                continue
            piece = next(p for p in table.track.pieces if not p.internal)
            beside = [(abs(q.index - piece.index), q.index, index[t.id]) for t in self.sv
                      if (q := t.track.piece_on(piece.edge)) is not None]
            index[table.id] = min(beside)[2] if beside else 0
        return index

    def route_id(self, api: ModuleType, route_index: int) -> str:
        """SUMO's id of the route from its `route_index`-th edge on (added on first use;
        the whole route is added when SUMO starts)."""
        rid = ROUTE_ID if route_index == 0 else f"{ROUTE_ID}@{route_index}"
        if route_index not in self._added:
            api.route.add(rid, list(self.route_road.route.edges[route_index:]))
            self._added.add(route_index)
        return rid

    def route_id_of(self, api: ModuleType, place: Place) -> str:
        """SUMO's id of the route from `place` on: the rest of the route from its edge,
        or (an `upstream_place`) that edge followed by the whole route (added on first
        use)."""
        if place.route_index >= 0:
            return self.route_id(api, place.route_index)
        rid = f"{ROUTE_ID}^{place.edge}"
        if rid not in self.extra_routes:
            joins = next(u.joins for u in self.upstream.values() if u.edge == place.edge)
            api.route.add(rid, [place.edge, *self.route_road.route.edges[joins:]])
            self.extra_routes.add(rid)
        return rid

    def upstream_place(self, track: int, s: float) -> Place | None:
        """The point at `s` (m) on `track` before the track's start, on its `Upstream` lane
        (route_index -1; `route_id_of` gives its route): s - begin metres before the lane's
        end, at least its start. None when `s` is on the route or the track has no
        upstream lane."""
        up = self.upstream.get(track)
        begin = self.table(track).begin
        if up is None or s >= begin:
            return None
        return Place(up.edge, up.index, max(up.length + (s - begin), 0.0), -1)

    def upstream_room(self, track: int, wanted: float) -> float:
        """m, the stretch before `track`'s start on its upstream lane, up to `wanted` (0:
        none)."""
        up = self.upstream.get(track)
        return 0.0 if up is None else min(wanted, up.length)

    def forget_routes(self) -> None:
        """SUMO closed: its routes are gone."""
        self._added.clear()
        self.extra_routes.clear()

    def table(self, track: int) -> LaneTable:
        """The lane table of a track (InputError: no such track on the route)."""
        try:
            return self.route_road.lane(track)
        except KeyError:
            ids = [t.id for t in self.route_road.lanes]
            raise InputError("traffic", "track", track, f"a track of the route {ids}") from None

    def place(self, track: int, s: float) -> Place:
        """SUMO's edge, lane index and lane position of the point at `s` (m) on `track`.
        On a junction's internal lane: the start of the next edge; beyond the track's
        ends: its first (last) edge's start (end)."""
        table = self.table(track)
        pieces = table.track.pieces
        k = min(bisect.bisect_left(self._s_end[track], s), len(pieces) - 1)
        piece = pieces[k]
        if piece.internal:
            if k + 1 < len(pieces):
                nxt = pieces[k + 1]
                return Place(nxt.edge, nxt.index, 0.0, nxt.route_index)
            piece = pieces[k - 1]
            return Place(piece.edge, piece.index, piece.length, piece.route_index)
        position = self._position(table, k, piece, s)
        return Place(piece.edge, piece.index, min(max(position, 0.0), piece.length),
                     piece.route_index)

    def _position(self, table: LaneTable, k: int, piece: TrackPiece, s: float) -> float:
        if self.straight:  # exact: s - s of the lane's start (SUMO's length = its shape's)
            return (s - float(table.s_start[k])) * _stretch(piece)
        s_knots, positions = self._samples(table.id, k)
        return float(np.interp(s, s_knots, positions,
                               left=positions[0] + s - s_knots[0],
                               right=positions[-1] + s - s_knots[-1]))

    def _samples(self, track: int, k: int) -> tuple[np.ndarray, np.ndarray]:
        """s of lane positions every ~SAMPLE_STEP m along piece k of a track (made on
        first use)."""
        found = self._sampled.get((track, k))
        if found is None:
            found = self._sampled[(track, k)] = lane_samples(self.route_road, track, k)
        return found

    def track_at(self, s: float, d: float) -> LaneTable:
        """The track whose lane holds (s, d) among those that exist at s (right border
        inclusive, left exclusive); outside them all, the one whose centre is nearest."""
        best, best_gap = None, math.inf
        here = [t for t in self.route_road.lanes if t.begin <= s <= t.end] or self.route_road.lanes
        for table in here:
            k = min(bisect.bisect_left(self._s_end[table.id], s), len(table.s_end) - 1)
            centre = float(table.d_start[k])
            if table.track.pieces[k].internal:  # LaneTable.centre's smoothstep, on floats
                a, b = float(table.s_start[k]), float(table.s_end[k])
                u = min(max((s - a) / max(b - a, 1e-12), 0.0), 1.0)
                centre += (float(table.d_end[k]) - centre) * u * u * (3.0 - 2.0 * u)
            half = 0.5 * float(table.width[k])
            if centre - half <= d < centre + half:
                return table
            gap = abs(d - centre)
            if gap < best_gap:
                best, best_gap = table, gap
        return best if best is not None else self.through[0]

    def hint(self, s: float, d: float) -> TrackPiece:
        """SUMO's lane (edge, index) of the track holding (s, d): the moveToXY hint that
        keeps a controlled vehicle on its route, in the right lane."""
        table = self.track_at(s, d)
        k = min(bisect.bisect_left(self._s_end[table.id], s), len(table.s_end) - 1)
        return table.track.pieces[k]

    def hint_box(self, s: float, d: float) -> tuple[TrackPiece, tuple[float, float, float, float]]:
        """`hint(s, d)`, and a box (s_lo, s_hi, d_lo, d_hi) around (s, d) in which `hint`
        gives the same piece for every s_lo < s < s_hi, d_lo <= d < d_hi: no track begins
        or ends in it, every track `track_at` looks at stays on one straight piece, and
        the lane found holds d with no lane before it overlapping it (empty, all NaN,
        where it cannot tell so cheaply: a junction's lane, outside every lane)."""
        piece = self.hint(s, d)
        empty = (math.nan, math.nan, math.nan, math.nan)
        bounds = self._bounds
        i = bisect.bisect_left(bounds, s)
        if i < len(bounds) and bounds[i] == s:
            return piece, empty
        lo = bounds[i - 1] if i > 0 else -math.inf
        hi = bounds[i] if i < len(bounds) else math.inf
        here = [t for t in self.route_road.lanes if t.begin <= s <= t.end] \
            or self.route_road.lanes
        seen: list[tuple[float, float]] = []  # the bands looked at before
        for table in here:
            ends = self._s_end[table.id]
            j = bisect.bisect_left(ends, s)
            k = min(j, len(ends) - 1)
            if table.track.pieces[k].internal:
                return piece, empty
            lo = max(lo, ends[k - 1] if k > 0 else -math.inf)
            hi = min(hi, ends[k]) if j == k else hi
            lo = max(lo, ends[k]) if j > k else lo
            centre, half = float(table.d_start[k]), 0.5 * float(table.width[k])
            band = (centre - half, centre + half)
            if band[0] <= d < band[1]:
                if any(a < band[1] and band[0] < b for a, b in seen):
                    return piece, empty
                return piece, (lo, hi, band[0], band[1])
            seen.append(band)
        return piece, empty


def lane_samples(route_road: Road, track: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(s in m, SUMO lane positions in m) every ~SAMPLE_STEP m along piece k of a track:
    SUMO stretches lane positions onto the lane's shape (the lanes of one edge share a
    length); s made non-decreasing against the frame's rounding."""
    table = route_road.lane(track)
    piece = table.track.pieces[k]
    shape = np.asarray(piece.shape, dtype=np.float64)
    seg = np.hypot(*np.diff(shape, axis=0).T)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    n = max(2, int(math.ceil(cum[-1] / SAMPLE_STEP)) + 1)
    offsets = np.linspace(0.0, cum[-1], n)
    x = np.interp(offsets, cum, shape[:, 0])
    y = np.interp(offsets, cum, shape[:, 1])
    hint = float(table.s_start[k]) + offsets
    s, _ = route_road.frame.to_frenet(x, y, s_hint=hint)
    positions = offsets * (piece.length / cum[-1] if cum[-1] > 0 else 1.0)
    return np.maximum.accumulate(np.asarray(s)), positions


@functools.lru_cache(maxsize=1024)
def _stretch(piece: TrackPiece) -> float:
    """SUMO's lane length over its shape's length (1.0 when they agree)."""
    from sumolib.geomhelper import polyLength

    shape_length = polyLength(list(piece.shape))
    return piece.length / shape_length if shape_length > 0 else 1.0


def s_of_lane_position(route_road: Road, lane_id: str, position: float) -> float:
    """m, s of SUMO lane position `position` on lane `lane_id` of a track (on the straight
    road exactly the lane's start s plus the position, as x was)."""
    if isinstance(route_road.frame, StraightFrame):
        table = route_road.track_of_lane(lane_id)
        k = next(i for i, p in enumerate(table.track.pieces) if p.lane == lane_id)
        return float(table.s_start[k]) + position / _stretch(table.track.pieces[k])
    return route_road.s_of_lane_position(lane_id, position)


def sv_start(route_road: Road, edge: str | None, lane: int, position: float) -> tuple[int, float]:
    """(track id, s in m) of the SV's start: SUMO lane `lane` (index) of `edge` (None:
    the route's first edge) at lane position `position` (its centre)."""
    edge_id = edge if edge is not None else route_road.route.edges[0]
    for table in route_road.lanes:
        piece = table.track.piece_on(edge_id)
        if piece is not None and piece.index == lane:
            track = table.track.joins if table.track.joins >= 0 else table.id
            return track, s_of_lane_position(route_road, piece.lane, position)
    raise InputError(str(route_road.route.path), "sv.lane", lane,
                     f"a lane of edge {edge_id!r} that a track of the route runs through")


def check_lanes(route_road: Road, source: str, sv_edge: str | None = None,
                sv_lane: int | None = None) -> None:
    """InputError (one line) unless the route's SV lanes (`sv_tracks`) can be driven: they
    are tracks 0..n-1 (no lane closed to cars among them), those that run through the
    whole route lie side by side (a lane that ends does so on the right or left of them,
    not between two that run on) and the SV starts on one of them (`sv_edge`, `sv_lane`:
    [sv] edge and lane; a lane that begins along the route is none)."""
    lanes = [t.id for t in sv_tracks(route_road)]
    through = [t.id for t in through_tracks(route_road)]
    edges = list(route_road.route.edges)
    if lanes != list(range(len(lanes))):
        raise InputError(source, "road.route", edges,
                         f"a route whose first edge {edges[0]!r} has only lanes open to cars "
                         f"(its tracks are {lanes})")
    if through != list(range(through[0], through[-1] + 1)):
        middle = [k for k in range(through[0], through[-1]) if k not in through]
        raise InputError(source, "road.route", edges,
                         f"a route whose lanes that end on it lie right or left of those that "
                         f"run through (lane {middle[0]} of edge {edges[0]!r} ends between "
                         "two that run on: not supported)")
    if sv_lane is not None:
        edge = sv_edge if sv_edge is not None else edges[0]
        track = next((t for t in route_road.lanes if (p := t.track.piece_on(edge)) is not None
                      and p.index == sv_lane), None)
        if track is not None and track.id not in lanes and track.track.joins not in lanes:
            raise InputError(source, "sv.lane", sv_lane,
                             f"a lane of the route's first edge {edges[0]!r} (lane {sv_lane} "
                             f"of {edge!r} begins along the route; start the route on the "
                             "edge where it begins)")
