"""Figures of one co-simulation run: the trajectories of the SV and the TVs near it in
road coordinates (s along the route, d across it: the planner's view; like the paper's
Fig. 16, whose straight road has s = x, d = y), with the lane lines, where each lane
ends or exits, and where each lane change started and ended; the gaps and TTC over
time."""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from numpy.typing import NDArray

from cosim.params import RoadParams
from cosim.plots import save_figure
from cosim.plots.labels import D_LABEL, S_LABEL, set_title, suptitle

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TrajectoryMarks:
    """What `road_trajectories` marks besides the paths."""

    highlight: Sequence[str] = ()  # TVs drawn in colour (e.g. the scenario's scripted TVs)
    roles: Mapping[str, str] = field(default_factory=dict)  # their roles, in the labels
    # s, (start, end) of the SV's lane changes (a plan's start and its t0 + tau)
    lane_changes: Sequence[tuple[float, float]] = ()
    # s, when a lane change was asked for (it may start later, after retries or while
    # the SV seeks a gap)
    requests: Sequence[float] = ()


def road_trajectories(
    path: Path,
    t: Array,
    sv_s: Array,
    sv_d: Array,
    tv_tracks: Mapping[str, tuple[Array, Array, Array]],
    road: RoadParams,
    marks: TrajectoryMarks | None = None,
    title: str = "",
    exits: Collection[int] = (),
) -> Path:
    """Write a figure of paths in road coordinates (s, d): the SV in colour, TVs in grey
    (those `marks` highlights in colour, labelled "TV <id>" with their role), dots every
    1 s; the lane changes' starts and planned ends and the requests marked on the SV's
    path; each of `road`'s lanes that ends barred where it ends ("lane k ends"), or, the
    lanes in `exits` (they run on off the route at a diverge), where they leave the
    route ("lane k exits").

    tv_tracks: id -> (t, s, d) arrays while the TV was near the SV.
    """
    marks = marks if marks is not None else TrajectoryMarks()
    fig, ax = plt.subplots(figsize=(11, 3.6))
    s_lo = float(np.nanmin(sv_s))
    s_hi = float(np.nanmax(sv_s))
    for _tid, (_tt, ss, _dd) in tv_tracks.items():
        if ss.size:
            s_lo, s_hi = min(s_lo, float(np.nanmin(ss))), max(s_hi, float(np.nanmax(ss)))
    pad = 0.02 * (s_hi - s_lo + 1.0)
    s_hi = _draw_lanes(ax, road, s_lo - 0.8 * pad, s_hi, exits)
    _draw_tvs(ax, tv_tracks, marks)
    ax.plot(sv_s, sv_d, color="C0", lw=2.0, label="SV")
    every = _every_second(t)
    ax.plot(sv_s[every], sv_d[every], "o", color="C0", ms=3)
    _draw_marks(ax, t, sv_s, sv_d, marks)
    ax.set_xlim(s_lo - pad, s_hi + pad)
    ax.set_ylim(road.y_right - 0.5, road.y_right + road.n_lanes * road.lane_width + 0.5)
    ax.set_xlabel(S_LABEL)
    ax.set_ylabel(D_LABEL)
    set_title(ax, title or "trajectories in road coordinates (s, d; dots every 1 s)")
    ax.legend(loc="upper right", fontsize=8, ncol=4)
    fig.tight_layout()
    return save_figure(fig, path)


def _draw_lanes(ax: Axes, road: RoadParams, s_label: float, s_hi: float,
                exits: Collection[int] = ()) -> float:
    """The lane lines, each lane's name at `s_label`, a bar across a lane where it ends
    or exits and a dashed one where it begins along the route; returns the right end of
    the view (`s_hi`, or a lane's end shortly past it)."""
    for k in range(road.n_lanes + 1):
        d_line = road.y_right + k * road.lane_width
        style = "-" if k in (0, road.n_lanes) else "--"
        ax.axhline(d_line, color="0.5", lw=0.8, ls=style, zorder=0)
    for k in range(road.n_lanes):
        ax.text(s_label, road.lane_center(k) + 0.3 * road.lane_width, f"lane {k}",
                fontsize=7, va="center", ha="left", color="0.4")
        end = road.lane_end(k)
        if math.isfinite(end):
            d_lo = road.y_right + k * road.lane_width
            # an exit is no end of the road: a dotted bar, the lane runs on off the route
            ax.plot([end, end], [d_lo, d_lo + road.lane_width], color="k",
                    lw=1.5 if k in exits else 3.0, ls=":" if k in exits else "-",
                    solid_capstyle="butt", zorder=1)
            ax.text(end, d_lo + 0.5 * road.lane_width,
                    f" lane {k} {'exits' if k in exits else 'ends'}", fontsize=7,
                    va="center", ha="left", color="0.2")
            s_hi = max(s_hi, end) if end < s_hi + 500.0 else s_hi
        begin = road.lane_begin(k)
        if math.isfinite(begin) and begin < s_hi:  # the mainline beside a ramp's lane, ...
            d_lo = road.y_right + k * road.lane_width
            ax.plot([begin, begin], [d_lo, d_lo + road.lane_width], color="k", lw=1.5,
                    ls="--", zorder=1)
            ax.text(begin, d_lo + 0.5 * road.lane_width, f"lane {k} begins ", fontsize=7,
                    va="center", ha="right", color="0.2")
    return s_hi


def _draw_tvs(ax: Axes, tv_tracks: Mapping[str, tuple[Array, Array, Array]],
              marks: TrajectoryMarks) -> None:
    """The TVs' paths: grey, the highlighted ones in colour with dots every 1 s."""
    colour = 1
    for tid, (tt, ss, dd) in sorted(tv_tracks.items()):
        if tid in marks.highlight:
            c = f"C{colour}"
            colour += 1
            role = marks.roles.get(tid, "")
            ax.plot(ss, dd, color=c, lw=1.5, label=f"TV {tid}" + (f" ({role})" if role else ""))
            every = _every_second(tt)
            ax.plot(ss[every], dd[every], "o", color=c, ms=2.5)
        else:
            ax.plot(ss, dd, color="0.65", lw=0.7)


def _draw_marks(ax: Axes, t: Array, sv_s: Array, sv_d: Array, marks: TrajectoryMarks
                ) -> None:
    """The requests, lane-change starts and planned ends on the SV's path (each label
    once in the legend)."""
    shown: set[str] = set()
    points = [(when, "x", "lane-change request") for when in marks.requests]
    for start, end in marks.lane_changes:
        points += [(start, ">", "lane change starts (plan adopted)"),
                   (end, "|", "planned end (start + tau)")]
    for when, marker, label in points:
        i = int(np.searchsorted(t, when - 1e-9))
        if 0 <= i < t.size:
            ax.plot(sv_s[i], sv_d[i], marker, color="k", ms=8,
                    label=None if label in shown else label)
            shown.add(label)


def gap_history(
    path: Path,
    t: Array,
    gap: Array,
    leader_gap: Array,
    ttc: Array,
    *,
    lane_changes: Sequence[tuple[float, float]] = (),
    title: str = "",
) -> Path:
    """Gap and time-to-collision over time (trace.csv's gap_min_m, leader_gap_m,
    ttc_min_s), lane changes shaded. inf (no one in the SV's strip, or no one
    closing in) is left as a break in the line and said in the panel."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    for ax in (top, bottom):
        for start, end in lane_changes:
            ax.axvspan(start, end, color="0.9", lw=0)
        ax.grid(alpha=0.3)
    if t.size:
        top.set_xlim(float(t[0]), float(t[-1]))
    finite_gap = np.where(np.isfinite(gap), gap, np.nan)
    top.plot(t, np.where(np.isfinite(leader_gap), leader_gap, np.nan), color="0.5", lw=1.0,
             label="gap to the leader in the SV's lane")
    top.plot(t, finite_gap, color="C0", lw=1.6, label="smallest gap to a TV in the SV's strip")
    top.set_ylabel("gap (m)")
    top.set_ylim(bottom=0.0)
    top.legend(fontsize=8, loc="upper right")
    finite_ttc = np.where(np.isfinite(ttc), ttc, np.nan)
    bottom.plot(t, finite_ttc, color="C3", lw=1.6, label="smallest TTC")
    if np.isfinite(ttc).any():
        bottom.set_yscale("log")
        worst = float(np.nanmin(finite_ttc))
        bottom.set_title(f"minimum {worst:.2f} s; breaks: no one closing in (TTC inf)",
                         fontsize=8)
    else:
        bottom.set_title("no TV ever closing in on the SV (TTC inf throughout)", fontsize=8)
    bottom.set_ylabel("time-to-collision (s)")
    bottom.set_xlabel("t (s)  (grey: the SV's lane changes)")
    suptitle(fig, title or "gaps and time-to-collision", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def _every_second(t: Array) -> Array:
    """Indices of the samples closest to whole seconds."""
    if t.size == 0:
        return np.zeros(0, dtype=int)
    marks = np.arange(np.ceil(t[0]), t[-1] + 1e-9, 1.0)
    return np.clip(np.searchsorted(t, marks - 1e-9), 0, t.size - 1)
