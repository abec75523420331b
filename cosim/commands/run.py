"""`cosim run SCENARIO.toml`: one co-simulation run, outputs under results/<scenario>/.

The scenario is loaded and validated first (InputError -> exit 2, nothing
written); flags override the file's [sv] plant / controller and [scenario] seed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "run",
        help="run one scenario: our SV (or the SUMO baseline) in SUMO traffic",
        description="Run one scenario and write trace.csv, plans.csv, metrics.csv, "
        "timing.csv and PNG figures (default folder results/<scenario name>/).",
    )
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default: results/<scenario name>)")
    parser.add_argument("--plant", choices=("twotrack", "bicycle"), default=None,
                        help="vehicle model (default: the scenario's)")
    parser.add_argument("--controller", choices=("mimo", "siso", "sumo"), default=None,
                        help="mimo / siso: our planner and controller; sumo: SUMO drives the SV")
    parser.add_argument("--gui", action="store_true", help="show the run in sumo-gui (traci)")
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: scenario's)")
    parser.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from cosim.output import check_output_dir
    from cosim.scenario import load_scenario, project_root, with_overrides
    from cosim.sim import run_scenario
    from cosim.vehicle.bicycle import warn_near_critical_speed

    scenario = load_scenario(args.scenario)
    changes: dict[str, object] = {}
    if args.plant is not None:
        changes["plant"] = args.plant
    if args.controller is not None:
        changes["controller"] = args.controller
    if args.seed is not None:
        changes["seed"] = args.seed
    if changes:
        scenario = with_overrides(scenario, **changes)
    warn_near_critical_speed(scenario)  # one line on stderr if the SV may get near it
    out = args.out if args.out is not None else project_root() / "results" / scenario.name
    check_output_dir(out)  # a bad --out is an input error now, not after the run
    metrics = run_scenario(
        scenario, out, write_trace=True, write_figures=not args.no_figures,
        progress=True, gui=args.gui,
    )
    keys = ("lane_changes", "collisions", "sumo_collisions", "min_gap_m", "min_ttc_s",
            "tau_first_s", "iae_ye_m_s")
    summary = ", ".join(f"{k} = {metrics[k]:.4g}" if isinstance(metrics[k], float)
                        else f"{k} = {metrics[k]}" for k in keys if k in metrics)
    print(f"{scenario.name}: {summary}")
    print(f"wrote {out}", file=sys.stderr)
    return 0
