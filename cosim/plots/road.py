"""The road of a route (cosim.road): an x-y map of SUMO's lanes with the frame's lane
borders over them, and the reference line's curvature along s beside SUMO's own
polyline's (kink angle / segment length), which shows what smoothing did."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.plots import save_figure
from cosim.plots.labels import route_name, set_title

if TYPE_CHECKING:
    from cosim.road.road import Road

STRETCH_BELOW = 0.05  # -, a map narrower than this share of its length is drawn stretched


def plot_road(route_road: Road, path: Path, *, title: str = "",
              sv_path: tuple[Any, Any] | None = None) -> Path:
    """Draw the route's road `route_road` to `path`; `sv_path`: (x, y) arrays of the
    SV's centre drawn over it (a run's trace)."""
    import matplotlib.pyplot as plt

    frame = route_road.frame
    fig, (ax_map, ax_k) = plt.subplots(2, 1, figsize=(10, 9),
                                       gridspec_kw={"height_ratios": [3, 1]})
    shapes = [np.asarray(piece.shape)
              for track in route_road.tracks for piece in track.pieces]
    for xy in shapes:
        ax_map.plot(xy[:, 0], xy[:, 1], color="0.75", lw=3.0, solid_capstyle="butt",
                    zorder=1)
    colours = plt.get_cmap("tab10")
    for table in route_road.lanes:
        s = np.arange(table.begin, table.end, 1.0)
        if s.size < 2:
            continue
        right, left = table.bounds(s)
        for k, d in enumerate((right, left)):
            x, y, _ = frame.to_cartesian(s, d)
            ax_map.plot(x, y, color=colours(table.id % 10), lw=0.8, zorder=2,
                        label=f"track {table.id} ({table.track.name})" if k == 0 else None)
    names = _mark_edges(ax_map, route_road)
    if sv_path is not None:
        ax_map.plot(sv_path[0], sv_path[1], color="k", lw=1.5, zorder=3, label="SV")
    ax_map.legend(fontsize=7, loc="best", title="frame's lane borders (SUMO's lanes grey)",
                  title_fontsize=7)
    span = np.ptp(np.concatenate(shapes), axis=0)  # m, extent in x and in y
    labels = ["x (m)", "y (m)"]
    if span.min() >= STRETCH_BELOW * span.max():
        ax_map.set_aspect("equal", adjustable="datalim")
    else:  # a near-straight road to scale is a line: its narrow axis stretched shows lanes
        narrow = int(np.argmin(span))
        labels[narrow] = f"{'xy'[narrow]} (m; stretched, not to scale)"
    ax_map.set_xlabel(labels[0])
    ax_map.set_ylabel(labels[1])
    q = frame.quality
    set_title(ax_map, title or f"{route_name(route_road.route.edges, frame.length)}: "
              f"deviation {route_road.max_deviation * 100:.1f} cm, smallest radius "
              f"{q.min_radius:.0f} m")
    s = np.arange(0.0, frame.length, 0.5)
    ax_k.plot(s, 1e3 * np.asarray(frame.curvature(s)), lw=0.8, label="frame (smoothed)")
    ref = np.asarray(route_road.reference.shape())
    v = np.diff(ref, axis=0)
    seg = np.hypot(v[:, 0], v[:, 1])
    turn = np.diff(np.unwrap(np.arctan2(v[:, 1], v[:, 0])))
    if turn.size:
        sv, _ = frame.to_frenet(ref[1:-1, 0], ref[1:-1, 1])
        ax_k.plot(sv, 1e3 * turn / (0.5 * (seg[:-1] + seg[1:])), ".", ms=2, color="0.5",
                  label="SUMO's polyline (kink / segment)")
    ax_k.set_xlabel("s (m)")
    ax_k.set_ylabel("curvature (1/km)")
    ax_k.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    _uncrowd(fig, names)
    return save_figure(fig, path)


def _mark_edges(ax: Any, route_road: Road) -> list[Any]:
    """A tick where each route edge begins and its name; returns the names
    (`_uncrowd` them once the figure is laid out)."""
    names = []
    for edge in route_road.route.edges:
        x, y = route_road.route.net.getEdge(edge).getShape()[0]
        ax.plot([x], [y], "k|", ms=12)
        names.append(ax.annotate(edge, (x, y), fontsize=8, xytext=(3, 6),
                                 textcoords="offset points"))
    return names


def _uncrowd(fig: Any, names: list[Any]) -> None:
    """Remove each edge name that would overlap one kept before it, in route order: a
    real route has dozens of edges, some a few metres long (every edge keeps its tick)."""
    fig.canvas.draw()  # the final limits (aspect, stretch) and layout place the names
    renderer = fig.canvas.get_renderer()
    kept: list[Any] = []
    for name in names:
        box = name.get_window_extent(renderer)
        if any(box.overlaps(other) for other in kept):
            name.remove()
        else:
            kept.append(box)
