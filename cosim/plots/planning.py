"""Planning figures in the style of the paper's Fig. 2 and Fig. 10-12.

(a) the SV's stable trajectory cluster with the TVs' predicted futures (C2: their
whole clusters), the chosen trajectory in bold; (b) the tau sets: stable,
collision-free, every rejected tau coloured by its reason, tau_opt and the choice;
(c) the chosen lane change as rectangles once a second, with the TVs (for C2 TVs
every hypothesis, faint). Positions are the planner's: road coordinates (s, d), which
are the paper's x, y on its straight road.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.patches import Polygon

from cosim.params import RoadParams, VehicleParams
from cosim.planning.collision import corners
from cosim.planning.planner import Plan
from cosim.planning.prediction import LazyFutures, TVFutures
from cosim.planning.trajectory import cluster_derivatives
from cosim.plots import save_figure
from cosim.plots.labels import D_LABEL, S_LABEL, set_title, suptitle

RECT_TIMES = 1.0  # s, spacing of the rectangles of panel (c)
MAX_NAMED = 6  # TVs named in a panel; more are drawn without a name each


def _lanes(ax: Axes, road: RoadParams) -> None:
    for k in range(road.n_lanes + 1):
        y = road.y_right + k * road.lane_width
        ax.axhline(y, color="0.3", lw=0.8, ls="-" if k in (0, road.n_lanes) else "--")


def _sv_cluster(
    plan: Plan, road: RoadParams, t_rel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(taus, s, d) of the stable candidates on t_rel, in road coordinates."""
    sv = plan.sv
    assert sv is not None
    taus = plan.taus[plan.stable]
    width = road.lane_center(plan.target_lane) - sv.y
    x, y = cluster_derivatives(sv.boundary(plan.vxf, width), taus, t_rel, (0,))[0]
    return taus, x + sv.x, y + sv.y


def draw_cluster(ax: Axes, plan: Plan, road: RoadParams) -> None:
    """Panel (a): stable cluster, TV futures, chosen trajectory (Fig. 2, 10a-12a)."""
    t_rel = plan.futures.t - plan.t if plan.futures is not None else np.linspace(0, 12, 241)
    _lanes(ax, road)
    if plan.sv is not None and plan.stable.any():
        taus, x, y = _sv_cluster(plan, road, t_rel)
        cmap = plt.get_cmap("viridis")
        span = max(float(taus.max() - taus.min()), 1e-9)
        step = max(1, taus.size // 40)  # about 40 lines: readable
        for i in range(0, taus.size, step):
            free = plan.collision_free[plan.stable][i]
            ax.plot(x[i], y[i], color=cmap((taus[i] - taus.min()) / span), lw=0.6,
                    alpha=0.9 if free else 0.35, ls="-" if free else ":")
        bar = plt.colorbar(ScalarMappable(Normalize(float(taus.min()), float(taus.min()) + span),
                                          cmap), ax=ax, pad=0.01, fraction=0.04)
        bar.set_label("SV's tau (s)")
    f = plan.futures
    if f is not None:
        # one legend entry per kind of prediction, not per TV (dense traffic has dozens)
        labelled: set[str] = set()
        for j, vid in enumerate(f.vehicle_ids):
            rows = np.flatnonzero(f.owner == j)
            step = max(1, rows.size // 15)
            kind = "TV cluster (C2)" if rows.size > 1 else "TV prediction"
            for h in rows[::step]:
                ax.plot(f.x[h], f.y[h], color="C3", lw=0.7 if rows.size > 1 else 1.6,
                        alpha=0.5 if rows.size > 1 else 1.0,
                        label=None if kind in labelled else kind)
                labelled.add(kind)
            if len(f.vehicle_ids) <= MAX_NAMED:
                ax.annotate(f"{vid} ({f.categories[j]})", (f.x[rows[0], 0], f.y[rows[0], 0]),
                            fontsize=6, color="C3", xytext=(0, 4), textcoords="offset points")
    if plan.trajectory is not None:
        tr = plan.trajectory
        ts = plan.t + t_rel[t_rel <= tr.tau + 2.0]
        x, y = tr.position(ts)
        ax.plot(x, y, color="k", lw=2.2, label=f"chosen tau = {tr.tau:.2f} s")
    ax.set_xlabel(S_LABEL)
    ax.set_ylabel(D_LABEL)
    ax.set_ylim(road.y_right - 0.5, road.y_right + road.n_lanes * road.lane_width + 0.5)
    ax.set_title("(a) stable cluster (dotted: collides) and TV futures")
    ax.legend(loc="upper left", fontsize=7, ncol=3)


def draw_tau_sets(ax: Axes, plan: Plan) -> None:
    """Panel (b): which tau is stable, collision-free, or rejected why (Fig. 10b-12b)."""
    taus = plan.taus
    rows = {"stable": 2.0, "collision-free": 1.0, "rejected": 0.0}
    for lo, hi in plan.stable_intervals:
        ax.plot([lo, hi], [rows["stable"]] * 2, color="C2", lw=8, solid_capstyle="butt")
    for lo, hi in plan.collision_free_intervals:
        ax.plot([lo, hi], [rows["collision-free"]] * 2, color="C0", lw=8, solid_capstyle="butt")
    unstable = np.array([r.tau for r in plan.rejections if r.reason == "unstable"])
    if unstable.size:
        ax.plot(unstable, np.zeros_like(unstable), "|", color="0.5", ms=10, label="unstable")
    by_tv: dict[str, list[float]] = {}
    for r in plan.rejections:
        if r.reason == "collision":
            by_tv.setdefault(str(r.vehicle_id), []).append(r.tau)
    # the TVs that reject the most taus by name, the rest together (a short legend)
    ranked = sorted(by_tv.items(), key=lambda kv: (-len(kv[1]), kv[0]))
    named, rest = ranked[:MAX_NAMED - 1], ranked[MAX_NAMED - 1:]
    if len(rest) == 1:
        named, rest = ranked, []
    for k, (vid, tv_taus) in enumerate(named):
        ax.plot(tv_taus, np.zeros(len(tv_taus)), "|", color=f"C{(k + 3) % 10}", ms=14,
                label=f"collides with TV {vid}")
    if rest:
        others = [tau for _, tv_taus in rest for tau in tv_taus]
        ax.plot(others, np.zeros(len(others)), "|", color="0.3", ms=14,
                label=f"collides with {len(rest)} other TVs")
    if np.isfinite(plan.tau_opt):
        ax.axvline(plan.tau_opt, color="k", ls="--", lw=1, label=f"tau_opt = {plan.tau_opt:.2f} s")
    if plan.tau is not None:
        ax.plot([plan.tau], [rows["collision-free"]], "v", color="k", ms=9,
                label=f"chosen {plan.tau:.2f} s")
    ax.set_yticks(list(rows.values()), list(rows.keys()))
    ax.set_ylim(-0.7, 2.7)
    ax.set_xlim(float(taus.min()) - 0.2, float(taus.max()) + 0.2)
    ax.set_xlabel("lane-change duration tau (s)")
    ax.set_title(f"(b) tau sets (omega = {plan.omega:.3f})")
    ax.legend(loc="upper left", fontsize=7, ncol=2)


def _draw_now(ax: Axes, plan: Plan, road: RoadParams, vehicle: VehicleParams) -> None:
    """Panel (c) without a lane change: the SV and each TV's first hypothesis now."""
    f = plan.futures
    ax.set_title("(c) no collision-free tau: keep lane (SV and TVs now)")
    if plan.sv is None:
        return
    sv = plan.sv
    ax.add_patch(Polygon(corners(sv.x, sv.y, sv.heading, vehicle.length, vehicle.width),
                         closed=True, fill=False, ec="k", lw=1.2))
    xs = [sv.x]
    if f is not None and f.n_hypotheses:
        first = np.unique(f.owner, return_index=True)[1]
        for hh in first:
            ax.add_patch(Polygon(corners(f.x[hh, 0], f.y[hh, 0], f.heading[hh, 0],
                                         f.length[hh], f.width[hh]),
                                 closed=True, fill=False, ec="C3", lw=1.0))
        xs += list(f.x[first, 0])
    ax.set_xlim(min(xs) - 20, max(xs) + 20)
    ax.set_ylim(road.y_right - 0.5, road.y_right + road.n_lanes * road.lane_width + 0.5)


def _draw_tv_boxes(ax: Axes, f: TVFutures | LazyFutures, j: int, k: np.ndarray,
                   marks: np.ndarray) -> None:
    """TV j's rectangles at the sample indices k (up to six of its hypotheses), the first
    one's numbered with the seconds in `marks`, and its name."""
    rows = np.flatnonzero(f.owner == j)
    single = rows.size == 1
    for hh in rows[:: max(1, rows.size // 6)]:
        for m, i in enumerate(k):
            ax.add_patch(Polygon(
                corners(f.x[hh, i], f.y[hh, i], f.heading[hh, i], f.length[hh], f.width[hh]),
                closed=True, fill=False, ec="C3", lw=1.0 if single else 0.5,
                alpha=1.0 if single else 0.4))
            if hh == rows[0]:
                ax.annotate(f"{marks[m]:g}", (f.x[hh, i], f.y[hh, i] - 0.5 * f.width[hh]),
                            fontsize=6, ha="center", va="top", color="C3")
    if rows.size:
        last = rows[0], k[-1]
        ax.annotate(f"TV {f.vehicle_ids[j]}", (f.x[last], f.y[last]), fontsize=7,
                    ha="left", va="center", color="C3", xytext=(6, 0),
                    textcoords="offset points")


def draw_snapshots(ax: Axes, plan: Plan, road: RoadParams, vehicle: VehicleParams) -> None:
    """Panel (c): the chosen trajectory and the TVs as rectangles every second (Fig. 10c-12c)."""
    _lanes(ax, road)
    f = plan.futures
    if plan.trajectory is None or f is None:
        _draw_now(ax, plan, road, vehicle)
        return
    tr = plan.trajectory
    marks = np.arange(0.0, tr.tau + 1e-9, RECT_TIMES)
    k = np.clip(np.searchsorted(f.t - plan.t, marks - 1e-9), 0, f.t.size - 1)
    x, y = tr.position(f.t[k])
    h = tr.heading(f.t[k])
    for i in range(k.size):
        ax.add_patch(Polygon(corners(x[i], y[i], h[i], vehicle.length, vehicle.width),
                             closed=True, fill=False, ec="k", lw=1.0))
        # each box's time from the plan, above the SV's and (the same instants) the
        # TVs' boxes: boxes of different times may overlap on the page, never in time
        ax.annotate(f"{marks[i]:g}", (x[i], y[i] + 0.5 * vehicle.width), fontsize=6,
                    ha="center", va="bottom", color="k")
    for j in range(len(f.vehicle_ids)):
        _draw_tv_boxes(ax, f, j, k, marks)
    xs = np.concatenate([x, f.x[:, k].ravel()])
    ax.set_xlim(float(xs.min()) - 5, float(xs.max()) + 5)
    ax.set_ylim(road.y_right - 0.5, road.y_right + road.n_lanes * road.lane_width + 0.5)
    ax.set_xlabel(S_LABEL)
    ax.set_ylabel(D_LABEL)
    ax.set_title(f"(c) chosen lane change and TVs every {RECT_TIMES:g} s (black: SV; "
                 "numbers: s after the plan)")


def planning_figure(path: Path, plan: Plan, road: RoadParams, vehicle: VehicleParams,
                    title: str = "") -> Path:
    """The three panels in one figure at `path` (written atomically)."""
    fig, axes = plt.subplots(3, 1, figsize=(10, 11))
    draw_cluster(axes[0], plan, road)
    draw_tau_sets(axes[1], plan)
    draw_snapshots(axes[2], plan, road, vehicle)
    if title:
        suptitle(fig, title)
    fig.tight_layout()
    return save_figure(fig, path)


def tau_sets(path: Path, plan: Plan, title: str = "") -> Path:
    """Panel (b) alone (the co-simulation's tau_sets.png)."""
    fig, ax = plt.subplots(figsize=(9, 3.2))
    draw_tau_sets(ax, plan)
    if title:
        set_title(ax, title)
    fig.tight_layout()
    return save_figure(fig, path)
