"""`cosim compare SCENARIO.toml [--out DIR] [--seed N]`: the same scenario and seed
driven by MIMO, SISO and SUMO-native, side by side.

Writes DIR/compare.csv (one row of metrics.csv's columns per driver) and
DIR/compare.<format> (SV trajectories, lateral acceleration, gap and TTC over
time); default DIR results/compare/<scenario name>/.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cosim.commands import add_figure_format, compile_first, flag_overrides

DRIVERS = ("mimo", "siso", "sumo")
SHOWN = ("lane_changes", "collisions", "min_gap_m", "min_ttc_s", "max_abs_lat_accel_mps2",
         "max_jerk_mps3", "lane_change_duration_s")


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "compare", help="one scenario and seed driven by MIMO, SISO and SUMO-native",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default results/compare/<scenario name>)")
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: scenario's)")
    add_figure_format(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import pandas as pd

    from cosim.output import atomic_write_csv, check_output_dir, make_output_dir
    from cosim.plots import figure_path
    from cosim.plots.compare import compare_figure
    from cosim.scenario import load_scenario, project_root, with_overrides
    from cosim.sim import simulate

    base = flag_overrides(load_scenario(args.scenario), {"--seed": ("seed", args.seed)})
    scenarios = {d: with_overrides(base, controller=d) for d in DRIVERS}  # all checked first
    out = args.out if args.out is not None else project_root() / "results" / "compare" / base.name
    check_output_dir(out)
    compile_first()
    results = {}
    for driver, scenario in scenarios.items():
        print(f"cosim compare: {base.name}, seed {base.seed}: {driver}", file=sys.stderr)
        results[driver] = simulate(scenario)
    make_output_dir(out)
    table = pd.DataFrame([r.metrics for r in results.values()])
    csv = atomic_write_csv(out / "compare.csv", table, float_format="%.9g")
    figure = compare_figure(figure_path(out, "compare"), results,
                            title=f"{base.name}, seed {base.seed}: MIMO, SISO and SUMO-native")
    print(table[["controller", *SHOWN]].to_string(index=False, float_format="%.3g"))
    print(f"wrote {csv}\nwrote {figure}", file=sys.stderr)
    return 0
