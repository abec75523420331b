"""`cosim compare SCENARIO.toml [--out DIR] [--seed N]`: the same scenario and seed
driven by MIMO and SISO (with the scenario's lane-change policy), MIMO with the other
policy (`[planner] policy`: the paper's method or the gap-seeking policy) and
SUMO-native, side by side.

Writes DIR/compare.csv (a `driver` column, then metrics.csv's columns; one row per
driver) and
DIR/compare.<format> (SV trajectories, lateral acceleration, gap and TTC over
time); default DIR ./results/compare/<scenario name>/ (with --seed N:
./results/compare/<scenario name>--seed_N/).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cosim.commands import PlainHelp, add_figure_format, compile_first, flag_overrides


def drivers(policy: str) -> dict[str, dict[str, str]]:
    """driver name -> the overrides that make it, for a scenario whose policy is `policy`:
    mimo and siso with it, mimo_<other> with each other policy, sumo."""
    from cosim.driving.registry import names

    runs = {"mimo": {"controller": "mimo"}, "siso": {"controller": "siso"}}
    runs |= {f"mimo_{p}": {"controller": "mimo", "policy": p}
             for p in names(planned=True) if p != policy}
    return runs | {"sumo": {"controller": "sumo"}}

SHOWN = ("lane_changes", "collisions", "min_gap_m", "min_ttc_s", "max_abs_lat_accel_mps2",
         "max_jerk_mps3", "lane_change_duration_s")


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "compare", help="one scenario and seed driven by MIMO, SISO, the other lane-change "
        "policy and SUMO-native",
        description=__doc__, formatter_class=PlainHelp,
    )
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default ./results/compare/<scenario name>[--seed_N])")
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: scenario's)")
    add_figure_format(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import pandas as pd

    from cosim.commands import RESULTS, overridden, variant_folder
    from cosim.output import atomic_write_csv, check_output_dir, make_output_dir
    from cosim.plots import figure_path
    from cosim.plots.compare import compare_figure
    from cosim.run.loop import simulate
    from cosim.scenario import load_scenario, with_overrides

    file = load_scenario(args.scenario)
    base = flag_overrides(file, {"--seed": ("seed", args.seed)})
    scenarios = {d: with_overrides(base, **changes)  # all checked first
                 for d, changes in drivers(base.planner.policy).items()}
    out = args.out if args.out is not None else variant_folder(
        RESULTS / "compare", base.name, {"seed": overridden(file.seed, base.seed)})
    check_output_dir(out)
    compile_first()
    results = {}
    for driver, scenario in scenarios.items():
        print(f"cosim compare: {base.name}, seed {base.seed}: {driver}", file=sys.stderr)
        results[driver] = simulate(scenario)
    make_output_dir(out)
    table = pd.DataFrame([{"driver": d, **r.metrics} for d, r in results.items()])
    csv = atomic_write_csv(out / "compare.csv", table, float_format="%.9g")
    figure = compare_figure(figure_path(out, "compare", args.figure_format), results,
                            title=f"{base.name}, seed {base.seed}: our drivers and SUMO-native")
    print(table[["driver", *SHOWN]].to_string(index=False, float_format="%.3g"))
    print(f"wrote {csv}\nwrote {figure}", file=sys.stderr)
    return 0
