"""The per-step geometry of the SV against the TVs near it, as compiled loops.

Two questions the loop asks every step of the few dozen TVs around the SV:

- `lane_neighbours`: the nearest TV ahead and behind the SV whose rectangle
  touches a lane (the decision rule's leader and follower, cosim.driving.layout);
- `gap_ttc_min`: the smallest along-lane gap and time-to-collision to a TV sharing
  the SV's strip of road (cosim.run.metrics.gap_ttc, reduced to its minima), and
  which TVs are within reach of an overlap (bounding circles), for the exact test.

As numpy expressions each is a few dozen calls on arrays of ~30 values, where the
fixed cost of each call dominates; a compiled loop does the same arithmetic
operation by operation (no fastmath), so the results are the same to the bit.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cosim.compiled import njit, register_warm_up

Array = NDArray[np.float64]


@njit
def lane_neighbours(lane: int, sv_x: float, sv_length: float, tv_x: Array, tv_y: Array,
                    tv_length: Array, tv_width: Array, y_right: float, lane_width: float,
                    tv_vy: Array, use_vy: bool) -> tuple[int, float, int, float]:
    """(leader index, gap ahead, follower index, gap behind) in `lane` (index -1 and
    gap inf: none). A TV belongs to every lane its rectangle touches; with `use_vy`,
    one whose centre is in another lane and that moves away from `lane` does not."""
    i_lead, i_foll = -1, -1
    best_ahead, best_behind = math.inf, math.inf
    for i in range(tv_x.size):
        hw = 0.5 * tv_width[i]
        lo = math.floor((tv_y[i] - hw - y_right) / lane_width)
        hi = math.floor((tv_y[i] + hw - y_right) / lane_width)
        if not (lo <= lane and hi >= lane):
            continue
        if use_vy:
            centre = math.floor((tv_y[i] - y_right) / lane_width)
            if (centre > lane and tv_vy[i] > 0.0) or (centre < lane and tv_vy[i] < 0.0):
                continue
        dx = tv_x[i] - sv_x
        gap = abs(dx) - 0.5 * (sv_length + tv_length[i])
        if dx >= 0.0:
            if gap < best_ahead:
                best_ahead, i_lead = gap, i
        elif gap < best_behind:
            best_behind, i_foll = gap, i
    return i_lead, best_ahead, i_foll, best_behind


@njit
def gap_ttc_min(x: float, y: float, vx: float, hx: float, hy: float, reach_sv: float,
                tv_x: Array, tv_y: Array, tv_vx: Array, tv_heading: Array, tv_length: Array,
                tv_width: Array, near: NDArray[np.bool_]) -> tuple[float, float]:
    """m, s: the smallest along-lane gap and TTC from the SV (centre x, y; global x
    speed vx; half extents hx, hy) to a TV whose lateral extent overlaps its strip
    (inf: none); fills `near` with the TVs whose bounding circle meets the SV's
    (`reach_sv`: the SV's diagonal). Same rules as cosim.run.metrics.gap_ttc."""
    gap_min, ttc_min = math.inf, math.inf
    for i in range(tv_x.size):
        c = abs(math.cos(tv_heading[i]))
        s = abs(math.sin(tv_heading[i]))
        hl = 0.5 * tv_length[i]
        hw = 0.5 * tv_width[i]
        tv_hx = hl * c + hw * s
        tv_hy = hl * s + hw * c
        dx = tv_x[i] - x
        reach = 0.5 * (math.hypot(tv_length[i], tv_width[i]) + reach_sv)
        near[i] = math.hypot(tv_x[i] - x, tv_y[i] - y) <= reach
        if not abs(tv_y[i] - y) < (hy + tv_hy):
            continue
        gap = abs(dx) - (hx + tv_hx)
        closing = vx - tv_vx[i] if dx >= 0.0 else tv_vx[i] - vx
        ttc = gap / closing if closing > 0.0 else math.inf
        if gap <= 0.0:
            ttc = 0.0
        gap_min = min(gap_min, gap)
        ttc_min = min(ttc_min, ttc)
    return gap_min, ttc_min


@register_warm_up
def warm_up() -> None:
    """Compile (or load from numba's cache) both loops now."""
    one = np.ones(1)
    lane_neighbours(0, 0.0, 4.0, one, one, one, one, 0.0, 3.75, one, True)
    gap_ttc_min(0.0, 0.0, 1.0, 1.0, 1.0, 4.0, one, one, one, one, one, one, np.zeros(1, bool))
