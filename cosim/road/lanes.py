"""Lane tables along s: each track's centre d(s), width, bounds, speed limit, and the
SUMO lane (edge, index) it occupies at each s.

On a route edge a lane's centre lies where SUMO puts it: its offset from the
reference track's lane on the same edge is the sum of the widths between them (SUMO
builds an edge's lanes side by side). Across a junction lane the centre moves from one
edge's offset to the next one's along a smoothstep (3u^2 - 2u^3), so a lane that SUMO
shifts sideways at a junction keeps a smooth centre line. Tracks that start or end
inside the route hold their first (last) edge's offset.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.road.frame import deviation
from cosim.road.tracks import Track, TrackPiece

Array = NDArray[np.float64]


@dataclass(frozen=True)
class LaneTable:
    """One track along s: its pieces' s ranges and centre offsets, widths, speeds."""

    track: Track
    s_start: Array  # m, per piece: where it begins along s
    s_end: Array  # m, per piece: where it ends
    d_start: Array  # m, per piece: centre offset at its start
    d_end: Array  # m, per piece: centre offset at its end (different only on junction lanes)
    width: Array  # m, per piece
    speed: Array  # m/s, per piece: SUMO's limit
    deviation: float  # m, Hausdorff distance of the centre line from SUMO's lane shapes

    @property
    def id(self) -> int:
        return self.track.id

    @property
    def begin(self) -> float:
        """m, s where the track begins."""
        return float(self.s_start[0])

    @property
    def end(self) -> float:
        """m, s where the track ends (its lane has no connection onward, or the route ends)."""
        return float(self.s_end[-1])

    def _piece_index(self, s: ArrayLike) -> Array:
        return np.clip(np.searchsorted(self.s_end, np.asarray(s, dtype=np.float64)), 0,
                       len(self.s_end) - 1)

    def contains(self, s: ArrayLike) -> Any:
        """Whether the track exists at s."""
        s_ = np.asarray(s, dtype=np.float64)
        return (s_ >= self.begin) & (s_ <= self.end)

    def centre(self, s: ArrayLike) -> Any:
        """m, d of the lane's centre at s (held constant beyond the track's ends)."""
        k = self._piece_index(s)
        s_ = np.asarray(s, dtype=np.float64)
        span = np.maximum(self.s_end[k] - self.s_start[k], 1e-12)
        u = np.clip((s_ - self.s_start[k]) / span, 0.0, 1.0)
        blend = u * u * (3.0 - 2.0 * u)
        return self.d_start[k] + (self.d_end[k] - self.d_start[k]) * blend

    def lane_width(self, s: ArrayLike) -> Any:
        """m, the lane's width at s."""
        return self.width[self._piece_index(s)]

    def bounds(self, s: ArrayLike) -> tuple[Any, Any]:
        """m, d of the lane's right and left borders at s."""
        c, w = self.centre(s), self.lane_width(s)
        return c - 0.5 * w, c + 0.5 * w

    def speed_limit(self, s: ArrayLike) -> Any:
        """m/s, SUMO's speed limit of the lane at s."""
        return self.speed[self._piece_index(s)]

    def piece_at(self, s: float) -> TrackPiece:
        """The SUMO lane of the track at s (edge, lane id, SUMO index): the hint for
        moveToXY and the edge/lane a trace reports."""
        return self.track.pieces[int(self._piece_index(s))]


def lane_tables(tracks: tuple[Track, ...], reference: dict[str, tuple[TrackPiece, float]],
                frame: Any, net: Any, skip: Sequence[tuple[float, float]] = ()
                ) -> tuple[LaneTable, ...]:
    """Every track's table in `frame`; `reference`: route edge id -> (the reference lane
    on it, d of its centre) (cosim.road.road.reference_lanes); each deviation measured
    outside the `skip` ranges of s (where the frame shifts sideways as SUMO's lanes step
    at a junction: there the lanes lie off SUMO's by design)."""
    tables = []
    for track in tracks:
        n = len(track.pieces)
        s0, s1 = np.empty(n), np.empty(n)
        hint = math.nan  # a track's first lane: searched from the nearest knot
        for k, piece in enumerate(track.pieces):
            (xa, ya), (xb, yb) = piece.shape[0], piece.shape[-1]
            a, _ = frame.to_frenet(xa, ya, s_hint=hint)
            b, _ = frame.to_frenet(xb, yb, s_hint=a + piece.length)
            s0[k], s1[k] = a, b
            hint = b
        centre = np.full(n, np.nan)
        for k, piece in enumerate(track.pieces):
            if not piece.internal:
                ref, d_ref = reference[piece.edge]
                centre[k] = _edge_offset(net, piece, ref, d_ref)
        d0, d1 = centre.copy(), centre.copy()
        for k, piece in enumerate(track.pieces):
            if piece.internal:
                before = centre[k - 1] if k > 0 else np.nan
                after = centre[k + 1] if k + 1 < n else np.nan
                d0[k] = before if not np.isnan(before) else after
                d1[k] = after if not np.isnan(after) else before
        table = LaneTable(track, s0, s1, d0, d1, np.array([p.width for p in track.pieces]),
                          np.array([p.speed for p in track.pieces]), math.nan)
        dev = deviation(frame, np.array(track.shape()), table.centre, skip)
        tables.append(replace(table, deviation=dev))
    return tuple(tables)


def _edge_offset(net: Any, piece: TrackPiece, ref: TrackPiece, d_ref: float) -> float:
    """m, d of a lane's centre on a route edge: the reference lane's d plus the widths
    between the two lanes (SUMO places an edge's lanes side by side)."""
    lanes = {ln.getIndex(): float(ln.getWidth()) for ln in net.getEdge(piece.edge).getLanes()}
    i, r = piece.index, ref.index
    if i == r:
        return d_ref
    lo, hi = sorted((i, r))
    between = sum(lanes[j] for j in range(lo + 1, hi))
    gap = 0.5 * lanes[i] + between + 0.5 * lanes[r]
    return d_ref + gap if i > r else d_ref - gap
