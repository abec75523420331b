"""`cosim docs [--check] [--quick] [--only NAME,...]`: the result tables of README.md
and docs/ recomputed from the code (cosim.docs_tables).

Without --check the marked tables are rewritten in place, each stamped with the
commit it ran on; with --check nothing is written and the exit status is 1 when
a table no longer matches the code (the test suite checks the quick ones).
"""

from __future__ import annotations

import argparse
import sys

from cosim.commands import PlainHelp
from cosim.errors import InputError


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "docs", help="recompute the result tables of README.md and docs/ (or check them)",
        description=__doc__, formatter_class=PlainHelp,
    )
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 if a table differs from the code's")
    parser.add_argument("--quick", action="store_true",
                        help="only the tables made in seconds (no SUMO runs)")
    parser.add_argument("--only", metavar="NAMES",
                        help="comma-separated table names (default: all)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from cosim.docs_tables import TABLES, regenerate
    from cosim.validation import suggest

    names = list(TABLES)
    if args.only is not None:
        names = [n.strip() for n in args.only.split(",")]
        for name in names:
            if name not in TABLES:
                raise InputError("command line", "--only", name,
                                 f"one of {', '.join(TABLES)}{suggest(name, list(TABLES))}")
    if args.quick:
        names = [n for n in names if TABLES[n].quick]
    problems = regenerate(names, check=args.check,
                          log=lambda line: print(line, file=sys.stderr))
    for problem in problems:
        print(f"cosim docs: {problem}", file=sys.stderr)
    if args.check and not problems:
        print(f"cosim docs: {len(names)} tables match the code ({', '.join(names)})")
    return 1 if problems else 0
