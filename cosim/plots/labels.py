"""The words on a figure: the axis labels of road coordinates, a route named by its ends
when its edge list is long, and titles wrapped at spaces until they are no wider than
their figure (a scenario's or a real network's names are as long as their authors made
them).

Road coordinates are what the planner sees (cosim.road): s the arc length along the
route's reference line, d the offset across it, + to the left; on the straight one-edge
road s = x - x0, d = y - y0.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from typing import Any

S_LABEL = "s along the route (m)"
D_LABEL = "d across the road (m)"

MAX_LISTED_CHARS = 40  # a route's name lists its edges when their ids fit in this
MAX_ID_CHARS = 24  # an edge id longer than this is shortened in the middle
FILL = 0.96  # share of the figure's width a title may take
MIN_LINE = 12  # characters: a line is never wrapped narrower


def short_id(edge: str) -> str:
    """`edge`, or its start and end around "..." if it is longer than MAX_ID_CHARS."""
    if len(edge) <= MAX_ID_CHARS:
        return edge
    keep = (MAX_ID_CHARS - 3) // 2
    return f"{edge[:keep]}...{edge[-keep:]}"


def route_name(edges: Sequence[str], length: float) -> str:
    """The route in a few words: "route a b c (1.5 km)", or, when the list would be long,
    its first and last edge and the count: "route A ... Z (51 edges, 3.4 km)";
    `length` in m."""
    km = f"{length / 1000.0:.1f} km"
    listed = " ".join(edges)
    if len(listed) <= MAX_LISTED_CHARS:
        return f"route {listed} ({km})"
    if len(edges) == 1:
        return f"route {short_id(edges[0])} ({km})"
    return f"route {short_id(edges[0])} ... {short_id(edges[-1])} ({len(edges)} edges, {km})"


def set_title(ax: Any, text: str, **kwargs: Any) -> Any:
    """`ax.set_title(text, **kwargs)`, wrapped to fit its figure's width (`fit`)."""
    return fit(ax.set_title(text, **kwargs))


def suptitle(fig: Any, text: str, **kwargs: Any) -> Any:
    """`fig.suptitle(text, **kwargs)`, wrapped to fit the figure's width (`fit`)."""
    return fit(fig.suptitle(text, **kwargs))


def fit(title: Any) -> Any:
    """Wrap the matplotlib Text `title` at spaces (a long word broken) until it is at most
    FILL of its figure's width; call it before the figure's tight_layout, which then
    makes room for the extra lines. Returns `title`."""
    fig = title.get_figure()
    renderer = fig.canvas.get_renderer()
    limit = FILL * fig.bbox.width
    width = title.get_window_extent(renderer).width
    text = title.get_text()
    if width <= limit or not text:
        return title
    lines = text.splitlines()
    per_line = max(MIN_LINE, int(max(len(line) for line in lines) * limit / width))
    while True:
        title.set_text("\n".join(
            wrapped for line in lines
            for wrapped in textwrap.wrap(line, per_line, break_on_hyphens=False) or [""]))
        if title.get_window_extent(renderer).width <= limit or per_line <= MIN_LINE:
            return title
        per_line = max(MIN_LINE, per_line - 4)
