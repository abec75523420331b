"""`cosim track`: follow one lane change without SUMO, MIMO against SISO, on the
two-track and/or the 2-DOF plant, and print Table 2's IAE beside the paper's.

Cases (paper Section 5; SUMO lane indices):
5.1 lane 0 -> 1, 80 -> 90 km/h, mu 0.4, p 0.2, a 70 km/h leader 15 m ahead, tau_opt 6.25 s;
5.2 lane 1 -> 0, 110 -> 90 km/h, mu 0.6, tau_opt 5.56 s;
5.3 lane 1 -> 2, 105 -> 110 km/h, mu 0.8, tau_opt 7.35 s.
Table 2 is for the single lane change of case 5.1 (the default). Case 5.1's
reference comes from `LaneChangePlanner` with the [planner] settings of
scenarios/paper_case1_overtaking.toml, as `cosim plan` reads them (`--source
planner`, the default) or
from eq. 2/4 with the paper's tau_opt (`--source paper`); cases 5.2 and 5.3 use
the paper's tau_opt (their traffic is the co-simulation's business); `--tau-s`
forces any tau. `--case all` runs the three, as the paper's Fig. 13-15 show them.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cosim.commands import RESULTS, add_figure_format, flag_type, variant_folder
from cosim.control.closed_loop import CONTROLLERS, PLANTS, YAW_MOMENT_SHARE, LoopConfig
from cosim.control.tracking import IAE_COLUMNS, PAPER_TABLE2, TrackingRun, run_tracking
from cosim.errors import InputError
from cosim.params import VEHICLE_PRESETS, ControllerGains, RoadParams, VehicleParams, kmh
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.study.spec import MU
from cosim.vehicle.bicycle import critical_speed, handling, understeer_gradient
from cosim.vehicle.chassis import chassis_for

HEADERS = {
    "vx": "Vx (m/s s)", "ye": "ye (m s)", "phi_e_deg": "phi_e (deg s)",
    "delta_f_deg": "delta_f (deg s)", "fx_kn": "Fx (kN s)",
}


@dataclass(frozen=True)
class PaperCase:
    """One of the paper's lane changes (Section 5)."""

    name: str
    origin_lane: int  # SUMO index
    target_lane: int  # SUMO index
    vx0_kmh: float  # km/h
    mu: float  # -
    occupant: float  # -, p
    tau_opt: float  # s, the paper's reported choice


# Case 5.1 as a scenario file (the planner's settings `cosim plan` uses for it)
CASE_51_SCENARIO = "scenarios/paper_case1_overtaking.toml"
CASES = {
    "5.1": PaperCase("5.1", 0, 1, 80.0, 0.4, 0.2, 6.25),
    "5.2": PaperCase("5.2", 1, 0, 110.0, 0.6, 0.5, 5.56),
    "5.3": PaperCase("5.3", 1, 2, 105.0, 0.8, 0.8, 7.35),
}


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "track",
        help="tracking run of one lane change without SUMO: MIMO vs SISO, Table 2's IAE",
        description="Follow a paper lane change (default case 5.1, Table 2's) with the MIMO "
        "triple-step controller and the SISO baseline on the chosen plant(s); print the IAE "
        "of Table 2 beside the paper's and write Fig. 13-15 style plots.",
    )
    parser.add_argument("--case", choices=(*CASES, "all"), default="5.1",
                        help="the paper's case (default 5.1, the one of Table 2)")
    parser.add_argument("--plant", choices=(*PLANTS, "both"), default="both",
                        help="vehicle model(s) (default: both)")
    parser.add_argument("--source", choices=("planner", "paper"), default=None,
                        help="case 5.1's reference: our planner's tau (default for 5.1 "
                        "alone), or the paper's tau_opt (default for --case all: one "
                        "source for every case)")
    parser.add_argument("--tau-s", type=float, default=None, help="force this tau (s)")
    parser.add_argument("--mu", type=flag_type(MU), default=None,
                        help=f"road friction, {MU.allowed()} as in scenario files "
                        "(default: the case's, 0.4 / 0.6 / 0.8)")
    parser.add_argument("--duration-s", type=float, default=10.0, help="run length (s)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the figures (default ./results/track, plus "
                        "--vehicle_X, --mu_X, --tau_X, --source_X, --cornering_X, --law_paper "
                        "for each such flag given)")
    parser.add_argument("--no-plot", action="store_true", help="write no figures")
    parser.add_argument("--cornering-scale", type=float, default=1.0,
                        help="two-track tyres' true cornering stiffness / Table 1's "
                        "(model mismatch; default 1)")
    parser.add_argument("--vehicle", choices=tuple(VEHICLE_PRESETS), default="table1",
                        help="the car (default: Table 1's; CommonRoad's vehicle1/2/3)")
    parser.add_argument("--paper-law", action="store_true",
                        help="no yaw-moment limit and no low-speed form of eq. 28's kx1: "
                        "the laws exactly as printed")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_figure_format(parser)
    parser.set_defaults(func=run)


def _planned(case: PaperCase, road: RoadParams) -> tuple[LaneChangeTrajectory, str] | None:
    """Case 5.1 through LaneChangePlanner (None if the planner is missing or keeps lane)."""
    try:
        from cosim.planning.planner import LaneChangePlanner, SVPlanState
    except ImportError:
        return None
    from cosim.traffic.v2v import V2VMessage

    vehicle = VehicleParams()
    y0 = road.lane_center(case.origin_lane)
    leader = V2VMessage(
        vehicle_id="PVC", t=0.0, x=15.0, y=y0, heading=0.0, speed=kmh(70.0), accel=0.0,
        lane=case.origin_lane, lateral_speed=0.0, length=vehicle.length, width=vehicle.width,
        intention=0,
    )
    sv = SVPlanState(x=0.0, y=y0, heading=0.0, vx=kmh(case.vx0_kmh), ax=0.0, vy=0.0, ay=0.0,
                     lane=case.origin_lane)
    plan = LaneChangePlanner(vehicle, road, case_planner()).plan(
        0.0, sv, case.target_lane, [leader], case.occupant
    )
    if plan.trajectory is None or plan.tau is None:
        return None
    return plan.trajectory, (
        f"planner ([planner] of {CASE_51_SCENARIO}): tau_min {plan.tau_min:.2f} s, "
        f"tau_opt {plan.tau_opt:.2f} s, chosen tau {plan.tau:.2f} s (paper: 2.75, 6.25)"
    )


def case_planner() -> Any:
    """Case 5.1's planner configuration: the [planner] table of its scenario file, the
    one `cosim plan` reads for the same lane change, so that both choose the same tau."""
    from cosim.scenario import load_scenario, project_root

    return load_scenario(project_root() / CASE_51_SCENARIO).planner


def case_reference(
    case: PaperCase, source: str, tau: float | None, mu: float
) -> tuple[LaneChangeTrajectory, str]:
    """The case's lane change and a sentence saying where its tau came from."""
    road = RoadParams(mu=mu)
    if tau is None and source == "planner" and case.name == "5.1":
        planned = _planned(case, road)
        if planned is not None:
            return planned
    if tau is None:
        tau = case.tau_opt
        origin = f"eq. 2/4 with the paper's tau_opt = {tau:g} s"
    else:
        origin = f"eq. 2/4 with tau = {tau:g} s (--tau-s)"
    if not 0.5 <= tau <= 30.0:
        raise InputError("--tau-s", "tau", tau, "a duration in [0.5, 30] s")
    y0 = road.lane_center(case.origin_lane)
    ref = LaneChangeTrajectory(
        t0=0.0, tau=tau, x0=0.0, y0=y0, vx0=kmh(case.vx0_kmh),
        vxf=road.target_speed(case.origin_lane, case.target_lane),
        width=road.lane_center(case.target_lane) - y0,
    )
    return ref, origin


def table(runs: list[TrackingRun], with_paper: bool) -> str:
    """Table 2 layout: paper rows (case 5.1 only), then ours."""
    cols = [HEADERS[c] for c in IAE_COLUMNS]
    first = 22
    lines = ["IAE".ljust(first) + "  ".join(c.rjust(15) for c in cols)]
    if with_paper:
        for ctrl in CONTROLLERS:
            vals = PAPER_TABLE2[ctrl]
            lines.append(f"paper {ctrl.upper()} (veDYNA)".ljust(first)
                         + "  ".join(f"{vals[c]:15.3f}" for c in IAE_COLUMNS))
    for r in runs:
        vals = r.iae()
        lines.append(f"ours {r.controller.upper()}, {r.plant}".ljust(first)
                     + "  ".join(f"{vals[c]:15.4f}" for c in IAE_COLUMNS))
    return "\n".join(lines)


def source_of(case: str, source: str | None) -> str:
    """Where the references' tau comes from: one source for all cases shown together
    (the planner plans case 5.1 only; 5.2 and 5.3 take the paper's tau_opt)."""
    if source is None:
        return "planner" if case == "5.1" else "paper"
    if source == "planner" and case != "5.1":
        raise InputError("command line", "--source", source,
                         "'paper' with --case 5.2, 5.3 or all (the planner plans case 5.1 "
                         "only, and one table must not mix the planner's tau with the "
                         "paper's)")
    return source


def default_folder(args: argparse.Namespace) -> Path:
    """./results/track, with a part per flag that changes the car, the road or the
    reference (the figures of other settings never overwrite the default's)."""
    return variant_folder(RESULTS, "track", {
        "vehicle": None if args.vehicle == "table1" else args.vehicle, "mu": args.mu,
        "tau": args.tau_s, "source": args.source,
        "cornering": None if args.cornering_scale == 1.0 else args.cornering_scale,
        "law": "paper" if args.paper_law else None})


def _check(args: argparse.Namespace) -> None:
    """InputError for a run length or a cornering scale out of range."""
    if not 0.5 <= args.duration_s <= 120.0:
        raise InputError("--duration-s", "duration", args.duration_s, "in [0.5, 120] s")
    if not 0.2 <= args.cornering_scale <= 2.0:
        raise InputError("--cornering-scale", "cornering_scale", args.cornering_scale,
                         "in [0.2, 2]")


def _track_case(args: argparse.Namespace, case: PaperCase, source: str,
                vehicle: VehicleParams) -> dict[str, Any]:
    """One case: its reference, the MIMO and SISO runs on each plant asked for, and
    whether MIMO beats SISO on the heading error on each."""
    chassis = dataclasses.replace(chassis_for(vehicle), cornering_scale=args.cornering_scale)
    share = None if args.paper_law else YAW_MOMENT_SHARE
    plants = PLANTS if args.plant == "both" else (args.plant,)
    mu = case.mu if args.mu is None else args.mu
    ref, origin = case_reference(case, source, args.tau_s, mu)
    runs = [
        run_tracking(LoopConfig(p, c, yaw_moment_share=share, low_speed_gain=not args.paper_law),
                     ref, mu=mu, duration=args.duration_s, vehicle=vehicle,
                     gains=ControllerGains(), chassis=chassis)
        for p in plants for c in CONTROLLERS
    ]
    verdicts = {}
    for p in plants:
        mimo, siso = (r.iae() for r in runs if r.plant == p)
        verdicts[p] = mimo["phi_e_deg"] < siso["phi_e_deg"]
    return {"case": case, "mu": mu, "ref": ref, "origin": origin, "runs": runs,
            "verdicts": verdicts}


def _figures(args: argparse.Namespace, out: Path, res: dict[str, Any], one_case: bool
             ) -> list[str]:
    """Fig. 13-15 style states and inputs of one case's runs."""
    from cosim.plots import figure_path
    from cosim.plots.tracking import plot_inputs, plot_states

    case, runs = res["case"], res["runs"]
    title = f"case {case.name} lane change, mu {res['mu']:g}, tau {res['ref'].tau:.2f} s"
    suffix = "" if one_case else f"_{case.name}"
    fmt = args.figure_format
    return [
        str(plot_states(runs, figure_path(out, f"tracking_states{suffix}", fmt), title)),
        str(plot_inputs(runs, figure_path(out, f"tracking_inputs{suffix}", fmt), title)),
    ]


def _json(args: argparse.Namespace, source: str, vehicle: VehicleParams,
          results: list[dict[str, Any]], figures: list[str]) -> dict[str, Any]:
    """The --json answer."""
    vc = critical_speed(vehicle)
    return {
        "cases": [{
            "case": res["case"].name,
            "reference": {"tau_s": res["ref"].tau, "vx0_mps": res["ref"].vx0,
                          "vxf_mps": res["ref"].vxf, "width_m": res["ref"].width,
                          "mu": res["mu"], "origin": res["origin"]},
            "runs": [{"plant": r.plant, "controller": r.controller, "iae": r.iae()}
                     for r in res["runs"]],
            "mimo_beats_siso_on_heading": res["verdicts"],
        } for res in results],
        "source": source,
        "duration_s": args.duration_s,
        "cornering_scale": args.cornering_scale,
        "vehicle": {
            "preset": vehicle.preset,
            "understeer_gradient_rad_per_mps2": understeer_gradient(vehicle),
            "critical_speed_kmh": None if vc is None else vc * 3.6,
        },
        "yaw_moment_share": None if args.paper_law else YAW_MOMENT_SHARE,
        "paper_table2_case_5_1": PAPER_TABLE2,
        "figures": figures,
    }


def _print(args: argparse.Namespace, vehicle: VehicleParams, results: list[dict[str, Any]],
           figures: list[str]) -> None:
    """The tables and verdicts as text."""
    law = ("MIMO law as printed (no yaw-moment limit)" if args.paper_law
           else f"MIMO yaw moment limited to {YAW_MOMENT_SHARE:g} mu M g ls")
    print(f"{law}; two-track cornering stiffness x {args.cornering_scale:g}; "
          f"{args.duration_s:g} s runs")
    print(f"car {vehicle.preset}: {handling(vehicle)}")
    for res in results:
        case, ref = res["case"], res["ref"]
        print()
        print(f"case {case.name}: lane {case.origin_lane} -> {case.target_lane}, "
              f"{ref.vx0 * 3.6:.0f} -> {ref.vxf * 3.6:.0f} km/h, W = {ref.width:g} m, "
              f"mu = {res['mu']:g}; {res['origin']}")
        print(table(res["runs"], with_paper=case.name == "5.1"))
        for p, ok in res["verdicts"].items():
            print(f"MIMO beats SISO on heading error ({p}): {'yes' if ok else 'NO'}")
    for f in figures:
        print(f"figure: {f}")


def run(args: argparse.Namespace) -> int:
    source = source_of(args.case, args.source)
    _check(args)
    out = args.out if args.out is not None else default_folder(args)
    if not args.no_plot:
        from cosim.output import check_output_dir

        check_output_dir(out)  # a bad --out now, not after the runs
    vehicle = VEHICLE_PRESETS[args.vehicle]
    cases = list(CASES.values()) if args.case == "all" else [CASES[args.case]]
    results: list[dict[str, Any]] = []
    figures: list[str] = []
    for case in cases:
        res = _track_case(args, case, source, vehicle)
        if not args.no_plot:
            figures += _figures(args, out, res, len(cases) == 1)
        results.append(res)
    if args.json:
        print(json.dumps(_json(args, source, vehicle, results, figures)))
    else:
        _print(args, vehicle, results, figures)
    return 0
