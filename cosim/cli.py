"""The `cosim` console script: `cosim plan | track | run | batch | bench ...`.

Each subcommand lives in its own module under cosim/commands/ (`add_parser`,
`run`). Errors a user can cause (`InputError`) are printed on one line and the
process exits with status 2; nothing is written before the input is valid.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from collections.abc import Sequence

from cosim import __version__
from cosim.errors import (
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    CosimError,
    InputError,
    sigterm_as_interrupt,
)

# Subcommand modules under cosim/commands/, in the order `cosim --help` lists them.
COMMANDS = ("plan", "track", "run", "batch", "bench")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cosim",
        description="Lane changes of an automated car through SUMO highway traffic "
        "(Wang et al., IET ITS 2020).",
    )
    parser.add_argument("--version", action="version", version=f"cosim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"cosim.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"cosim.commands.{name}":
                raise
            continue  # command not built yet
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    previous = sigterm_as_interrupt()  # SIGTERM unwinds like Ctrl-C (exit 143)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"cosim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except CosimError as exc:
        print(f"cosim {args.command}: failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        status = getattr(exc, "exit_status", EXIT_INTERRUPTED)
        what = "terminated (SIGTERM)" if status == EXIT_TERMINATED else "interrupted"
        print(f"cosim {args.command}: {what}", file=sys.stderr)
        return status
    except BrokenPipeError:
        # the reader (`| head`) went away: stop quietly, as a Unix filter does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
