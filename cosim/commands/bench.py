"""`cosim bench NAME [--json]`: speed measured side by side in one run.

Each benchmark is a module cosim/bench/NAME.py with `add_arguments(parser)` and
`measure(args) -> dict` (see cosim.bench.report for the dict's shape).
"""

from __future__ import annotations

import argparse
import importlib

from cosim.bench import BENCHMARKS, report


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "bench", help="benchmarks: medians and side-by-side ratios measured in one run"
    )
    names = parser.add_subparsers(dest="benchmark", metavar="NAME", required=True)
    for name, help_text in BENCHMARKS.items():
        try:
            module = importlib.import_module(f"cosim.bench.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"cosim.bench.{name}":
                raise
            continue  # benchmark not built yet
        p = names.add_parser(name, help=help_text)
        p.add_argument("--json", action="store_true", help="print one JSON object instead")
        module.add_arguments(p)
        p.set_defaults(func=run, bench_module=module)


def run(args: argparse.Namespace) -> int:
    result = args.bench_module.measure(args)
    print(report(result, as_json=args.json))
    return 0



