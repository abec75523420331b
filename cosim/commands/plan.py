"""`cosim plan SCENARIO.toml`: the planner's verdict at the scenario's planning instant.

Builds the situation at the SV's first scripted lane-change request without SUMO
(cosim.planning.situation: y_right = 0, scripted TVs where their scripts put
them), plans, and prints the stable set, the collision-free set (a union of
intervals), omega, tau_opt, the chosen tau and why every other tau was rejected.
Draws the paper's Fig. 10-12 style picture (cluster, tau sets, rectangles) unless
--no-plot. With --json, one JSON object instead of the text.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from cosim.commands import add_figure_format
from cosim.errors import InputError
from cosim.params import PlannerConfig
from cosim.planning.collision import warm_up
from cosim.planning.planner import LaneChangePlanner, Plan, Rejection
from cosim.planning.situation import Situation, situation


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "plan",
        help="plan the scenario's first lane change (no SUMO): tau sets, tau_opt, reasons",
        description="Plan the SV's first scripted lane change of a scenario at its request "
        "time, without SUMO, and print the stable set, the collision-free set, tau_opt and "
        "the reason for every rejected tau; draw Fig. 10-12 style pictures.",
    )
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--out", type=Path, default=Path("results/plan"),
                        help="folder for the figure (default ./results/plan)")
    parser.add_argument("--no-plot", action="store_true", help="draw no figure")
    parser.add_argument("--collision-test", choices=("exact", "col"), default=None,
                        help="override the scenario's [planner] collision_test")
    parser.add_argument("--envelope", choices=("inverse_dynamics", "kinematic", "paper_maps"),
                        default=None, help="override the scenario's [planner] envelope")
    add_figure_format(parser)
    parser.set_defaults(func=run)


COLLISION_TESTS = {"exact": "exact collision test (separating axes)",
                   "col": "paper's CoL collision test (corners at the samples)"}


def figure_stem(name: str, cfg: PlannerConfig) -> str:
    """The figure's name: the scenario's, plus the collision test and a non-default
    envelope, so that planning one scenario two ways keeps both figures."""
    stem = f"{name}_{cfg.collision_test}"
    return stem if cfg.envelope == PlannerConfig.envelope else f"{stem}_{cfg.envelope}"


def describe_method(cfg: PlannerConfig) -> str:
    """Which collision test and envelope made the plan, for the figure's title."""
    text = COLLISION_TESTS.get(cfg.collision_test, cfg.collision_test)
    return text if cfg.envelope == PlannerConfig.envelope else f"{text}, {cfg.envelope} envelope"


def rejection_ranges(rejections: list[Rejection]) -> list[dict[str, Any]]:
    """Consecutive rejected taus with the same reason and TV, merged into ranges."""
    out: list[dict[str, Any]] = []
    for r in rejections:
        last = out[-1] if out else None
        if last and last["reason"] == r.reason and last["vehicle_id"] == r.vehicle_id:
            last["tau_hi"] = r.tau
            last["count"] += 1
            if r.time is not None:
                last["t_lo"] = min(last["t_lo"], r.time)
                last["t_hi"] = max(last["t_hi"], r.time)
            continue
        out.append({"reason": r.reason, "vehicle_id": r.vehicle_id, "tau_lo": r.tau,
                    "tau_hi": r.tau, "count": 1, "t_lo": r.time, "t_hi": r.time})
    return out


def _intervals(iv: list[tuple[float, float]]) -> str:
    return " U ".join(f"[{a:.2f}, {b:.2f}]" for a, b in iv) or "empty"


def report(name: str, plan: Plan, startup_s: float, map_build_s: float = 0.0) -> str:
    lines = [
        f"{name}: lane {plan.origin_lane} -> {plan.target_lane} at t = {plan.t:g} s, "
        f"target speed {plan.vxf * 3.6:.1f} km/h",
        "TVs: " + (", ".join(f"{k} {v}" for k, v in plan.categories.items()) or "none"),
        f"stable set      tau_min = {plan.tau_min:.3f} s, tau_max = {plan.tau_max:.2f} s: "
        f"{_intervals(plan.stable_intervals)}",
        f"collision-free  {_intervals(plan.collision_free_intervals)}",
        f"omega = {plan.omega:.3f}, tau_opt (eq. 13) = {plan.tau_opt:.3f} s",
        f"chosen tau      {plan.tau:.2f} s" if plan.tau is not None
        else "chosen          none: keep the lane",
        f"planning time   {plan.planning_time_s * 1e3:.2f} ms (the planner's own, as "
        f"`cosim bench planner` measures it)",
        f"map build       {map_build_s:.2f} s (the envelope's tau_min map of this lane "
        f"change, the speeds it reads: once per process, on the planner's first call)",
        f"start-up        {startup_s:.2f} s (numba: load, or the first time compile, the "
        f"collision check; once per process)",
        "rejected:",
    ]
    for g in rejection_ranges(plan.rejections):
        span = f"{g['tau_lo']:.2f}-{g['tau_hi']:.2f} s ({g['count']})"
        if g["reason"] == "unstable":
            lines.append(f"  {span}: unstable (outside the handling envelope)")
        else:
            lines.append(f"  {span}: collision with {g['vehicle_id']} "
                         f"(first overlap at t = {g['t_lo']:.2f}-{g['t_hi']:.2f} s)")
    return "\n".join(lines)


def _config(args: argparse.Namespace, sc: Any) -> PlannerConfig:
    """The scenario's planner settings with the flags' collision test and envelope."""
    cfg = sc.planner
    if args.collision_test:
        cfg = replace(cfg, collision_test=args.collision_test)
    if args.envelope:
        cfg = replace(cfg, envelope=args.envelope)
    return cfg


def _timed_plan(planner: LaneChangePlanner, si: Situation) -> tuple[Plan, float, float]:
    """(the plan, numba's start-up s, the tau_min maps' build s). The first call builds
    the envelope's tau_min maps of this lane change (the speeds it reads: one-off,
    cached for the process); the plan reported is the second, identical call, so that
    planning_time_s is the planner's own (as `cosim bench planner`)."""
    start = time.perf_counter()
    warm_up()  # so that the planning time is the planner's own
    startup_s = time.perf_counter() - start
    first = planner.plan(si.t, si.sv, si.target_lane, si.messages, si.occupant)
    plan = planner.plan(si.t, si.sv, si.target_lane, si.messages, si.occupant)
    return plan, startup_s, max(first.planning_time_s - plan.planning_time_s, 0.0)


def run(args: argparse.Namespace) -> int:
    from cosim.driving.registry import prediction_of
    from cosim.scenario import load_scenario

    sc = load_scenario(args.scenario)
    cfg = _config(args, sc)
    si = situation(sc)
    planner = LaneChangePlanner(sc.vehicle, si.road, cfg, prediction=prediction_of(cfg.policy))
    plan, startup_s, map_build_s = _timed_plan(planner, si)
    figure = None
    if not args.no_plot:
        from cosim.output import check_output_dir
        from cosim.plots import figure_path

        check_output_dir(args.out)  # no escaping or empty name
        figure = figure_path(args.out, figure_stem(sc.name, cfg), args.figure_format)
    # The answer first, the figure after it: if standard output cannot take the answer (a
    # full device), the command fails before it writes anything (docs/commands.md, `cosim plan`).
    if args.json:
        d = plan.to_dict()
        d["scenario"] = sc.name
        d["startup_s"] = startup_s
        d["map_build_s"] = map_build_s
        d["figure"] = str(figure) if figure is not None else None
        print(json.dumps(d, sort_keys=True))
    else:
        print(report(sc.name, plan, startup_s, map_build_s))
        if figure is not None:
            print(f"figure: {figure}")
    if sys.stdout is not None:  # (None: a closed descriptor)
        sys.stdout.flush()
    if figure is not None:
        from cosim.output import make_output_dir
        from cosim.plots.planning import planning_figure

        try:
            make_output_dir(args.out)
        except OSError as exc:
            raise InputError("cosim plan", "--out", str(args.out),
                             f"a writable folder ({exc})") from None
        planning_figure(figure, plan, si.road, sc.vehicle,
                        title=f"{sc.name}: planning at t = {si.t:g} s, {describe_method(cfg)}")
    return 0
