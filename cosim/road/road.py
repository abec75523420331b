"""The road of a run: a route on a SUMO network, its tracks, the (s, d) frame along it
and every track's lane table, built once from the network (`load_road`).

The frame's reference is the rightmost track that runs through the whole route; d = 0
is that lane's right border on the route's first edge and s = 0 the start of that
lane. A route of one straight edge along +x gets the `StraightFrame` (s = x - x0,
d = y - y0, exactly; on networks/highway.net.xml x0 = y0 = 0, so s = x and d = y);
every other route the smoothed `ArcFrame`, or an InputError if it cannot be smoothed
within `FrameLimits`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from cosim.errors import InputError
from cosim.road.corners import (
    CORNER_TURN,
    CORNER_TURN_REFUSED,
    U_TURN,
    Corner,
    CornerSite,
    corner_vertex,
    filleted,
    rounding,
)
from cosim.road.frame import (
    CORNER_SPREAD,
    DEFAULT_LIMITS,
    ArcFrame,
    FrameLimits,
    LateralShift,
    StraightFrame,
    kappa_max,
    shifted,
    smooth,
)
from cosim.road.lanes import LaneTable, lane_tables
from cosim.road.route import Route, make_route
from cosim.road.tracks import (
    LeadIn,
    Track,
    TrackPiece,
    follow_tracks,
    lane_turn,
    lateral_jump,
    reference_tracks,
)

CORNER_JOIN = 50.0  # m, corners closer are one stretch of slow road; tuned: docs/tuned_constants.md


@dataclass(frozen=True)
class Road:
    """A route, its tracks and lane tables, and the frame along it."""

    route: Route
    tracks: tuple[Track, ...]
    reference: Track  # the frame's reference track
    frame: StraightFrame | ArcFrame
    lanes: tuple[LaneTable, ...]  # in track id order (ids may skip a lane cars may not use)
    lead_in: LeadIn | None = None  # the reference's lead-in (a route from an on-ramp, ...)
    # where the frame shifts sideways as SUMO's lanes step at a junction (s along it)
    shifts: tuple[LateralShift, ...] = ()
    # where the frame rounds a junction drawn as a corner (cosim.road.corners)
    corners: tuple[Corner, ...] = ()

    @property
    def carriageway(self) -> int:
        """Route index of the edge whose lanes are the SV's (cosim.road.tracks)."""
        return 0 if self.lead_in is None else self.lead_in.edge

    @functools.cached_property
    def ramp_lanes(self) -> frozenset[int]:
        """Track ids of the ramp lanes (cosim.road.tracks): lanes leading into the
        lead-in that end before the carriageway edge, SV lanes too; not those that join
        a lane of the carriageway edge (`joined`)."""
        if self.lead_in is None:
            return frozenset()
        return frozenset(li.track.id for li in self.lead_in.chain()[1:]
                         if li.track.last_edge < self.carriageway and li.track.joins < 0)

    @functools.cached_property
    def joined(self) -> dict[int, LaneTable]:
        """Track id of a lane of the carriageway edge that begins along the route -> the
        lane table of the ramp lane that joins it (`Track.joins`: one SV lane, the ramp
        lane up to its end, that lane from its begin); empty on most routes."""
        return {t.track.joins: t for t in self.lanes if t.track.joins >= 0}

    @property
    def max_deviation(self) -> float:
        """m, the largest Hausdorff distance of a track's centre line from SUMO's lane."""
        return max(t.deviation for t in self.lanes)

    @functools.cached_property
    def _by_id(self) -> dict[int, LaneTable]:
        return {t.id: t for t in self.lanes}

    def lane(self, track: int) -> LaneTable:
        """The lane table of a track id (KeyError: no such track)."""
        return self._by_id[track]

    @functools.cached_property
    def track_ids(self) -> dict[str, int]:
        """SUMO lane id -> track id, for every lane of every track (junction lanes too)."""
        return {p.lane: t.id for t in self.tracks for p in t.pieces}

    @functools.cached_property
    def edge_ids(self) -> frozenset[str]:
        """The route's edges and the junction edges between them: a vehicle on any other
        edge (a road crossing on a bridge, a ramp not yet joined) is not in the SV's lanes."""
        return frozenset(p.edge for t in self.tracks for p in t.pieces)

    def on_route(self, road_ids: Sequence[str]) -> np.ndarray:
        """Which of SUMO's road ids (vehicle.getRoadID) lie on the route."""
        return np.fromiter((r in self.edge_ids for r in road_ids), dtype=bool,
                           count=len(road_ids))

    @property
    def curved(self) -> bool:
        """The frame is not the identity up to an offset (an ArcFrame)."""
        return not isinstance(self.frame, StraightFrame)

    def curvature_bound(self) -> tuple[float, float]:
        """(1/m, m): the reference line's largest |curvature| over the route and the
        largest |offset| of a lane's edge from the line (the frame's distortion bound,
        `frame.distortion_margin`); (0, 0) on a StraightFrame."""
        if not self.curved:
            return 0.0, 0.0
        frame = self.frame
        assert isinstance(frame, ArcFrame)
        # a corner's fillet bends the SV's one lane only, where it slows to that
        # corner's own speed (cosim.driving.curve_speed.CornerSpeeds)
        outside = [0.0]
        for lo, hi, _ in self.corner_zones():
            outside += [lo, hi]
        outside.append(frame.length)
        kappa = max((kappa_max(frame, lo, hi) for lo, hi
                     in zip(outside[::2], outside[1::2], strict=True) if hi > lo),
                    default=0.0)
        edges = [abs(c - frame.d_offset + sign * 0.5 * w) for t in self.lanes
                 for c, w in zip(np.concatenate([t.d_start, t.d_end]),
                                 np.concatenate([t.width, t.width]), strict=True)
                 for sign in (-1.0, 1.0)]
        return kappa, max(edges)

    def corner_zones(self) -> tuple[tuple[float, float, float], ...]:
        """(s_lo m, s_hi m, R m): the stretches of the route its corners' fillets bend,
        each padded by twice the smoothing length and CORNER_SPREAD (the smoothing
        spreads a fillet's ends), corners less than CORNER_JOIN apart as one (a ramp's
        run of corners: the line between them keeps their drawing's small kinks), R the
        tightest fillet of the SV's lane there."""
        zones: list[list[float]] = []
        pad = 2.0 * self.frame.quality.smoothing_length + CORNER_SPREAD
        for c in self.corners:
            lo, hi = c.s_lo - pad, c.s_hi + pad
            if zones and lo - zones[-1][1] < CORNER_JOIN:
                zones[-1][1:] = [hi, min(zones[-1][2], c.lane_radius)]
            else:
                zones.append([lo, hi, c.lane_radius])
        return tuple((lo, hi, r) for lo, hi, r in zones)

    def track_of_lane(self, lane_id: str) -> LaneTable:
        """The lane table of the track that runs through SUMO lane `lane_id` (KeyError:
        no track does)."""
        return self._by_id[self.track_ids[lane_id]]

    def s_of_lane_position(self, lane_id: str, position: float) -> float:
        """m, s of SUMO lane position `position` (m along the lane, as SUMO counts it) on
        lane `lane_id` of the route."""
        from sumolib.geomhelper import polyLength, positionAtShapeOffset

        table = self.track_of_lane(lane_id)
        k = next(i for i, p in enumerate(table.track.pieces) if p.lane == lane_id)
        piece = table.track.pieces[k]
        # SUMO stretches lane positions onto the shape (lanes of one edge share a length)
        offset = position * polyLength(piece.shape) / piece.length
        x, y = positionAtShapeOffset(list(piece.shape), offset)
        s, _ = self.frame.to_frenet(x, y, s_hint=float(table.s_start[k]) + position)
        return float(s)


def _straight(route: Route, reference: Track) -> bool:
    """A route of one edge whose lanes are straight lines along +x."""
    if len(route.edges) != 1:
        return False
    shapes = [lane.getShape() for lane in route.edge(0).getLanes()]
    return all(len(s) == 2 and s[0][1] == s[1][1] and s[1][0] > s[0][0] for s in shapes)


def _where_on(route: Route, track: Track, x: float, y: float) -> str:
    """Which of the track's SUMO lanes (x, y) lies on, in words; where a junction's lane
    meets an edge's, the junction (a refusal's place is mostly a kink there)."""
    from sumolib.geomhelper import distancePointToPolygon

    gaps = [distancePointToPolygon((x, y), list(p.shape)) if len(p.shape) > 1
            else math.dist((x, y), p.shape[0]) for p in track.pieces]
    nearest = min(gaps)
    piece = next((p for p, g in zip(track.pieces, gaps, strict=True)
                  if p.internal and g <= nearest + 1e-6),
                 track.pieces[gaps.index(nearest)])
    if not piece.internal:
        return f"on edge {piece.edge}"
    k = piece.route_index
    junction = route.net.getEdge(piece.edge).getFromNode().getID()
    said = f"at junction {junction} between edges {route.edges[k]} and {route.edges[k + 1]}"
    i = track.pieces.index(piece)
    before = next((p for p in reversed(track.pieces[:i]) if not p.internal), None)
    after = next((p for p in track.pieces[i + 1:] if not p.internal), None)
    if before is None or after is None:
        return said
    a, b = route.net.getLane(before.lane), route.net.getLane(after.lane)
    step = lateral_jump(a, b)
    # a sideways step is what no smoothing can follow (lanes re-spread at a junction)
    if step >= 0.05:
        said += f", across which SUMO's lane steps {step:.1f} m sideways"
    turn = lane_turn(a, b)
    if turn >= CORNER_TURN:
        # a junction drawn as a corner (a ramp meeting its acceleration lane at 40
        # degrees within a few metres): SUMO moves its vehicles along the lanes' shapes,
        # so it drives a bend no frame across the route's lanes can follow
        inside = sum(p.length for p in track.pieces[i:] if p.internal
                     and p.route_index == k)
        said += (f", a corner: SUMO's junction turns the lane by "
                 f"{math.degrees(turn):.0f} degrees within {inside:.1f} m (R "
                 f"{inside / turn:.1f} m), which SUMO's vehicles follow along its shape, "
                 f"having no turning circle")
    return said


def reference_lanes(ref: Track, lead: LeadIn | None) -> dict[str, tuple[TrackPiece, float]]:
    """Route edge id -> (the reference's lane on it, d of that lane's centre): the
    reference track's, its centre half its width left of d = 0; before the carriageway
    edge, the lead-in's (and those leading into it), its `shift` to the right of the
    reference line."""
    half = ref.pieces[0].width / 2.0
    lanes = {p.edge: (p, half) for p in ref.pieces if not p.internal}
    if lead is not None:
        lanes |= {p.edge: (p, half - shift) for p, shift in lead.shifted_pieces()
                  if not p.internal}
    return lanes


def reference_line(ref: Track, lead: LeadIn | None) -> np.ndarray:
    """m, the polyline the frame smooths: the reference track's centre line, led in by the
    lead-in's shifted `shift` to its left (the line where the reference's lane would run
    beside it), each lane leading into the lead-in shifted by its own."""
    points = np.array(ref.shape())
    if lead is None:
        return points
    parts = [shift_left(np.array(Track(lead.track.id, pieces).shape()), shift)
             for pieces, shift in lead.runs()] + [points]
    kept = [part if k + 1 == len(parts) or math.dist(tuple(part[-1]), tuple(parts[k + 1][0]))
            >= 1e-9 else part[:-1] for k, part in enumerate(parts)]
    return np.vstack(kept)


# m: a sideways step of the reference lane at a junction beyond this is a lateral shift of
# the road (lanes re-spread at a lane-count change), not a kink: FrameLimits.max_deviation
# is what smoothing may spend on each side of it
STEP = 2.0 * DEFAULT_LIMITS.max_deviation


def _reference_pieces(ref: Track, lead: LeadIn | None) -> list[tuple[TrackPiece, np.ndarray]]:
    """The reference line's pieces in order, each with its shape as the line takes it
    (the lead-in's shifted `shift` to its left)."""
    pieces = [] if lead is None else [(p, shift_left(np.array(p.shape), shift))
                                      for p, shift in lead.shifted_pieces()
                                      if len(p.shape) > 1]
    return pieces + [(p, np.array(p.shape)) for p in ref.pieces if len(p.shape) > 1]


def _lead_shifts(lead: LeadIn | None) -> list[float]:
    """m, the shift of each of the lead-in's pieces `_reference_pieces` takes."""
    return [] if lead is None else [shift for p, shift in lead.shifted_pieces()
                                    if len(p.shape) > 1]


def _signed_jump(a: np.ndarray, b: np.ndarray, corner_turn: float = CORNER_TURN) -> float:
    """m, how far the start of polyline b lies left of the end of polyline a (across
    a's last segment); 0 where b's first segment turns from a's last by `corner_turn`
    (rad) or more (a junction drawn as a corner, not lanes side by side)."""
    t = a[-1] - a[-2]
    u = b[1] - b[0]
    if abs(math.atan2(t[0] * u[1] - t[1] * u[0], t[0] * u[0] + t[1] * u[1])) >= corner_turn:
        return 0.0
    q = b[0] - a[-1]
    return float((t[0] * q[1] - t[1] * q[0]) / (math.hypot(*t) or 1.0))


def _borders(net: object, piece: TrackPiece, right_of_line: float) -> tuple[float, float]:
    """m, how far the lanes of `piece`'s edge reach right and left of a line that runs
    `right_of_line` m left of `piece`'s centre (each side's farthest border; negative:
    none on that side)."""
    widths = {ln.getIndex(): float(ln.getWidth())
              for ln in net.getEdge(piece.edge).getLanes()}  # type: ignore[attr-defined]
    right = right_of_line + 0.5 * piece.width + sum(w for i, w in widths.items()
                                                    if i < piece.index)
    left = -right_of_line + 0.5 * piece.width + sum(w for i, w in widths.items()
                                                    if i > piece.index)
    return right, left


def corner_sites(route: Route, ref: Track, lead: LeadIn | None,
                 min_turn: float = CORNER_TURN) -> list[CornerSite]:
    """The junctions where the reference line turns by `min_turn` (rad) or more between
    one route edge's last segment and the next's first (a junction drawn as a corner),
    and, with `min_turn` below CORNER_TURN, the vertices inside a route edge's lane that
    turn so much (`_vertex_sites`), in order along the line, in the line's coordinates
    (`_reference_pieces`)."""
    pieces = _reference_pieces(ref, lead)
    shifts = _lead_shifts(lead)
    n_lead = len(shifts)
    edges = [(k, p, shape) for k, (p, shape) in enumerate(pieces) if not p.internal]
    sites = []
    for i, (k, a, sa) in enumerate(edges):
        shift_a = shifts[k] if k < n_lead else 0.0
        if min_turn < CORNER_TURN:
            sites += _vertex_sites(route, a, sa, shift_a, min_turn)
        if i + 1 == len(edges):
            break
        kb, b, sb = edges[i + 1]
        t, u = sa[-1] - sa[-2], sb[1] - sb[0]
        turn = math.atan2(t[0] * u[1] - t[1] * u[0], t[0] * u[0] + t[1] * u[1])
        if abs(turn) < min_turn:
            continue
        shift_b = shifts[kb] if kb < n_lead else 0.0
        ra, la = _borders(route.net, a, shift_a)
        rb, lb = _borders(route.net, b, shift_b)
        reach = max(ra, rb) if turn < 0.0 else max(la, lb)
        sites.append(CornerSite(
            tuple(sa[-2]), tuple(sa[-1]), tuple(sb[0]), tuple(sb[1]),
            route.net.getEdge(b.edge).getFromNode().getID(), min(a.speed, b.speed),
            a.width, shift_a, max(reach, 0.0)))
    return sites


def _vertex_sites(route: Route, piece: TrackPiece, shape: np.ndarray, shift: float,
                  min_turn: float) -> list[CornerSite]:
    """The vertices inside a route edge's lane `piece` (its `shape` as the line takes it,
    `shift` m left of the lane) where the line turns by `min_turn` (rad) or more, as
    corners, on a lane drawn with corners: one of its vertices turns by CORNER_TURN or
    more (a ramp drawn as chords, SUMO's game/highway ramp: 40-86 m long, turning 6-18
    degrees at each vertex, no line within 0.5 m of them bends as its curve does); none
    on a lane whose vertices all turn less (a coarse curve, a kink: smoothed, or refused)."""
    seg = np.diff(shape, axis=0)
    turns = [math.atan2(t[0] * u[1] - t[1] * u[0], t[0] * u[0] + t[1] * u[1])
             for t, u in zip(seg[:-1], seg[1:], strict=True)]
    if not turns or max(abs(a) for a in turns) < CORNER_TURN:
        return []
    sites = []
    right, left = _borders(route.net, piece, shift)
    for i, turn in enumerate(turns, start=1):
        if abs(turn) >= min_turn:
            sites.append(CornerSite(
                tuple(shape[i - 1]), tuple(shape[i]), tuple(shape[i]), tuple(shape[i + 1]),
                f"{piece.edge} vertex {i}", piece.speed, piece.width, shift,
                max(right if turn < 0.0 else left, 0.0)))
    return sites


def lateral_steps(ref: Track, lead: LeadIn | None, step: float = STEP,
                  corner_turn: float = CORNER_TURN
                  ) -> tuple[np.ndarray, list[tuple[float, float, float]]]:
    """The reference line with its sideways steps taken out, and the steps: where the
    reference lane on one route edge starts more than `step` m sideways of where it
    ended on the edge before (netconvert re-spreads the lanes at a lane-count change),
    the line after it is moved back across by the steps so far and the junction's
    lanes between are left out (the smoothing spline bridges the junction). Returns the
    line and each step as (x, y of the junction's middle on that line, the jump, m to
    the left); no steps: the line `reference_line` gives."""
    pieces = _reference_pieces(ref, lead)
    edges = [(k, shape) for k, (p, shape) in enumerate(pieces) if not p.internal]
    jumps = {k1: _signed_jump(s0, s1, corner_turn) for (_, s0), (k1, s1)
             in zip(edges[:-1], edges[1:], strict=True)}
    if all(abs(j) <= step for j in jumps.values()):
        return reference_line(ref, lead), []
    shifts = _lead_shifts(lead)
    n_lead = len(shifts)
    # runs of pieces between the steps (and where the lead-in's shift changes), each
    # moved as one line
    runs: list[tuple[list[TrackPiece], float, float]] = []  # pieces, moved by, step before
    moved = 0.0  # m, to the left: the steps so far, taken back
    pending: list[TrackPiece] = []  # a step's junction lanes, until the step is known
    for k, (piece, _) in enumerate(pieces):
        if piece.internal:
            pending.append(piece)
            continue
        jump = jumps.get(k, 0.0)
        if abs(jump) > step:
            moved -= jump
            pending = []  # the step's junction lanes: the smoothing bridges them
        if runs and abs(jump) <= step:
            runs[-1][0].extend(pending)
        shift = shifts[k] if k < n_lead else 0.0
        if not runs or abs(jump) > step or k == n_lead or (0 < k < n_lead
                                                           and shift != shifts[k - 1]):
            runs.append(([piece], moved + shift, jump if abs(jump) > step else 0.0))
        else:
            runs[-1][0].append(piece)
        pending = []
    if pending:
        runs[-1][0].extend(pending)
    out: list[np.ndarray] = []
    steps: list[tuple[float, float, float]] = []
    for run, amount, jump in runs:
        points = np.array(Track(ref.id, tuple(run)).shape())
        here = points if amount == 0.0 else shift_left(points, amount)
        if out:
            if jump != 0.0:
                steps.append((*(0.5 * (out[-1][-1] + here[0])), jump))
            if math.dist(tuple(out[-1][-1]), tuple(here[0])) < 1e-9:
                here = here[1:]
        out.append(here)
    return np.vstack(out), steps


def shift_left(points: np.ndarray, amount: float) -> np.ndarray:
    """m, the polyline `points` moved `amount` m to its left (negative: right), each
    vertex along the bisector of its two segments (a parallel line at the vertices)."""
    seg = np.diff(points, axis=0)
    seg = seg / np.maximum(np.hypot(seg[:, 0], seg[:, 1]), 1e-12)[:, None]
    tangent = np.vstack([seg[:1], seg[:-1] + seg[1:], seg[-1:]])
    tangent /= np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-12)[:, None]
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    # at a vertex the bisector's offset is amount / cos(half the turn)
    cos_half = np.ones(len(points))
    cos_half[1:-1] = np.maximum(np.einsum("ij,ij->i", tangent[1:-1], seg[1:]), 0.2)
    return points + normal * (amount / cos_half)[:, None]


def load_road(network: Path | str, edges: Sequence[str] | None = None, *,
              limits: FrameLimits = DEFAULT_LIMITS, source: str | None = None) -> Road:
    """The road of `edges` (None: the network's only edge) on `network`. InputError
    (one line, naming `source` or the network) for a bad route or a network the frame
    cannot support.

    A route the frame cannot support with its corners at CORNER_TURN is tried again with
    every junction turning by CORNER_TURN_REFUSED or more rounded as a corner (a ramp
    drawn straight up to the mainline at 11 degrees), and every vertex inside a lane of
    the reference line that turns so much (a ramp drawn as coarse chords, `corner_sites`):
    taken if those corners were all
    that kept it from lying within max_deviation of SUMO's lanes elsewhere (a coarse
    curve stays refused), else the first refusal stands."""
    try:
        return _load_road(network, edges, limits, source, CORNER_TURN)
    except InputError as refusal:
        try:
            road = _load_road(network, edges, limits, source, CORNER_TURN_REFUSED)
        except InputError:
            raise refusal from None
        if (not road.corners or road.frame.quality.coarse
                or road.max_deviation > limits.max_deviation):
            raise refusal from None
        return road


def _load_road(network: Path | str, edges: Sequence[str] | None, limits: FrameLimits,
               source: str | None, corner_turn: float) -> Road:
    """load_road's road, junctions turning by `corner_turn` (rad) or more its corners."""
    route = make_route(network, edges, source=source)
    src = source if source is not None else str(route.path)
    tracks = follow_tracks(route)
    if not tracks:
        raise InputError(src, "route", list(route.edges), "a route with a lane a car may use")
    ref, lead = reference_tracks(route, tracks, src)
    shifts: tuple[LateralShift, ...] = ()
    sites: list[CornerSite] = []
    rounded: list[tuple[float, float, float, float, float]] = []
    ends: list[tuple[np.ndarray, np.ndarray]] = []
    first = ref.pieces[0]
    half = first.width / 2.0
    if _straight(route, ref):
        (x0, yc), (x1, _) = first.shape
        frame: StraightFrame | ArcFrame = StraightFrame(x0, yc - half, x1 - x0,
                                                        limits.extension)
    else:
        line = ref if lead is None else Track(ref.id, (*lead.pieces(), *ref.pieces))
        top = max(p.speed for t in tracks for p in t.pieces)
        # the lanes lie within the widest route edge's width of the reference line
        reach = max(sum(float(ln.getWidth()) for ln in route.net.getEdge(e).getLanes())
                    for e in route.edges)
        points, steps = lateral_steps(ref, lead, corner_turn=corner_turn)
        where = functools.partial(_where_on, route, line)
        sites = corner_sites(route, ref, lead, corner_turn)
        if corner_turn < CORNER_TURN and len(sites) == len(corner_sites(route, ref, lead)):
            raise InputError(src, "route", list(route.edges), "no gentler corner")  # load_road
        if sites:
            rounded = rounding(sites, limits.limit_lat_accel, limits.min_radius)
            for site, r in zip(sites, rounded, strict=True):
                if not math.isfinite(r[0]):
                    x, y = site.p1
                    turn = abs(corner_vertex(site)[3])
                    why = (f"a U-turn of {math.degrees(turn):.0f} degrees, not driven"
                           if turn >= U_TURN else "no room for a radius its lanes allow")
                    raise InputError(src, "route", list(route.edges),
                                     f"a route whose corners can be rounded within the "
                                     f"straight ends of their edges (near x = {x:.1f}, "
                                     f"y = {y:.1f}, {where(x, y)}: {why})")
            points, ends = filleted(points, sites, rounded)
        frame = smooth(points, limits, d_offset=half, source=src, where=where,
                       speed_limit=top, reach=reach, corners=ends)
        if steps:
            # SUMO's lanes step sideways at a junction: the line follows them, shifting
            # over as long as a curve of the radius the speed limit needs, and never
            # tighter than the lanes allow
            floor = max(limits.min_radius, reach / (1.0 - limits.min_stretch))
            frame, shifts = shifted(frame, steps, np.array(line.shape()),
                                    max(top**2 / limits.limit_lat_accel, floor), limits)
            _check_radius(frame, reach, limits, src, route, line)
    corners: tuple[Corner, ...] = ()
    if sites:
        placed = []
        for site, r, (t1, t2) in zip(sites, rounded, ends, strict=True):
            (lo, hi), _ = frame.to_frenet(np.array([t1[0], t2[0]]), np.array([t1[1], t2[1]]))
            v, _, _, turn = corner_vertex(site)
            placed.append(Corner(float(lo), float(hi), turn, r[0], r[1], r[2], site.junction,
                                 r[4]))
        corners = tuple(placed)
    tables = lane_tables(tracks, reference_lanes(ref, lead), frame, route.net,
                         [sh.window for sh in shifts] + [c.window for c in corners])
    if any(not math.isfinite(v) for t in tables for v in (*t.s_start, *t.s_end)):
        raise InputError(src, "route", list(route.edges),
                         "a route whose lanes all lie within the reference line's reach "
                         "(a lane's end could not be placed along it)")
    worst = max(tables, key=lambda t: t.deviation)
    # a coarse curve smoothed towards the curve its vertices lie on (FrameLimits)
    allowed = limits.coarse_deviation if frame.quality.coarse else limits.max_deviation
    if worst.deviation > allowed and frame.quality.coarse:
        # not a coarse curve after all (lanes that step sideways at a junction): judged
        # within max_deviation, as any other route, so the refusal names its cause
        return _load_road(network, edges, replace(limits, coarse_deviation=limits.max_deviation),
                          source, corner_turn)
    if worst.deviation > allowed:
        raise InputError(src, "lane deviation", f"{worst.deviation:.3f} m",
                         f"lanes whose centre lines stay within {allowed:g} m of "
                         f"SUMO's lane shapes (track {worst.id}, from {worst.track.name}, "
                         "does not)")
    return Road(route, tracks, ref, frame, tables, lead, shifts, corners)


def _check_radius(frame: ArcFrame, reach: float, limits: FrameLimits, source: str,
                  route: Route, line: Track) -> None:
    """Refuse a frame whose shifts at SUMO's lane steps bend it tighter than its lanes
    allow (`FrameLimits.min_stretch`, the SV's turning circle), naming where."""
    floor = max(limits.min_radius, reach / (1.0 - limits.min_stretch))
    if frame.quality.min_radius >= floor:
        return
    k = int(np.argmax(np.abs(frame.kappa)))
    raise InputError(source, "reference line radius", f"{frame.quality.min_radius:.1f} m",
                     f"a route whose lanes' sideways steps at junctions can be followed at a "
                     f"radius of at least {floor:.3g} m (it bends tightest near x = "
                     f"{frame.x[k]:.1f}, y = {frame.y[k]:.1f}, "
                     f"{_where_on(route, line, frame.x[k], frame.y[k])})")
