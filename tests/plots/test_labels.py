"""Figure words that stay true and fit: a long real route named by its ends, titles
wrapped to the figure, road-coordinate axes labelled as such, a lane that leaves the
route at a diverge labelled as an exit, not as a lane end."""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cosim.params import RoadParams
from cosim.plots.labels import D_LABEL, S_LABEL, route_name, set_title
from cosim.road.road import load_road
from cosim.traffic.network import netconvert_binary
from cosim.traffic.route_lanes import exit_lanes, road_params

N_EDGES = 51
EDGE_LENGTH = 66.7  # m: 51 edges, 3.4 km
DIVERGE = 10  # the off-ramp leaves where edge 10 begins
EDGES = [f"4711815#{i}" for i in range(N_EDGES)]  # ids the way OSM imports make them


def long_route(tmp: Path) -> Path:
    """A 3.4 km motorway of 51 edges along +x: three lanes on the first ten, where the
    rightmost leaves onto an off-ramp (a diverge: it runs on, off the route), two after."""
    nodes = [f'<node id="n{i}" x="{i * EDGE_LENGTH:.2f}" y="0"/>' for i in range(N_EDGES + 1)]
    ramp_x = (DIVERGE * EDGE_LENGTH) + 300.0
    nodes.append(f'<node id="ramp" x="{ramp_x:.2f}" y="-60"/>')
    edges = [f'<edge id="{e}" from="n{i}" to="n{i + 1}" speed="33.3" '
             f'numLanes="{3 if i < DIVERGE else 2}"/>' for i, e in enumerate(EDGES)]
    edges.append(f'<edge id="off" from="n{DIVERGE}" to="ramp" numLanes="1" speed="22.2"/>')
    before, after = EDGES[DIVERGE - 1], EDGES[DIVERGE]
    connections = (f'<connection from="{before}" to="off" fromLane="0" toLane="0"/>'
                   f'<connection from="{before}" to="{after}" fromLane="1" toLane="0"/>'
                   f'<connection from="{before}" to="{after}" fromLane="2" toLane="1"/>')
    for name, text in (("nod", f"<nodes>{''.join(nodes)}</nodes>"),
                       ("edg", f"<edges>{''.join(edges)}</edges>"),
                       ("con", f"<connections>{connections}</connections>")):
        (tmp / f"long.{name}.xml").write_text(text, encoding="utf-8")
    subprocess.run([netconvert_binary(), "-n", "long.nod.xml", "-e", "long.edg.xml",
                    "-x", "long.con.xml", "-o", "long.net.xml", "--no-turnarounds", "true"],
                   cwd=tmp, check=True, capture_output=True)
    return tmp / "long.net.xml"


def _keep(module: Any, monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures `module` would save, kept open instead of written."""
    figures: list[Any] = []
    monkeypatch.setattr(module, "save_figure", lambda fig, path: figures.append(fig) or path)
    return figures


def _fits(fig: Any, text: Any) -> bool:
    """The Text lies within its figure's width."""
    fig.canvas.draw()
    box = text.get_window_extent(fig.canvas.get_renderer())
    return box.x0 >= 0.0 and box.x1 <= fig.bbox.width and box.width > 0.0


def test_a_long_route_is_named_by_its_ends() -> None:
    assert route_name(["e1", "e2", "e3", "e4"], 1502.0) == "route e1 e2 e3 e4 (1.5 km)"
    name = route_name(EDGES, 3401.7)
    assert name == "route 4711815#0 ... 4711815#50 (51 edges, 3.4 km)"
    very_long_id = "x" * 200
    assert len(route_name([very_long_id, *EDGES], 3401.7)) < 80
    assert len(route_name([very_long_id], 10.0)) < 50


def test_the_road_of_a_51_edge_route_has_a_short_title_within_the_figure(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import cosim.plots.road as road_plots

    figures = _keep(road_plots, monkeypatch)
    road = load_road(long_route(tmp_path), EDGES)
    road_plots.plot_road(road, tmp_path / "road.png")
    (fig,) = figures
    ax_map = fig.axes[0]
    title = ax_map.title
    assert title.get_text().startswith("route 4711815#0 ... 4711815#50 (51 edges, 3.4 km): ")
    assert len(title.get_text()) < 110 and _fits(fig, title)
    # every edge ticked, its name shown only where it does not run into another's
    names = [t for t in ax_map.texts if t.get_text() in EDGES]
    assert names[0].get_text() == EDGES[0] and 2 <= len(names) < N_EDGES
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in names]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def test_the_lane_that_leaves_at_a_diverge_exits_the_route(tmp_path: Path) -> None:
    road = load_road(long_route(tmp_path), EDGES)
    lanes = road_params(road)
    assert np.isfinite(lanes.lane_ends[0]) and np.isinf(lanes.lane_ends[1:]).all()
    assert exit_lanes(road) == (0,)
    assert [t.exits for t in road.tracks] == [True, False, False]


def test_a_dropped_lane_and_an_acceleration_lane_end(tmp_path: Path) -> None:
    from cosim.scenario import project_root

    onramp = project_root() / "networks" / "onramp.net.xml"
    for route in (["main2", "main3"], ["acc", "main1", "main2"]):  # lane drop, on-ramp
        road = load_road(onramp, route)
        assert any(np.isfinite(road_params(road).lane_ends)) and exit_lanes(road) == ()


@pytest.mark.parametrize(("exits", "word"), [((0,), "exits"), ((), "ends")])
def test_trajectories_are_in_road_coordinates_and_say_how_a_lane_stops(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, exits: tuple[int, ...],
        word: str) -> None:
    import cosim.plots.run as run_plots

    figures = _keep(run_plots, monkeypatch)
    t = np.arange(0.0, 10.0, 0.05)
    road = RoadParams(lane_ends=(150.0, np.inf, np.inf))
    run_plots.road_trajectories(tmp_path / "t.png", t, 25.0 * t, np.full_like(t, 5.625), {},
                                road, exits=exits)
    ax = figures[0].axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == (S_LABEL, D_LABEL)
    assert "road coordinates (s, d" in ax.get_title()
    said = [x.get_text().strip() for x in ax.texts if x.get_text().strip().startswith("lane 0 ")]
    assert said == [f"lane 0 {word}"]


def test_trajectories_say_where_a_lane_begins_along_the_route(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A route over an off-ramp: the deceleration lane (lane 0) begins at 700 m, the
    mainline's lanes exit at 895 m."""
    import cosim.plots.run as run_plots

    figures = _keep(run_plots, monkeypatch)
    t = np.arange(0.0, 10.0, 0.05)
    road = RoadParams(lane_ends=(np.inf, 895.0, 895.0), lane_begins=(700.0, -np.inf, -np.inf))
    run_plots.road_trajectories(tmp_path / "t.png", t, 600.0 + 25.0 * t,
                                np.full_like(t, 5.625), {}, road, exits=(1, 2))
    said = sorted(x.get_text().strip() for x in figures[0].axes[0].texts
                  if x.get_text().strip().startswith("lane ") and " " in x.get_text().strip()[5:])
    assert said == ["lane 0 begins", "lane 1 exits", "lane 2 exits"]


def test_a_long_title_is_wrapped_to_the_figure(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3))
    name = "a_scenario_whose_author_liked_long_names " * 6
    title = set_title(ax, f"{name}: trajectories in road coordinates (s, d)")
    assert "\n" in title.get_text() and _fits(fig, title)
    short = set_title(ax, "short")
    assert short.get_text() == "short"
    plt.close(fig)
