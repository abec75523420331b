"""What one run writes: trace.csv, plans.csv, metrics.csv, timing.csv, the figures and,
with `[detectors] enabled`, detectors.csv, with `[ssm] enabled`, conflicts.csv (and with
a `[fleet]` too, fleet_conflicts.csv: cosim.run.encounters).

Every file is written atomically (cosim.output); the CSVs use one fixed float
format, so two runs of the same scenario and seed give byte-identical files
(timing.csv aside).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.driving.plans import PLAN_COLUMNS
from cosim.run.fleet import FLEET_COLUMNS, FleetResult
from cosim.run.recorder import TRACE_COLUMNS
from cosim.run.result import RunResult
from cosim.traffic.world import SV_ID

Array = NDArray[np.float64]

CSV_FLOAT = "%.9g"  # float format of every CSV (fixed: byte-identical reruns)

INT_TRACE_COLUMNS = ("lane", "sumo_lane", "target_lane", "changing", "collisions",
                     "sumo_collisions", "n_tvs", "track")


def trace_frame(trace: dict[str, Array], edges: Sequence[str] = ()) -> Any:
    """The trace as a table; the `edge` column (indices into `edges`) as SUMO's road ids."""
    import pandas as pd

    frame = pd.DataFrame({name: trace[name] for name in TRACE_COLUMNS})
    for name in INT_TRACE_COLUMNS:
        frame[name] = frame[name].astype(int)
    names = np.array([*edges, ""], dtype=object)  # index -1 (unknown): ""
    index = frame["edge"].to_numpy()
    frame["edge"] = names[np.where(np.isfinite(index), index, -1).astype(int)]
    return frame


def fleet_trace_frame(sv_frame: Any, fleet: FleetResult) -> Any:
    """trace.csv with a fleet: the SV's rows (`sv_frame`, `trace_frame`) and every
    automated vehicle's, a `vehicle_id` column, ordered by time, then id."""
    import pandas as pd

    frames = [sv_frame.assign(vehicle_id=SV_ID)]
    frames += [trace_frame(trace, edges).assign(vehicle_id=vid)
               for vid, trace, edges in fleet.traces]
    frame = pd.concat(frames, ignore_index=True)
    return frame.sort_values(["t_s", "vehicle_id"], kind="stable", ignore_index=True)


def fleet_plans_frame(sv_plans: Any, fleet: FleetResult) -> Any:
    """plans.csv with a fleet: the SV's rows and every automated vehicle's, a
    `vehicle_id` column, ordered by time, then id."""
    import pandas as pd

    frame = pd.concat([sv_plans.assign(vehicle_id=SV_ID),
                       pd.DataFrame(fleet.plans, columns=[*PLAN_COLUMNS, "vehicle_id"])],
                      ignore_index=True)
    return frame.sort_values(["t_s", "vehicle_id"], kind="stable", ignore_index=True)


def write_outputs(result: RunResult, out_dir: Path, *, write_trace: bool = True,
                  write_figures: bool = True, extra_files: Sequence[Path] = (),
                  figure_format: str | None = None) -> list[Path]:
    """trace.csv, plans.csv, metrics.csv, timing.csv, detectors.csv (with the run's
    detectors), conflicts.csv (with SUMO's SSM device) and the figures (in
    `figure_format`, default png), built in a hidden sibling folder and swapped in whole
    (cosim.output.staged_dir): `out_dir` holds either this run's complete result or,
    after an interrupt, exactly what it held before.
    `extra_files` (complete files, e.g. SUMO's fcd.xml) are copied in under their names."""
    import shutil

    import pandas as pd

    from cosim.output import atomic_write_csv, staged_dir

    written = []
    with staged_dir(out_dir) as out:
        if write_trace:
            frame = trace_frame(result.trace, result.edges)
            if result.fleet is not None:  # every vehicle's rows, a vehicle_id column
                frame = fleet_trace_frame(frame, result.fleet)
            written.append(atomic_write_csv(out / "trace.csv", frame, float_format=CSV_FLOAT))
            plans = pd.DataFrame(result.plans, columns=list(PLAN_COLUMNS))
            if result.fleet is not None:  # every vehicle's plans, a vehicle_id column
                plans = fleet_plans_frame(plans, result.fleet)
            written.append(atomic_write_csv(out / "plans.csv", plans, float_format=CSV_FLOAT))
        written.append(atomic_write_csv(out / "metrics.csv", pd.DataFrame([result.metrics]),
                                        float_format=CSV_FLOAT))
        written.append(atomic_write_csv(out / "timing.csv", pd.DataFrame([result.timing]),
                                        float_format=CSV_FLOAT))
        if result.fleet is not None:  # one row per automated vehicle (cosim.run.fleet)
            written.append(atomic_write_csv(out / "fleet.csv", pd.DataFrame(
                result.fleet.rows, columns=list(FLEET_COLUMNS)), float_format=CSV_FLOAT))
        if result.detectors is not None:  # SUMO's detectors ([detectors] enabled)
            written.append(atomic_write_csv(out / "detectors.csv", result.detectors,
                                            float_format=CSV_FLOAT))
        if result.conflicts is not None:  # SUMO's SSM device ([ssm] enabled)
            written.append(atomic_write_csv(out / "conflicts.csv", result.conflicts,
                                            float_format=CSV_FLOAT))
        if result.fleet_conflicts is not None:  # ours for the automated vehicles
            written.append(atomic_write_csv(out / "fleet_conflicts.csv",
                                            result.fleet_conflicts, float_format=CSV_FLOAT))
        for path in extra_files:
            written.append(Path(shutil.copyfile(path, out / Path(path).name)))
        if write_figures:
            fcd = next((Path(p) for p in extra_files if Path(p).name == "fcd.xml"), None)
            written += write_run_figures(result, out, figure_format, fcd=fcd)
    return [Path(out_dir) / p.name for p in written]


def tv_role(tv: Any) -> str:
    """A scripted TV's role for a legend: ahead / behind the SV at the start, its lane,
    and its scripted lane change (with what it broadcasts) or braking."""
    parts = [f"{'ahead' if tv.gap > 0 else 'behind'}, lane {tv.lane}"]
    lc = tv.lane_change
    if lc is not None:
        category = {"reference": "C3", "intention": "C2", "none": "C1"}.get(lc.broadcast, "")
        parts.append(f"to lane {lc.target_lane} at {lc.start:g} s ({category})")
    if tv.brake is not None:
        parts.append(f"brakes at {tv.brake.at:g} s")
    return ", ".join(parts)


def write_run_figures(result: RunResult, out: Path, fmt: str | None = None, *,
                      fcd: Path | None = None) -> list[Path]:
    """trajectories (Fig. 16), gaps (gap and TTC over time), tracking and inputs
    (Fig. 13-15), tau_sets and planning (Fig. 10-12), and with SUMO's floating-car data
    `fcd` (`cosim run --fcd`) the time-space diagram, in the format `fmt` (default png)."""
    from functools import partial

    from cosim import plots
    from cosim.plots.run import TrajectoryMarks, gap_history, road_trajectories
    from cosim.road.frame import StraightFrame
    from cosim.traffic.route_lanes import exit_lanes

    figure_path = partial(plots.figure_path, fmt=fmt)

    tr = result.trace
    sc = result.scenario
    spans = [(lc.t0, lc.t0 + lc.tau) for lc in result.lane_changes]
    rr = result.route_road
    # the SV's and the TVs' paths in road coordinates (s, d), as the planner sees them
    # (the scene is in them: trace.csv's s_m, d_m and the recorder's TV tracks)
    same = (rr is not None and isinstance(rr.frame, StraightFrame)
            and rr.frame.x0 == 0.0 and rr.frame.y0 == 0.0)
    view = "road coordinates (s, d" + (" = global x, y)" if same else ")")
    paths = [
        road_trajectories(figure_path(out, "trajectories"), tr["t_s"], tr["s_m"], tr["d_m"],
                          result.tv_tracks, result.road, TrajectoryMarks(
                              highlight=[tv.id for tv in sc.tvs],
                              roles={tv.id: tv_role(tv) for tv in sc.tvs},
                              lane_changes=spans,
                              requests=[float(p["t_s"]) for p in result.plans
                                        if p.get("trigger") in ("scripted", "decision")]),
                          title=f"{sc.name}: trajectories in {view}, dots every 1 s",
                          exits=exit_lanes(rr) if rr is not None else ()),
        gap_history(figure_path(out, "gaps"), tr["t_s"], tr["gap_min_m"], tr["leader_gap_m"],
                    tr["ttc_min_s"], lane_changes=spans,
                    title=f"{sc.name}: gaps and time-to-collision"),
    ]
    if rr is not None and rr.curved:  # the x-y map: SUMO's lanes, frame's borders, SV's path
        from cosim.plots.road import plot_road

        paths.append(plot_road(rr, figure_path(out, "road"), sv_path=(tr["x_m"], tr["y_m"])))
    if result.records:
        from cosim.control.tracking import TrackingRun
        from cosim.plots.tracking import plot_inputs, plot_states

        run = TrackingRun(sc.sv.plant, sc.sv.controller, result.road.mu,
                          tuple(result.records))
        paths.append(plot_states([run], figure_path(out, "tracking"),
                                 f"{sc.name}: tracking (cf. Fig. 13-15)"))
        paths.append(plot_inputs([run], figure_path(out, "inputs"), f"{sc.name}: inputs"))
    if fcd is not None and rr is not None:  # every vehicle along the route over time
        paths.append(time_space_figure(result, fcd, figure_path(out, "time_space")))
    plan = result.first_plan
    if plan is not None:
        from cosim.plots.planning import planning_figure, tau_sets

        paths.append(tau_sets(figure_path(out, "tau_sets"), plan,
                              f"{sc.name}: tau sets of the plan at t = {plan.t:.2f} s "
                              "(cf. Fig. 10-12 b)"))
        paths.append(planning_figure(figure_path(out, "planning"), plan, result.road,
                                     sc.vehicle,
                                     f"{sc.name}: plan at t = {plan.t:.2f} s (cf. Fig. 10-12)"))
    return paths


def time_space_figure(result: RunResult, fcd: Path, path: Path) -> Path:
    """The run's time-space diagram (cosim.plots.time_space) from its fcd.xml."""
    from cosim.plots.time_space import DRAW_EVERY, time_space
    from cosim.traffic.fcd import read_route_records
    from cosim.traffic.route_lanes import sv_tracks
    from cosim.traffic.world import SV_ID

    rr = result.route_road
    assert rr is not None
    records = read_route_records(fcd, rr, result.t_warmup, every=DRAW_EVERY)
    top = max(hi for _, hi in result.scenario.road.speed_bands)
    return time_space(path, records, [t.id for t in sv_tracks(rr)], SV_ID,
                      f"{result.scenario.name}: time-space diagram, every vehicle on the SV "
                      f"lanes every {DRAW_EVERY:g} s, coloured by speed", v_max=top)
