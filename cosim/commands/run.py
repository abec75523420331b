"""`cosim run SCENARIO.toml`: one co-simulation run, outputs under ./results/<scenario>/
(a flag that changes the scenario adds `--<flag>_<value>` to the folder's name).

The scenario is loaded and validated first (InputError -> exit 2, nothing
written); flags override the file's [sv] plant / controller and [scenario] seed.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from cosim.commands import add_figure_format, compile_first, flag_overrides
from cosim.driving.registry import PLANNED
from cosim.errors import InputError


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "run",
        help="run one scenario: our SV (or the SUMO baseline) in SUMO traffic",
        description="Run one scenario and write trace.csv, plans.csv, metrics.csv, "
        "timing.csv and PNG figures (default folder ./results/<scenario name>/, plus "
        "--controller_X, --plant_X, --policy_X, --seed_N for each flag that changes the "
        "scenario's value).",
    )
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default: ./results/<scenario name>"
                        "[--<flag>_<value>...])")
    parser.add_argument("--plant", choices=("twotrack", "bicycle"), default=None,
                        help="vehicle model (default: the scenario's)")
    parser.add_argument("--controller", choices=("mimo", "siso", "sumo"), default=None,
                        help="mimo / siso: our planner and controller; sumo: SUMO drives the SV")
    parser.add_argument("--policy", choices=PLANNED, default=None,
                        help="lane-change policy (default: the scenario's [planner] policy)")
    parser.add_argument("--gui", action="store_true",
                        help="show the run in sumo-gui (traci), following the SV, in real "
                        "time; the window stays open until closed (needs a display)")
    parser.add_argument("--gui-speed", type=float, default=None, metavar="FACTOR",
                        help="with --gui: simulated seconds per wall second (default 1: "
                        "real time; 0.5: slow motion)")
    parser.add_argument("--gui-quit", action="store_true",
                        help="with --gui: close sumo-gui when the run ends")
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: scenario's)")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures")
    parser.add_argument("--fcd", action="store_true",
                        help="also write SUMO's floating-car data (--fcd-output) of the run "
                        "as fcd.xml into the output folder, and draw its time-space diagram "
                        "(time_space.png)")
    add_figure_format(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from cosim.commands import RESULTS, overridden, variant_folder
    from cosim.output import check_output_dir
    from cosim.run.loop import run_scenario
    from cosim.run.route_notes import route_notes
    from cosim.scenario import load_scenario
    from cosim.traffic import gui as sumo_gui
    from cosim.vehicle.bicycle import warn_near_critical_speed

    check_flags(args)
    settings = sumo_gui.GuiSettings(speed=1.0 if args.gui_speed is None else args.gui_speed,
                                    keep_open=not args.gui_quit)
    if args.gui:
        sumo_gui.check_gui(settings)  # no display: one line now, not a traceback later
    base = load_scenario(args.scenario)
    if args.plant is not None and (args.controller or base.sv.controller) == "sumo":
        why = ("--controller sumo" if args.controller else
               f"the scenario's sv.controller = 'sumo' ({args.scenario})")
        raise InputError(SOURCE, "--plant", args.plant,
                         f"no --plant with {why}: SUMO drives the SV, no plant of ours runs")
    scenario = flag_overrides(base, {
        "--plant": ("plant", args.plant), "--controller": ("controller", args.controller),
        "--policy": ("policy", args.policy), "--seed": ("seed", args.seed)})
    warn_near_critical_speed(scenario)  # one line on stderr if the SV may get near it
    for note in route_notes(scenario):  # signals the SV does not obey
        print(f"cosim run: {scenario.name}: {note}", file=sys.stderr)
    out = args.out if args.out is not None else variant_folder(RESULTS, scenario.name, {
        "controller": overridden(base.sv.controller, scenario.sv.controller),
        "plant": overridden(base.sv.plant, scenario.sv.plant),
        "policy": overridden(base.planner.policy, scenario.planner.policy),
        "seed": overridden(base.seed, scenario.seed)})
    check_output_dir(out, whole=True)  # a bad --out is an input error now, not after the run
    if scenario.sv.controller != "sumo":
        compile_first()  # before the progress bar, which then counts steps only
    try:
        metrics = run_scenario(
            scenario, out, write_trace=True, write_figures=not args.no_figures,
            progress=True, gui=settings if args.gui else False, fcd=args.fcd,
            figure_format=args.figure_format,
        )
    except Exception as exc:
        if args.gui and type(exc).__name__ == "FatalTraCIError":  # its user closed it
            print("cosim run: stopped: the sumo-gui window was closed before the run ended",
                  file=sys.stderr)
            return 130
        if args.gui and type(exc).__name__ == "TraCIException" and "finished" in str(exc):
            # sumo-gui ended before traci reached it: it could not open its window
            raise InputError(f"{SOURCE} --gui", "sumo-gui", "ended at start",
                             "a display sumo-gui can open (DISPLAY "
                             f"{os.environ.get('DISPLAY', '')!r}); run without --gui, or "
                             "under xvfb-run") from None
        raise
    keys = ("lane_changes", "collisions", "sumo_collisions", "min_gap_m", "min_ttc_s",
            "tau_first_s", "iae_ye_m_s")
    summary = ", ".join(f"{k} = {metrics[k]:.4g}" if isinstance(metrics[k], float)
                        else f"{k} = {metrics[k]}" for k in keys if k in metrics)
    print(f"{scenario.name}: {summary}")
    top = max(scenario.sv.speed, scenario.sv.desired_speed or 0.0,
              *(hi for _, hi in scenario.road.speed_bands))
    if metrics["curve_speed_mps"] < top:
        print(f"cosim run: {scenario.name}: the SV drove at most "
              f"{metrics['curve_speed_mps'] * 3.6:.1f} km/h, the curve speed of the route's "
              f"tightest curve at sv.curve_lat_accel_mps2 = {scenario.sv.curve_lat_accel:g} "
              f"on mu {scenario.road.mu:g} (its speeds and bands above it were capped)",
              file=sys.stderr)
    asked = min(scenario.sv.speed, metrics["curve_speed_mps"])
    # (1 %: in a curve the body's speed differs from the lane's by the frame's stretch)
    if metrics["start_speed_mps"] < 0.99 * asked:
        print(f"cosim run: {scenario.name}: the SV started at "
              f"{metrics['start_speed_mps'] * 3.6:.1f} km/h, not {asked * 3.6:.4g}: "
              "the random traffic ahead was too close and slow to brake for from that speed "
              "(SUMO's departSpeed rule)", file=sys.stderr)
    if metrics["vehicles_inserted"] < metrics["vehicles_asked"]:
        print(f"cosim run: {scenario.name}: [traffic] density_veh_per_km_lane = "
              f"{scenario.traffic.density:g}: SUMO inserted {metrics['vehicles_inserted']} of "
              f"the {metrics['vehicles_asked']} vehicles asked for at t = 0 (no room at its "
              "minimum gap); the run went on with fewer", file=sys.stderr)
    if metrics.get("stopped_by_collision"):
        print(f"cosim run: {scenario.name}: collision with {metrics['collision_with']} at "
              f"t = {metrics['collision_t_s']:.2f} s ({'SV' if metrics['collisions_sv'] else 'TV'}"
              " at fault): the run stopped there (outputs written up to it; "
              "[scenario] on_collision = \"continue\" runs on)", file=sys.stderr)
    note = quiet_sv_note(scenario, metrics)
    if note:
        print(note)
    print(f"wrote {out}", file=sys.stderr)
    sumo_gui.wait_for_windows()
    return 0


SOURCE = "command line"


def check_flags(args: argparse.Namespace) -> None:
    """Flags that mean nothing without another one are refused, naming both."""
    if not args.gui:
        for flag, given in (("--gui-speed", args.gui_speed is not None),
                            ("--gui-quit", args.gui_quit)):
            if given:
                raise InputError(SOURCE, flag, args.gui_speed if flag == "--gui-speed" else
                                 True, f"only with --gui ({flag} sets how sumo-gui shows the "
                                 "run; without --gui there is no window)")


def quiet_sv_note(scenario: Any, metrics: dict[str, Any]) -> str:
    """A line when the SUMO-native SV never changed lanes although the decision rule
    was on: SUMO's own lane-change model found no reason (or no gap) to."""
    if (scenario.sv.controller == "sumo" and scenario.sv.decision
            and not metrics.get("lane_changes")):
        return (f"note: SUMO's own model drove the SV and changed no lane in "
                f"{metrics.get('duration_s', scenario.duration):g} s (its lane-change "
                "model saw no advantage worth a change, or no gap)")
    return ""
