"""The command line of the docs' study scripts (study_merge_table.py,
study_comfort_table.py, study_gap_table.py): `python docs/<script>.py DIR` prints the
Markdown table of a `cosim batch` output folder, `--figure PATH` writes its figure
instead. A folder without runs.csv is refused in one line, exit status 2."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path


def run(doc: str, table: Callable[[Path], str], figure: Callable[[Path, Path], None]) -> None:
    """Parse the command line (`doc`: the script's docstring) and print the table or
    write the figure."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path, help="a cosim batch output folder")
    parser.add_argument("--figure", type=Path, metavar="PATH",
                        help="write the figure to PATH (format from its suffix) instead "
                             "of printing the table")
    args = parser.parse_args()
    if not (args.folder / "runs.csv").is_file():
        parser.error(f"{args.folder}: no runs.csv in it (a cosim batch output folder is "
                     "expected)")
    if args.figure is not None:
        figure(args.folder, args.figure)
    else:
        print(table(args.folder), end="")
