"""The `cosim` console script: `cosim plan | track | run | batch | bench ...`.

Each subcommand lives in its own module under cosim/commands/ (`add_parser`,
`run`). Errors a user can cause (`InputError`) are printed on one line and the
process exits with status 2; nothing is written before the input is valid.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import os
import re
import signal
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from cosim import __version__
from cosim.commands import check_figure_flags
from cosim.errors import (
    EXIT_INTERRUPTED,
    SIGNAL_WORDS,
    CosimError,
    InputError,
    OutputError,
    check_signals,
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


class _Guarded:
    """sys.stdout / sys.stderr whose write errors (a full device, an I/O error) become
    one OutputError naming the stream, not a traceback; a closed pipe stays
    BrokenPipeError (a reader such as `head` went away: not an error)."""

    def __init__(self, stream: Any, name: str) -> None:
        self._stream = stream
        self._name = name

    def write(self, text: str) -> Any:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            if exc.errno == errno.EBADF:  # closed by the user (`2>&-`): discarded, as asked
                return len(text)
            raise OutputError(self._name, exc) from None

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            if exc.errno != errno.EBADF:
                raise OutputError(self._name, exc) from None

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def _silence(fd: int) -> None:
    """Point a standard stream's descriptor at /dev/null, so that the interpreter's final
    flush of what could not be written does not fail again (exit 120, a warning)."""
    with contextlib.suppress(OSError):
        os.dup2(os.open(os.devnull, os.O_WRONLY), fd)


def _say(text: str) -> None:
    """One line on stderr; if stderr itself cannot take it, nothing (the status tells)."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, OutputError):
        with contextlib.suppress(OSError, ValueError):
            _silence(sys.__stderr__.fileno())


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    previous = signals_as_interrupts()  # noted, acted on at `check_signals`
    streams = sys.stdout, sys.stderr
    # a closed descriptor (`2>&-`) leaves its stream None, which print skips but the
    # progress bar does not: what would go there goes nowhere, as the user asked
    sink = open(os.devnull, "w") if None in streams else None  # noqa: SIM115 (closed below)
    sys.stdout = _Guarded(sys.stdout or sink, "standard output")
    sys.stderr = _Guarded(sys.stderr or sink, "standard error")
    completed_before = len(_completed())
    try:
        check_figure_flags(args)
        status = int(args.func(args) or 0)
        check_signals()  # a signal that came after the command's last check still counts
        sys.stdout.flush()  # a full stdout fails here, inside the command, not at exit
        return status
    except InputError as exc:
        _say(f"cosim {args.command}: error: {exc}")
        return 2
    except OutputError as exc:
        if exc.where == "standard output":
            with contextlib.suppress(OSError, ValueError):
                _silence(streams[0].fileno())
        _say(f"cosim {args.command}: error: {exc}")
        return 2
    except CosimError as exc:
        _say(f"cosim {args.command}: failed: {exc}")
        return 1
    except KeyboardInterrupt as exc:
        done = _completed()[completed_before:]
        return _interrupted(args.command, getattr(exc, "exit_status", EXIT_INTERRUPTED), done)
    except BrokenPipeError:
        # the reader (`| head`) went away: stop quietly, as a Unix filter does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception:
        status = interrupted_status()  # e.g. Ctrl-C inside matplotlib's C import: ImportError
        if status is None:
            raise
        return _interrupted(args.command, status, _completed()[completed_before:])
    finally:
        sys.stdout, sys.stderr = streams
        if sink is not None:
            sink.close()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _completed() -> list[Any]:
    """Output folders swapped in whole by this process (cosim.output.COMPLETED)."""
    output = sys.modules.get("cosim.output")
    return list(getattr(output, "COMPLETED", []))


def _interrupted(command: str, status: int, done: list[Any]) -> int:
    what = SIGNAL_WORDS.get(status, "interrupted")
    if command == "run" and done:
        # the signal came once the run's folder was swapped in: the run is complete and
        # in place, and the status says so (README, "Atomic outputs")
        _say(f"cosim {command}: {what} after the run was complete: {done[-1]} holds it")
        return 0
    _say(f"cosim {command}: {what}")
    return status


if __name__ == "__main__":
    sys.exit(main())
