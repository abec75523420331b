"""The `cosim` console script: `cosim plan | track | run | batch | bench ...`.

Each subcommand lives in its own module under cosim/commands/ (`add_parser`,
`run`). Errors a user can cause (`InputError`) are printed on one line and the
process exits with status 2; nothing is written before the input is valid.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
import sys
from collections.abc import Sequence
from typing import NoReturn

from cosim import __version__
from cosim.errors import (
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    CosimError,
    InputError,
    interrupted_status,
    signals_as_interrupts,
)
from cosim.validation import suggest

# Subcommand modules under cosim/commands/, in the order `cosim --help` lists them.
COMMANDS = ("plan", "track", "run", "compare", "batch", "bench", "docs")


class Parser(argparse.ArgumentParser):
    """argparse with user errors on one line (`cosim run: error: ...`, exit 2), and
    a "did you mean" for a misspelt flag, as the scenario files' keys get."""

    def error(self, message: str) -> NoReturn:
        choice = re.search(r"invalid choice: '(.*)' \(choose from (.*)\)$", message)
        if choice:  # argparse lists the choices: add the nearest, as for a flag
            options = re.findall(r"'([^']*)'", choice.group(2))
            message += suggest(choice.group(1), options)
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")

    def parse_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> argparse.Namespace:
        argv = list(sys.argv[1:] if args is None else args)
        parsed, extras = self.parse_known_args(argv, namespace)
        if extras:
            active = self._active(argv)
            flag = next((a for a in extras if a.startswith("-")), extras[0])
            known = [o for a in active._actions for o in a.option_strings]
            hint = suggest(flag.split("=", 1)[0], known) if flag.startswith("-") else ""
            active.error(f"unrecognized argument {flag}{hint}")
        return parsed

    def _active(self, argv: list[str]) -> argparse.ArgumentParser:
        """The (sub)parser the command line selected: follows subcommand names."""
        parser: argparse.ArgumentParser = self
        for token in argv:
            subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
            if subs and token in subs[0].choices:
                parser = subs[0].choices[token]
        return parser


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
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
    if getattr(args, "figure_format", None):
        from cosim.plots import set_format

        set_format(args.figure_format)
    previous = signals_as_interrupts()  # SIGTERM unwinds like Ctrl-C (exit 143)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"cosim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except CosimError as exc:
        print(f"cosim {args.command}: failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        return _interrupted(args.command, getattr(exc, "exit_status", EXIT_INTERRUPTED))
    except BrokenPipeError:
        # the reader (`| head`) went away: stop quietly, as a Unix filter does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception:
        status = interrupted_status()  # e.g. Ctrl-C inside matplotlib's C import: ImportError
        if status is None:
            raise
        return _interrupted(args.command, status)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _interrupted(command: str, status: int) -> int:
    what = "terminated (SIGTERM)" if status == EXIT_TERMINATED else "interrupted"
    print(f"cosim {command}: {what}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
