"""What one run writes: trace.csv, plans.csv, metrics.csv, timing.csv and the figures.

Every file is written atomically (cosim.output); the CSVs use one fixed float
format, so two runs of the same scenario and seed give byte-identical files
(timing.csv aside).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.recorder import PLAN_COLUMNS, TRACE_COLUMNS, RunResult

Array = NDArray[np.float64]

CSV_FLOAT = "%.9g"  # float format of every CSV (fixed: byte-identical reruns)

INT_TRACE_COLUMNS = ("lane", "sumo_lane", "target_lane", "changing", "collisions",
                     "sumo_collisions", "n_tvs")


def trace_frame(trace: dict[str, Array]) -> Any:
    import pandas as pd

    frame = pd.DataFrame({name: trace[name] for name in TRACE_COLUMNS})
    for name in INT_TRACE_COLUMNS:
        frame[name] = frame[name].astype(int)
    return frame


def write_outputs(result: RunResult, out_dir: Path, *, write_trace: bool = True,
                  write_figures: bool = True) -> list[Path]:
    """trace.csv, plans.csv, metrics.csv, timing.csv and the figures, each atomically."""
    import pandas as pd

    from cosim.output import atomic_write_csv, make_output_dir

    out = make_output_dir(out_dir)
    written = []
    if write_trace:
        written.append(atomic_write_csv(out / "trace.csv", trace_frame(result.trace),
                                        float_format=CSV_FLOAT))
        plans = pd.DataFrame(result.plans, columns=list(PLAN_COLUMNS))
        written.append(atomic_write_csv(out / "plans.csv", plans, float_format=CSV_FLOAT))
    written.append(atomic_write_csv(out / "metrics.csv", pd.DataFrame([result.metrics]),
                                    float_format=CSV_FLOAT))
    written.append(atomic_write_csv(out / "timing.csv", pd.DataFrame([result.timing]),
                                    float_format=CSV_FLOAT))
    if write_figures:
        written += write_run_figures(result, out)
    return written


def write_run_figures(result: RunResult, out: Path) -> list[Path]:
    """trajectories.png (Fig. 16), tracking.png (Fig. 13-15), tau_sets.png (Fig. 10-12)."""
    from cosim.output import atomic_path
    from cosim.plots.run import global_trajectories

    tr = result.trace
    paths = []
    spans = [(lc.t0, lc.t0 + lc.tau) for lc in result.lane_changes]
    with atomic_path(out / "trajectories.png") as tmp:
        global_trajectories(tmp, tr["t_s"], tr["x_m"], tr["y_m"], result.tv_tracks, result.road,
                            highlight=[tv.id for tv in result.scenario.tvs], lane_changes=spans,
                            title=f"{result.scenario.name}: global trajectories")
    paths.append(out / "trajectories.png")
    sc = result.scenario
    if result.records:
        from cosim.control.tracking import TrackingRun
        from cosim.plots.tracking import plot_inputs, plot_states

        run = TrackingRun(sc.sv.plant, sc.sv.controller, result.road.mu,
                          tuple(result.records))
        paths.append(plot_states([run], out / "tracking.png",
                                 f"{sc.name}: tracking (cf. Fig. 13-15)"))
        paths.append(plot_inputs([run], out / "inputs.png", f"{sc.name}: inputs"))
    plan = result.first_plan
    if plan is not None:
        from cosim.plots.planning import planning_figure, tau_sets

        with atomic_path(out / "tau_sets.png") as tmp:
            tau_sets(tmp, plan, f"{sc.name}: tau sets of the plan at t = {plan.t:.2f} s "
                                "(cf. Fig. 10-12 b)")
        paths.append(out / "tau_sets.png")
        with atomic_path(out / "planning.png") as tmp:
            planning_figure(tmp, plan, result.road, sc.vehicle,
                            f"{sc.name}: plan at t = {plan.t:.2f} s (cf. Fig. 10-12)")
        paths.append(out / "planning.png")
    return paths
