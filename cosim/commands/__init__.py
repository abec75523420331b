"""One module per CLI subcommand: `add_parser(subparsers)` and `run(args) -> int`.

Flags shared by several commands and flag types checked like scenario keys are here.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.validation import Field


class PlainHelp(argparse.HelpFormatter):
    """Help as plain text: the description's paragraphs (blank-line separated) and list
    items ("- ...", "1. ...") each re-filled to the terminal's width, Markdown's backticks
    dropped, in the descriptions and in every flag's help."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        import textwrap

        blocks = []
        for paragraph in re.split(r"\n\s*\n", text.replace("`", "").strip()):
            items = re.split(r"\n\s*(?=- |\d+\. )", paragraph)
            blocks.append("\n".join(
                textwrap.fill(" ".join(item.split()), width, initial_indent=indent,
                              subsequent_indent=indent + ("  " if item.lstrip()[:1] in "-123456789"
                                                          else ""))
                for item in items))
        return "\n\n".join(blocks)

    def _split_lines(self, text: str, width: int) -> list[str]:
        return super()._split_lines(text.replace("`", ""), width)


FIGURE_FORMATS = ("png", "svg", "pdf")  # = cosim.plots.FORMATS (not imported: matplotlib)


def add_figure_format(parser: argparse.ArgumentParser) -> None:
    """`--figure-format png|svg|pdf` (default png, 200 dpi), for every command that draws."""
    parser.add_argument("--figure-format", choices=FIGURE_FORMATS, default=None,
                        help="format of the figures (default png, 200 dpi)")


# Flags that turn a command's figures off: --figure-format with one of them means nothing.
NO_FIGURE_FLAGS = (("no_figures", "--no-figures"), ("no_plot", "--no-plot"),
                   ("no_plots", "--no-plots"))


def check_figure_flags(args: argparse.Namespace) -> None:
    """--figure-format with a flag that draws no figure is refused, naming both."""
    if getattr(args, "figure_format", None) is None:
        return
    for attr, flag in NO_FIGURE_FLAGS:
        if getattr(args, attr, False):
            raise InputError("command line", "--figure-format", args.figure_format,
                             f"no --figure-format with {flag} (no figure is drawn)")


def flag_type(field: Field) -> Callable[[str], Any]:
    """An argparse type that checks a flag's value as `field` checks a file's key:
    an error names the flag, the value and what is allowed (argparse: exit 2)."""

    def convert(text: str) -> Any:
        try:
            raw: Any = int(text) if field.kind is int else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: {field.allowed()}") from None
        if isinstance(raw, float) and not math.isfinite(raw):
            raise argparse.ArgumentTypeError(f"{text!r}: {field.allowed()}")
        try:
            return field.convert("command line", field.key, raw)
        except InputError:
            raise argparse.ArgumentTypeError(f"{text}: {field.allowed()}") from None

    convert.__name__ = field.kind.__name__  # argparse names the type in some messages
    return convert


def count(key: str, lo: int = 1, hi: int | None = None) -> Callable[[str], Any]:
    """An integer flag >= lo (repeats, workers, seeds), at most hi if given."""
    return flag_type(Field(key, int, lo=lo, hi=hi, default=None))


# Local worker processes per core at most (each run is one SUMO and one Python process,
# CPU-bound): more only queue for the cores and hold memory.
WORKERS_PER_CORE = 4


def max_workers() -> int:
    """The most local worker processes a command starts without being told otherwise."""
    import os

    return WORKERS_PER_CORE * (os.cpu_count() or 1)


def seconds(key: str, hi: float = 3600.0) -> Callable[[str], Any]:
    """A positive duration flag in (0, hi] s."""
    return flag_type(Field(key, float, lo=0.0, hi=hi, lo_open=True, unit="s", default=None))


def number_list(key: str, kind: type, lo: float, hi: float, what: str,
                example: str) -> Callable[[str], tuple[Any, ...]]:
    """A comma-separated flag of `kind` numbers in [lo, hi] (`what` they are)."""
    def convert(text: str) -> tuple[Any, ...]:
        try:
            values = tuple(kind(v) for v in text.split(","))
        except ValueError:
            values = ()
        if not values or not all(lo <= v <= hi for v in values):
            raise argparse.ArgumentTypeError(
                f"{key} {text!r}: comma-separated {what} in [{lo:g}, {hi:g}], e.g. {example}")
        return values

    return convert


RESULTS = Path("results")  # default outputs: under the current directory, as a user expects


def variant_folder(base: Path, name: str, variants: dict[str, Any]) -> Path:
    """The default output folder base/name, with one `--key_value` part per variant
    that differs from the defaults (`results/paper_case1_overtaking--controller_siso
    --seed_3`): runs of one scenario with other flags never overwrite each other, and
    the same flags write into the same folder again. `variants`: key -> value, None
    for "not overridden" (skipped); the order is the caller's."""
    parts = [name]
    for key, value in variants.items():
        if value is not None:
            text = re.sub(r"[^A-Za-z0-9.]+", "_", f"{value:g}" if isinstance(value, float)
                          else str(value)).strip("_.")
            parts.append(f"{key}_{text}")
    return base / "--".join(parts)


def overridden(before: Any, after: Any) -> Any:
    """after if a flag changed the scenario's value, else None (no folder part)."""
    return None if after == before else after


# s, numba compiling every hot loop on a cold cache, as the first run's message says (longer
# on a busy machine)
COMPILE_ESTIMATE_S = 40.0  # tuned: docs/tuned_constants.md


def compile_first(stream: Any = None) -> float:
    """Compile (or load from numba's cache) the hot loops before a progress bar
    starts, so that the bar measures runs only; on a cold cache say so first.
    Returns the seconds it took."""
    import sys
    import time

    from cosim.compiled import cache_folder, cache_warm, load_compiled_modules

    load_compiled_modules()  # their sources name the cache's folder

    out = stream or sys.stderr
    cold = not cache_warm()
    if cold:
        print(f"compiling (once per machine, ~{COMPILE_ESTIMATE_S:.0f} s, longer on a busy "
              "machine) ...", file=out, flush=True)
    start = time.perf_counter()
    import cosim.control.warm  # noqa: F401  (compiles or loads every compiled function)

    took = time.perf_counter() - start
    if cold:
        folder = cache_folder()
        where = (f"cached in {folder}" if any(folder.rglob("*.nbi")) else
                 "not cached: no folder numba could write; each process compiles again")
        print(f"compiled in {took:.0f} s ({where})", file=out, flush=True)
    return took


def flag_overrides(scenario: Any, flags: dict[str, tuple[str, Any]]) -> Any:
    """The scenario with command-line flags applied (`{"--seed": ("seed", 3)}`: flag ->
    (override name, value); None values skipped), validated like the file; an error
    names the flag."""
    from cosim.scenario import apply_overrides

    for flag, (name, value) in flags.items():
        if value is not None:
            scenario = apply_overrides(scenario, {name: value}, f"command line {flag}")
    return scenario
