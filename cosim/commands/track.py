"""`cosim track`: follow one lane change without SUMO, MIMO against SISO, on the
two-track and/or the 2-DOF plant, and print Table 2's IAE beside the paper's.

The reference is the paper's case 5.1 (lane 0 -> 1, 80 -> 90 km/h, W = 3.75 m,
mu = 0.4, occupant p = 0.2, a 70 km/h leader 15 m ahead): planned by
`LaneChangePlanner` (`--source planner`, the default), or the eq. 2/4
polynomials with the paper's reported tau_opt = 6.25 s (`--source paper`), or
any `--tau-s`.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from cosim.control.closed_loop import YAW_MOMENT_SHARE
from cosim.control.tracking import IAE_COLUMNS, PAPER_TABLE2, TrackingRun, run_tracking
from cosim.errors import InputError
from cosim.params import ControllerGains, RoadParams, VehicleParams, kmh
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.chassis import ChassisParams

PAPER_TAU = 6.25  # s, the paper's tau_opt of case 5.1
HEADERS = {
    "vx": "Vx (m/s s)", "ye": "ye (m s)", "phi_e_deg": "phi_e (deg s)",
    "delta_f_deg": "delta_f (deg s)", "fx_kn": "Fx (kN s)",
}


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "track",
        help="tracking run of one lane change without SUMO: MIMO vs SISO, Table 2's IAE",
        description="Follow the case 5.1 lane change with the MIMO triple-step controller "
        "and the SISO baseline on the chosen plant(s); print the IAE of Table 2 beside the "
        "paper's and write Fig. 13-15 style plots.",
    )
    parser.add_argument("--plant", choices=("twotrack", "bicycle", "both"), default="both",
                        help="vehicle model(s) (default: both)")
    parser.add_argument("--source", choices=("planner", "paper"), default="planner",
                        help="reference: our planner's choice, or the paper's tau = 6.25 s")
    parser.add_argument("--tau-s", type=float, default=None, help="force this tau (s)")
    parser.add_argument("--mu", type=float, default=0.4, help="road friction (default 0.4)")
    parser.add_argument("--duration-s", type=float, default=10.0, help="run length (s)")
    parser.add_argument("--out", type=Path, default=Path("results/track"),
                        help="folder for the figures (default results/track)")
    parser.add_argument("--no-plot", action="store_true", help="write no figures")
    parser.add_argument("--cornering-scale", type=float, default=1.0,
                        help="two-track tyres' true cornering stiffness / Table 1's "
                        "(model mismatch; default 1)")
    parser.add_argument("--paper-law", action="store_true",
                        help="no yaw-moment limit: the MIMO law exactly as printed")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def case_5_1_reference(
    source: str, tau: float | None, mu: float
) -> tuple[LaneChangeTrajectory, str]:
    """The case 5.1 lane change and a sentence saying where its tau came from."""
    road = RoadParams(mu=mu)
    vx0 = kmh(80.0)
    y0 = road.lane_center(0)
    if tau is None and source == "planner":
        try:
            from cosim.planning.planner import LaneChangePlanner, SVPlanState
        except ImportError:
            source = "paper"
        else:
            from cosim.params import PlannerConfig
            from cosim.traffic.v2v import V2VMessage

            vehicle = VehicleParams()
            leader = V2VMessage(
                vehicle_id="PVC", t=0.0, x=15.0, y=y0, heading=0.0, speed=kmh(70.0),
                accel=0.0, lane=0, lateral_speed=0.0, length=vehicle.length,
                width=vehicle.width, intention=0,
            )
            sv = SVPlanState(x=0.0, y=y0, heading=0.0, vx=vx0, ax=0.0, vy=0.0, ay=0.0, lane=0)
            plan = LaneChangePlanner(vehicle, road, PlannerConfig()).plan(
                0.0, sv, 1, [leader], 0.2
            )
            if plan.trajectory is not None:
                return plan.trajectory, (
                    f"planner: tau_min {plan.tau_min:.2f} s, tau_opt {plan.tau_opt:.2f} s, "
                    f"chosen tau {plan.tau:.2f} s (paper: 2.75, 6.25)"
                )
            source = "paper"
    if tau is None:
        tau = PAPER_TAU
        origin = f"eq. 2/4 with the paper's tau_opt = {tau:g} s"
    else:
        origin = f"eq. 2/4 with tau = {tau:g} s (--tau-s)"
    if not 0.5 <= tau <= 30.0:
        raise InputError("--tau-s", "tau", tau, "a duration in [0.5, 30] s")
    ref = LaneChangeTrajectory(
        t0=0.0, tau=tau, x0=0.0, y0=y0, vx0=vx0, vxf=road.target_speed(0, 1),
        width=road.lane_width,
    )
    return ref, origin


def table(runs: list[TrackingRun]) -> str:
    """Table 2 layout: paper rows, then ours."""
    cols = [HEADERS[c] for c in IAE_COLUMNS]
    first = 22
    lines = ["IAE".ljust(first) + "  ".join(c.rjust(15) for c in cols)]
    for ctrl in ("mimo", "siso"):
        vals = PAPER_TABLE2[ctrl]
        lines.append(f"paper {ctrl.upper()} (veDYNA)".ljust(first)
                     + "  ".join(f"{vals[c]:15.3f}" for c in IAE_COLUMNS))
    for r in runs:
        vals = r.iae()
        lines.append(f"ours {r.controller.upper()}, {r.plant}".ljust(first)
                     + "  ".join(f"{vals[c]:15.4f}" for c in IAE_COLUMNS))
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if not 0.0 < args.mu <= 1.5 or not math.isfinite(args.mu):
        raise InputError("--mu", "mu", args.mu, "road friction in (0, 1.5]")
    if not 0.5 <= args.duration_s <= 120.0:
        raise InputError("--duration-s", "duration", args.duration_s, "in [0.5, 120] s")
    if not 0.2 <= args.cornering_scale <= 2.0:
        raise InputError("--cornering-scale", "cornering_scale", args.cornering_scale,
                         "in [0.2, 2]")
    chassis = ChassisParams(cornering_scale=args.cornering_scale)
    ref, origin = case_5_1_reference(args.source, args.tau_s, args.mu)
    plants = ("twotrack", "bicycle") if args.plant == "both" else (args.plant,)
    gains, vehicle = ControllerGains(), VehicleParams()
    share = None if args.paper_law else YAW_MOMENT_SHARE
    runs = [
        run_tracking(p, c, ref, mu=args.mu, duration=args.duration_s, vehicle=vehicle,
                     gains=gains, chassis=chassis, yaw_moment_share=share)
        for p in plants for c in ("mimo", "siso")
    ]
    verdicts: dict[str, bool] = {}
    for p in plants:
        mimo, siso = (r.iae() for r in runs if r.plant == p)
        verdicts[p] = mimo["phi_e_deg"] < siso["phi_e_deg"]
    figures: list[str] = []
    if not args.no_plot:
        from cosim.plots.tracking import plot_inputs, plot_states

        title = f"case 5.1 lane change, mu {args.mu:g}, tau {ref.tau:.2f} s"
        figures = [
            str(plot_states(runs, args.out / "tracking_states.png", title)),
            str(plot_inputs(runs, args.out / "tracking_inputs.png", title)),
        ]
    if args.json:
        out: dict[str, Any] = {
            "reference": {"tau_s": ref.tau, "vx0_mps": ref.vx0, "vxf_mps": ref.vxf,
                          "width_m": ref.width, "mu": args.mu, "origin": origin},
            "cornering_scale": args.cornering_scale,
            "yaw_moment_share": None if args.paper_law else YAW_MOMENT_SHARE,
            "duration_s": args.duration_s,
            "paper": PAPER_TABLE2,
            "runs": [{"plant": r.plant, "controller": r.controller, "iae": r.iae()}
                     for r in runs],
            "mimo_beats_siso_on_heading": verdicts,
            "figures": figures,
        }
        print(json.dumps(out))
        return 0
    law = ("MIMO law as printed (no yaw-moment limit)" if args.paper_law
           else f"MIMO yaw moment limited to {YAW_MOMENT_SHARE:g} mu M g ls")
    print(f"case 5.1 lane change: lane 0 -> 1, 80 -> 90 km/h, W = {ref.width:g} m, "
          f"mu = {args.mu:g}; {origin}; {args.duration_s:g} s; {law}; two-track cornering "
          f"stiffness x {args.cornering_scale:g}")
    print(table(runs))
    for p, ok in verdicts.items():
        print(f"MIMO beats SISO on heading error ({p}): {'yes' if ok else 'NO'}")
    for f in figures:
        print(f"figure: {f}")
    return 0
