"""Run figures: the gap and TTC history among them, each figure's axes labelled with what
it draws; compiling announced before a bar."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cosim.plots.run import gap_history


def test_gap_history_handles_inf(tmp_path: Path) -> None:
    t = np.arange(0.0, 5.0, 0.05)
    gap = np.where(t < 2.0, 10.0 - t, np.inf)
    ttc = np.where(t < 1.0, 5.0 - t, np.inf)
    path = gap_history(tmp_path / "gaps.svg", t, gap, np.full_like(t, np.inf), ttc,
                       lane_changes=[(1.0, 3.0)], title="t")
    assert "<svg" in path.read_text()
    never = gap_history(tmp_path / "none.png", t, gap, gap, np.full_like(t, np.inf))
    assert never.stat().st_size > 5_000


def test_compile_first_says_so_on_a_cold_cache(monkeypatch: pytest.MonkeyPatch,
                                               tmp_path: Path) -> None:
    from cosim.commands import compile_first
    from cosim.compiled import cache_warm

    compile_first(io.StringIO())  # fills the cache if it was cold
    assert cache_warm()
    quiet = io.StringIO()
    compile_first(quiet)
    assert quiet.getvalue() == ""  # a warm cache: nothing to say
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))  # an empty cache
    assert not cache_warm()
    told = io.StringIO()
    compile_first(told)
    lines = told.getvalue().splitlines()
    assert lines[0].startswith("compiling (once per machine, ~") and "compiled in" in lines[1]


def test_trajectories_legend_names_markers_and_tvs(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The request, start and planned-end markers are in the legend (once each), the
    request apart from the start; scripted TVs are "TV <id> (role)"."""
    import cosim.plots.run as run_plots
    from cosim.params import RoadParams

    figures = []
    monkeypatch.setattr(run_plots, "save_figure", lambda fig, path: figures.append(fig) or path)
    t = np.arange(0.0, 10.0, 0.05)
    tv = (t, 20.0 + 25.0 * t, np.full_like(t, 5.625))
    run_plots.road_trajectories(
        tmp_path / "trajectories.png", t, 25.0 * t, np.full_like(t, 1.875),
        {"pvc": tv, "tv7": tv}, RoadParams(), run_plots.TrajectoryMarks(
            highlight=["pvc"], roles={"pvc": "ahead, lane 1"},
            lane_changes=[(2.0, 8.0), (8.5, 9.5)], requests=[1.0]))
    labels = figures[0].axes[0].get_legend_handles_labels()[1]
    assert labels == ["TV pvc (ahead, lane 1)", "SV", "lane-change request",
                      "lane change starts (plan adopted)", "planned end (start + tau)"]


def test_figure_path_takes_the_format_it_is_given(tmp_path: Path) -> None:
    import cosim.plots as plots

    assert plots.figure_path(tmp_path, "gaps") == tmp_path / "gaps.png"
    assert plots.figure_path(tmp_path, "gaps", None) == tmp_path / "gaps.png"
    assert plots.figure_path(tmp_path, "gaps", "pdf") == tmp_path / "gaps.pdf"
    assert plots.figure_path(tmp_path, "gaps") == tmp_path / "gaps.png"  # nothing kept
    with pytest.raises(ValueError, match="one of png, svg, pdf"):
        plots.figure_path(tmp_path, "gaps", "jpg")
    assert not hasattr(plots, "set_format")  # no process-wide setting left


def test_every_run_figure_labels_what_it_draws(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """On a curved route the paths drawn over the lane lines are in road coordinates
    (s, d), and their axes say so: trajectories, the planning panels, compare's; the
    x-y map (road.png) is the one Cartesian figure, titled with its route."""
    import cosim.plots.compare as compare_plots
    import cosim.plots.planning as planning_plots
    import cosim.plots.road as road_plots
    import cosim.plots.run as run_plots
    import cosim.plots.tracking as tracking_plots
    from cosim.plots.labels import D_LABEL, S_LABEL
    from cosim.run.loop import simulate
    from cosim.run.outputs import write_run_figures
    from cosim.scenario import load_scenario, project_root, with_overrides

    figures: dict[str, Any] = {}

    def keep(fig: Any, path: Path) -> Path:
        figures[Path(path).stem] = fig
        return path

    for module in (run_plots, road_plots, planning_plots, tracking_plots, compare_plots):
        monkeypatch.setattr(module, "save_figure", keep)
    sc = load_scenario(project_root() / "scenarios" / "curved_case1_overtaking.toml")
    result = simulate(with_overrides(sc, duration=1.0))
    write_run_figures(result, tmp_path)
    compare_plots.compare_figure(tmp_path / "compare.png", {"mimo": result}, title="c")
    assert {"trajectories", "gaps", "road", "tracking", "inputs", "tau_sets", "planning",
            "compare"} <= set(figures)

    trajectories = figures["trajectories"].axes[0]
    assert "road coordinates (s, d)" in trajectories.get_title()
    assert (trajectories.get_xlabel(), trajectories.get_ylabel()) == (S_LABEL, D_LABEL)
    planning = [ax for ax in figures["planning"].axes
                if ax.get_title().startswith(("(a)", "(c)"))]
    assert [(ax.get_xlabel(), ax.get_ylabel()) for ax in planning] == [(S_LABEL, D_LABEL)] * 2
    paths = figures["compare"].axes[0]
    assert (paths.get_xlabel(), paths.get_ylabel()) == (S_LABEL, D_LABEL)
    road_map = figures["road"].axes[0]
    assert road_map.get_xlabel() == "x (m)" and road_map.get_ylabel() == "y (m)"
    assert road_map.get_title().startswith("route e1 e2 e3 e4 (")
