"""Run metrics: one row per co-simulation run, from the trace's numpy columns.

Pure numpy, no SUMO. The loop (cosim.run.loop) records per step the SV state, its
reference, errors, inputs and, per traffic vehicle (TV) near it, the along-lane
gap and time-to-collision (`gap_ttc`); this module reduces those columns:

- IAE per Table 2 column of the paper (Vx, ye, phi_e, delta_f, Fx): the
  integral over time of the absolute value (trapezoid rule). The paper labels
  the columns with the signal's unit (m/s, m, deg, deg, kN); the integral's
  unit carries an extra second, and the column names here say so.
- minimum gap and time-to-collision along the lane between oriented rectangles,
- max |lateral acceleration|, max jerk,
- lane-change durations: from the start of a manoeuvre until the SV stays
  within a tolerance of its target lane's centre,
- the largest deceleration of the SV's new follower in the target lane (the nearest
  TV behind the SV there when the SV enters that lane), from the start of the change
  until FOLLOWER_WINDOW after it settles (`follower_max_decel`; what the manoeuvre
  asked of the traffic behind it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.params import STANDSTILL_SPEED

Array = NDArray[np.float64]


def iae(t: ArrayLike, values: ArrayLike) -> float:
    """Integral of |values| over t (trapezoid rule); unit: values' unit x s."""
    tt = np.asarray(t, dtype=float)
    v = np.abs(np.asarray(values, dtype=float))
    if tt.size < 2:
        return 0.0
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(tt)))


def half_extents(length: ArrayLike, width: ArrayLike, heading: ArrayLike) -> tuple[Array, Array]:
    """m, half extents along global x and y of a rectangle turned by heading (rad).

    The projection of an oriented rectangle (eq. 9) on the road axes: what the
    along-lane gap and the lateral overlap are measured with.
    """
    c = np.abs(np.cos(heading))
    s = np.abs(np.sin(heading))
    hl = 0.5 * np.asarray(length, dtype=float)
    hw = 0.5 * np.asarray(width, dtype=float)
    return hl * c + hw * s, hl * s + hw * c


def gap_ttc(
    sv_x: ArrayLike,
    sv_y: ArrayLike,
    sv_vx: ArrayLike,
    sv_half: tuple[ArrayLike, ArrayLike],
    tv_x: ArrayLike,
    tv_y: ArrayLike,
    tv_vx: ArrayLike,
    tv_half: tuple[ArrayLike, ArrayLike],
) -> tuple[Array, Array]:
    """Along-lane gap (m) and time-to-collision (s) from the SV to every TV.

    Only TVs whose lateral extent overlaps the SV's count (they share some of
    its strip of road); others get gap = ttc = inf. The gap is the distance
    between the rectangles' x extents (negative: the extents overlap); the
    TTC is gap / closing speed when the two are closing, 0 when the gap is
    already <= 0, inf otherwise. `*_vx` are global x velocities (m/s); `*_half` the
    half extents (m) along x and y (`half_extents`). Several egos at once: the SV's
    arguments as columns (shape (n, 1)), the result one row per ego (numpy broadcasting).
    """
    sv_hx, sv_hy = sv_half
    tv_hx, tv_hy = tv_half
    tx = np.asarray(tv_x, dtype=float)
    dx = tx - sv_x
    lateral = np.abs(np.asarray(tv_y, dtype=float) - sv_y) < (sv_hy + np.asarray(tv_hy))
    gap = np.abs(dx) - (sv_hx + np.asarray(tv_hx, dtype=float))
    # closing speed: the rear vehicle faster than the front one
    closing = np.where(dx >= 0.0, sv_vx - np.asarray(tv_vx), np.asarray(tv_vx) - sv_vx)
    with np.errstate(divide="ignore", invalid="ignore"):
        ttc = np.where(closing > 0.0, gap / closing, np.inf)
    ttc = np.where(gap <= 0.0, 0.0, ttc)
    gap = np.where(lateral, gap, np.inf)
    ttc = np.where(lateral, ttc, np.inf)
    return gap, ttc


def max_abs(values: ArrayLike) -> float:
    """max |values| ignoring NaN; 0 for an empty array."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.max(np.abs(v))) if v.size else 0.0


def jerk(t: ArrayLike, ax: ArrayLike, ay: ArrayLike) -> Array:
    """m/s^3, magnitude of the time derivative of the acceleration vector (ax, ay),
    by finite differences between samples (length n - 1)."""
    tt = np.asarray(t, dtype=float)
    if tt.size < 2:
        return np.zeros(0)
    dt = np.diff(tt)
    jx = np.diff(np.asarray(ax, dtype=float)) / dt
    jy = np.diff(np.asarray(ay, dtype=float)) / dt
    return np.hypot(jx, jy)


def settle_time(
    t: ArrayLike, y: ArrayLike, start: float, y_target: float, end: float, tol: float = 0.1
) -> float:
    """s, first time in [start, end] after which |y - y_target| < tol holds up to `end`
    (NaN if it never settles in that window)."""
    tt = np.asarray(t, dtype=float)
    yy = np.asarray(y, dtype=float)
    window = (tt >= start) & (tt <= end)
    if not np.any(window):
        return math.nan
    tw, yw = tt[window], yy[window]
    outside = np.abs(yw - y_target) >= tol
    if outside[-1]:
        return math.nan
    if not np.any(outside):
        return float(tw[0])
    last_out = int(np.flatnonzero(outside)[-1])
    return float(tw[last_out + 1])


def lane_change_durations(
    t: ArrayLike,
    y: ArrayLike,
    starts: Sequence[float],
    y_targets: Sequence[float],
    ends: Sequence[float],
    tol: float = 0.1,
) -> Array:
    """s, duration of each lane change: from its start until the SV settles within
    `tol` of its target lane's centre (looked for up to `ends[i]`, the start of the
    next manoeuvre or the end of the run). NaN: never settled."""
    out = np.full(len(starts), np.nan)
    for i, (s, yt, e) in enumerate(zip(starts, y_targets, ends, strict=True)):
        out[i] = settle_time(t, y, s, yt, e, tol) - s
    return out


IAE_COLUMNS = {
    # metrics column: (trace column, scale to the paper's unit)
    "iae_vx_mps_s": ("ex_mps", 1.0),
    "iae_ye_m_s": ("ye_m", 1.0),
    "iae_phie_deg_s": ("phie_deg", 1.0),
    "iae_deltaf_deg_s": ("delta_f_deg", 1.0),
    "iae_fx_kn_s": ("fx_abs_sum_n", 1e-3),
}
FX_WHEEL_COLUMNS = ("fx_fl_n", "fx_fr_n", "fx_rl_n", "fx_rr_n")


def iae_row(t: ArrayLike, trace: dict[str, Array], t0: float, t1: float) -> dict[str, float]:
    """IAE per Table 2 column over [t0, t1] of the trace (see IAE_COLUMNS).

    The Fx column integrates the sum of the four wheels' |Fx| (N; the trace's
    FX_WHEEL_COLUMNS), as `cosim track` does."""
    tt = np.asarray(t, dtype=float)
    w = (tt >= t0) & (tt <= t1)
    cols = dict(trace)
    if "fx_abs_sum_n" not in cols:
        cols["fx_abs_sum_n"] = np.sum(
            [np.abs(np.asarray(trace[c], dtype=float)) for c in FX_WHEEL_COLUMNS], axis=0)
    return {
        name: iae(tt[w], np.asarray(cols[col], dtype=float)[w] * scale)
        for name, (col, scale) in IAE_COLUMNS.items()
    }


SETTLE_TOL = 0.1  # m, |y - target lane centre| below which a lane change counts as done
FOLLOWER_PERCENTILE = 95  # the percentile of the follower's braking the studies compare
FOLLOWER_WINDOW = 3.0  # s, after the change settles, the new follower is still watched


def lane_entry_time(t: ArrayLike, lane: ArrayLike, start: float, target_lane: int,
                    end: float = math.inf) -> float:
    """s, the first time in [start, end] at which the SV's lane (the lane its centre is
    in, per sample) is `target_lane`: when it enters that lane (NaN: never)."""
    tt = np.asarray(t, dtype=float)
    inside = (tt >= start) & (tt <= end) & (np.asarray(lane) == target_lane)
    k = np.flatnonzero(inside)
    return float(tt[k[0]]) if k.size else math.nan


def follower_max_decel(t: ArrayLike, speed: ArrayLike, start: float, settled: float,
                       window: float = FOLLOWER_WINDOW) -> float:
    """m/s^2 (>= 0), the largest deceleration -dv/dt of the new follower between two
    consecutive samples, both in [start, settled + window]; `speed` (m/s) is that one
    vehicle's speed at times t, NaN where it is not known (not yet / no longer in the
    simulation). NaN: no follower (start NaN) or fewer than two known samples.
    An unsettled change (settled NaN) is watched to the end of the record.

    `start` is the start of the change, for our drivers and SUMO's alike: SUMO's own
    driver is in the target lane for its followers from the moment its change begins,
    and its new follower brakes then, before the SV's centre crosses the line (a window
    from the crossing would miss that braking); our SV is seen only from the crossing
    on, inside the window either way."""
    if math.isnan(start):
        return math.nan
    tt = np.asarray(t, dtype=float)
    v = np.asarray(speed, dtype=float)
    stop = settled + window if math.isfinite(settled) else math.inf
    inside = (tt >= start - 1e-9) & (tt <= stop + 1e-9) & np.isfinite(v)
    pair = inside[1:] & inside[:-1]
    if not pair.any():
        return math.nan
    decel = float((-np.diff(v)[pair] / np.diff(tt)[pair]).max())
    return decel if decel > 0.0 else 0.0


def polyline_distance(points: ArrayLike, shape: ArrayLike) -> NDArray[np.float64]:
    """m, each point's (rows x, y) distance from the polyline `shape` (rows x, y)."""
    p = np.asarray(points, dtype=float)[:, None, :]
    a = np.asarray(shape, dtype=float)
    if len(a) == 1:
        return np.hypot(*(p[:, 0, :] - a[0]).T)
    q0, q1 = a[:-1][None], a[1:][None]
    v = q1 - q0
    u = np.clip(np.sum((p - q0) * v, axis=-1) / np.maximum(np.sum(v * v, axis=-1), 1e-300),
                0.0, 1.0)
    return np.hypot(*(p - q0 - u[..., None] * v).transpose(2, 0, 1)).min(axis=1)


def lane_keeping_offset(x: ArrayLike, y: ArrayLike, lane_ids: Sequence[str],
                        keeping: ArrayLike, shapes: Mapping[str, Sequence[tuple[float, float]]]
                        ) -> float:
    """m, the largest distance of the SV's centre (x, y per step) from SUMO's centre line
    of the lane it is in (`lane_ids` per step, shapes by that id) over the steps where
    `keeping` (it keeps its lane); NaN: no such step on a known lane."""
    xy = np.column_stack([np.asarray(x, dtype=float), np.asarray(y, dtype=float)])
    keep = np.asarray(keeping, dtype=bool)
    ids = np.asarray(lane_ids, dtype=object)
    worst = math.nan
    for lane in set(ids[keep].tolist()):
        if lane not in shapes:
            continue
        d = polyline_distance(xy[keep & (ids == lane)], shapes[lane])
        worst = float(d.max()) if math.isnan(worst) else max(worst, float(d.max()))
    return worst


# ----------------------------------------------------------------------------- entry
# The SV's entry into the target lane as its new follower sees it: at the instant the
# SV's centre enters, the follower's bumper gap and time gap, the deceleration it needs
# to stay SUMO's minimum gap behind (if closing), and the smallest TTC to anyone in the
# SV's strip over ENTRY_WINDOW after the entry. Smallest gaps and largest needs over the
# lane changes of a run.
ENTRY_WINDOW = 3.0  # s, the TTC after the entry is watched this long
SUMO_MIN_GAP = 2.5  # m, SUMO's default minGap: the follower keeps it at a standstill
ENTRY_DOCS: dict[str, str] = {
    "entry_follower_gap_m": "bumper-to-bumper gap from the new follower (the nearest TV "
    "behind the SV in the target lane) to the SV as the SV's centre enters that lane, "
    "smallest over the lane changes (m; inf: no follower; NaN: no lane change entered)",
    "entry_follower_time_gap_s": "that gap over the follower's speed then, smallest over the "
    "lane changes (s; inf: no follower or it stands; NaN: no lane change entered)",
    "entry_follower_needed_decel_mps2": "the deceleration that follower needs then to stay "
    "SUMO's minimum gap (2.5 m) behind the SV, (v_f - v_sv)^2 / (2 (gap - 2.5)) when it is "
    "faster (0: not closing; inf: closing within 2.5 m), largest over the lane changes "
    "(m/s^2; NaN: no lane change with a follower)",
    "entry_min_ttc_s": "smallest along-lane TTC to any TV sharing the SV's strip over the "
    f"{ENTRY_WINDOW:g} s after each entry, smallest over the lane changes (s; inf: never "
    "closing; NaN: no lane change entered)",
}
ENTRY_COLUMNS = tuple(ENTRY_DOCS)


def follower_needed_decel(gap: float, follower_speed: float, sv_speed: float,
                          min_gap: float = SUMO_MIN_GAP) -> float:
    """m/s^2, the constant deceleration that brings a follower `gap` m behind (bumper to
    bumper) from `follower_speed` to `sv_speed` (m/s) at `min_gap` m: 0 when it is not
    faster, inf when it is faster and already within `min_gap`."""
    closing = follower_speed - sv_speed
    if closing <= 0.0:
        return 0.0
    room = gap - min_gap
    return closing * closing / (2.0 * room) if room > 0.0 else math.inf


def window_min(t: ArrayLike, values: ArrayLike, start: float, window: float) -> float:
    """The smallest of `values` at times t in [start, start + window] (inf: none there;
    NaN: start NaN)."""
    if math.isnan(start):
        return math.nan
    tt = np.asarray(t, dtype=float)
    inside = (tt >= start - 1e-9) & (tt <= start + window + 1e-9)
    v = np.asarray(values, dtype=float)[inside]
    return float(v.min()) if v.size else math.inf


# ----------------------------------------------------------------------------- comfort
# Riding comfort of the SV, for our drivers and SUMO's alike: what the paper's method
# exists for. Longitudinal acceleration and jerk over the run; around
# each lane change: the time gap to the new leader as the SV enters the target lane,
# the SV's hardest braking from then until POST_CHANGE_WINDOW after the change settles,
# and how long after the request the SV got there.

ACCEL_JUMP = 5.0  # m/s^2, a step-to-step change of ax this large is a jump (chatter)
POST_CHANGE_WINDOW = FOLLOWER_WINDOW  # s, after the change settles, the SV is still watched
COMFORT_COLUMNS = (
    "rms_long_accel_mps2", "rms_long_jerk_mps3", "max_long_jerk_mps3", "long_accel_jump_share",
    "merge_time_gap_s", "post_change_max_decel_mps2", "request_to_lane_s",
)


def longitudinal_comfort(t: ArrayLike, ax: ArrayLike) -> dict[str, float]:
    """RMS of ax (m/s^2), RMS and peak |dax/dt| between samples (m/s^3), and the share of
    steps whose |ax change| exceeds ACCEL_JUMP (-); samples where ax is not finite are
    left out (NaN: fewer than two)."""
    tt = np.asarray(t, dtype=float)
    a = np.asarray(ax, dtype=float)
    ok = np.isfinite(a)
    da = np.diff(a)
    step = np.diff(tt)
    pair = ok[1:] & ok[:-1] & (step > 0.0)
    if not pair.any():
        return dict.fromkeys(COMFORT_COLUMNS[:4], math.nan)
    j = da[pair] / step[pair]
    return {
        "rms_long_accel_mps2": float(np.sqrt(np.mean(a[ok] ** 2))),
        "rms_long_jerk_mps3": float(np.sqrt(np.mean(j**2))),
        "max_long_jerk_mps3": float(np.abs(j).max()),
        "long_accel_jump_share": float(np.mean(np.abs(da[pair]) > ACCEL_JUMP)),
    }


def time_gap(sv_x: float, sv_speed: float, sv_length: float, tv_x: ArrayLike,
             tv_length: ArrayLike) -> float:
    """s, bumper-to-bumper gap to the nearest TV ahead (centre x > the SV's) over the SV's
    speed; inf: no TV ahead; candidates are the TVs given (those in the lane)."""
    x = np.asarray(tv_x, dtype=float)
    ahead = x > sv_x
    if not ahead.any():
        return math.inf
    k = int(np.argmin(np.where(ahead, x, np.inf)))
    gap = float(x[k] - sv_x - 0.5 * (np.asarray(tv_length, dtype=float)[k] + sv_length))
    return gap / sv_speed if sv_speed > 0.0 else (math.inf if gap > 0.0 else 0.0)


def post_change_max_decel(t: ArrayLike, ax: ArrayLike, enter: float, settled: float,
                          window: float = POST_CHANGE_WINDOW) -> float:
    """m/s^2 (>= 0), the SV's largest deceleration -ax in [enter, settled + window]
    (an unsettled change: [enter, enter + window]); NaN: never entered."""
    if math.isnan(enter):
        return math.nan
    tt = np.asarray(t, dtype=float)
    stop = (settled if math.isfinite(settled) else enter) + window
    inside = (tt >= enter - 1e-9) & (tt <= stop + 1e-9)
    a = np.asarray(ax, dtype=float)[inside]
    a = a[np.isfinite(a)]
    if not a.size:
        return math.nan
    decel = float(-a.min())
    return decel if decel > 0.0 else 0.0


def request_to_lane(t: ArrayLike, lane: ArrayLike, request: float, target_lane: int) -> float:
    """s, from a lane-change request at `request` until the SV's centre is first in
    `target_lane` (NaN: no request, or never got there)."""
    if math.isnan(request):
        return math.nan
    enter = lane_entry_time(t, lane, request, target_lane)
    return enter - request if math.isfinite(enter) else math.nan


# --------------------------------------------------------------------------- outcomes
# Which collision check saw what, and lane changes the run's end cut short.
# Our exact overlap check is the referee; SUMO's getCollisions() is a cross-check that
# sees only vehicles on the same lane index and, for the SV moved by moveToXY, counts
# a gap below zero along its lane (docs/run_results.md, "Two collision checks").
COLLISION_SEEN = ("none", "both", "ours", "sumo")
LANE_CHANGE_STATUSES = ("none", "completed", "unfinished", "failed")
OUTCOME_DOCS: dict[str, str] = {
    "sumo_collision": "1 if sumo_collisions > 0, else 0",
    "collision_seen_by": "which check saw a collision in the run: none, both, ours (our "
    "exact overlap check only) or sumo (SUMO's getCollisions only; docs/run_results.md)",
    "lane_change_status": "none (no lane change requested), completed (lane_change_completed"
    " = 1), unfinished (the run ended while the SV was between lanes or before its last lane"
    " change settled: neither a success nor a failure) or failed (a run stopped by a "
    "collision included)",
    "lane_change_unfinished": "1 if lane_change_status is unfinished, else 0",
}


def collision_seen_by(ours: int, sumo: int) -> str:
    """One of COLLISION_SEEN from the two checks' event counts."""
    if ours and sumo:
        return "both"
    return "ours" if ours else "sumo" if sumo else "none"


@dataclass(frozen=True)
class LaneChangeEnd:
    """How a run's lane changes stood when it ended (`lane_change_status`)."""

    requests: int  # lane changes requested
    completed: bool  # lane_change_completed
    durations: Array  # s, each lane change's duration (NaN: did not settle)
    ends: Sequence[float]  # s, the end of each one's settling window
    t_end: float  # s, the run's end
    y_end: float  # m, the SV's d at the end
    stopped: bool = False  # a collision stopped the run ([scenario] on_collision = "stop")


def lane_change_status(end: LaneChangeEnd, centres: Array, tol: float) -> str:
    """One of LANE_CHANGE_STATUSES: unfinished when a requested change did not
    complete because the run ended first: the SV ends more than `tol` (m) from every
    lane centre in `centres` (still moving over), or its last lane change's settling
    window reached the run's end without settling (durations[-1] NaN). A run a
    collision stopped did not end by itself: failed."""
    if end.requests == 0:
        return "none"
    if end.completed:
        return "completed"
    if end.stopped:
        return "failed"
    between = float(np.min(np.abs(np.asarray(centres, dtype=float) - end.y_end))) > tol
    cut = (len(end.durations) > 0 and not np.isfinite(end.durations[-1])
           and end.ends[-1] >= end.t_end - 1e-9)
    return "unfinished" if between or cut else "failed"


def outcome_columns(collisions: int, sumo_collisions: int, end: LaneChangeEnd,
                    centres: Array, tol: float) -> dict[str, Any]:
    """The OUTCOME_DOCS columns of a run's metrics row: our check's and SUMO's
    collision events, how its lane changes ended."""
    status = lane_change_status(end, centres, tol)
    return {"sumo_collision": int(sumo_collisions > 0),
            "collision_seen_by": collision_seen_by(collisions, sumo_collisions),
            "lane_change_status": status,
            "lane_change_unfinished": int(status == "unfinished")}


# ----------------------------------------------------------------------------- merges
# A lane that ends (an acceleration lane, a dropped lane: RoadParams.lane_ends) forces a
# lane change before its end. Read from the trace alone, for our drivers and
# SUMO's alike: did the SV's centre leave the lane it started in before that lane's end,
# how far from the end, and how long it stood still.
MERGE_COLUMNS = ("merge_success", "merge_distance_to_end_m", "stopped_time_s",
                 "merge_follower_max_decel_mps2")
MERGE_DOCS: dict[str, str] = {
    "merge_success": "1 if the SV started in a lane that ends on its route (an acceleration "
    "lane, a dropped lane) and its centre crossed into another lane before that lane's end, "
    "0 if it did not (still in it at the run's end), empty when the SV's start lane does not "
    "end",
    "merge_distance_to_end_m": "distance along s left to the end of the SV's start lane when "
    "its centre crossed into the target lane (m; empty: no lane end, or no merge)",
    "stopped_time_s": f"time the SV's speed was below {STANDSTILL_SPEED:g} m/s (s)",
    "merge_follower_max_decel_mps2": "largest deceleration of the SV's follower in the target "
    "lane of the merge (the nearest TV behind it there when its centre crossed; as "
    "follower_max_decel_mps2), from the start of the merge until 3 s after it settles "
    f"at that lane's centre (within {SETTLE_TOL:g} m; settling is looked for until the SV leaves "
    "the centre again, as a next change begins, an aborted one too) (m/s^2; empty: no "
    "merge or no follower)",
}


def stopped_time(t: ArrayLike, speed: ArrayLike, threshold: float = STANDSTILL_SPEED) -> float:
    """s, the time the speed was below `threshold` (each sample counts its step to the next)."""
    tt = np.asarray(t, dtype=float)
    v = np.asarray(speed, dtype=float)
    if tt.size < 2:
        return 0.0
    return float(np.sum(np.diff(tt)[v[:-1] < threshold]))


def merge_crossing(t: ArrayLike, s: ArrayLike, lane: ArrayLike, lane_end: float
                   ) -> tuple[float, float, int]:
    """(time s, distance to the end m, target lane) of the first sample whose lane (the
    SV centre's) differs from the first sample's, before the start lane's end at s =
    `lane_end` (m): the merge; (NaN, NaN, -1) if there is none (the SV still in its lane,
    or out of it only at or past the end)."""
    tt = np.asarray(t, dtype=float)
    ss = np.asarray(s, dtype=float)
    ln = np.asarray(lane)
    if tt.size == 0 or not math.isfinite(lane_end):
        return math.nan, math.nan, -1
    out = np.flatnonzero((ln != ln[0]) & (ss < lane_end))
    if not out.size:
        return math.nan, math.nan, -1
    k = int(out[0])
    return float(tt[k]), float(lane_end - ss[k]), int(ln[k])


def merge_start(t: ArrayLike, d: ArrayLike, cross: float, centre: float,
                tol: float = SETTLE_TOL) -> float:
    """s, the start of a merge that crossed out of its lane at `cross`: the last sample
    before it at which the SV's d was within `tol` of its start lane's centre (the first
    sample if it never was)."""
    tt = np.asarray(t, dtype=float)
    dd = np.asarray(d, dtype=float)
    before = np.flatnonzero((tt <= cross) & (np.abs(dd - centre) < tol))
    return float(tt[before[-1]]) if before.size else float(tt[0])


def merge_end(t: ArrayLike, d: ArrayLike, lane: ArrayLike, cross: float, centre: float,
              tol: float = SETTLE_TOL) -> float:
    """s, the end of the watch of a merge that crossed into the lane of centre `centre`
    at `cross`: the last sample at that centre (within `tol`) before the SV leaves it
    again, its next change beginning (an aborted one too: it leaves the centre and comes
    back); the run's last sample if it stays. A merge that never reaches the centre is
    watched until the SV's centre crosses out of the lane it entered at `cross`, else to
    the run's last sample."""
    tt = np.asarray(t, dtype=float)
    off = np.abs(np.asarray(d, dtype=float) - centre) >= tol
    after = tt >= cross
    reached = np.flatnonzero(after & ~off)
    if reached.size:
        left = np.flatnonzero(off[reached[0]:])
        return float(tt[reached[0] + left[0] - 1]) if left.size else float(tt[-1])
    ln = np.asarray(lane)
    out = np.flatnonzero(after & (ln != ln[np.flatnonzero(after)[0]]))
    return float(tt[out[0]]) if out.size else float(tt[-1])
