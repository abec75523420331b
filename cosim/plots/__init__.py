"""Matplotlib figures (Agg backend), one module per subject.

Every figure is saved through `save_figure` (atomically, at `DPI` for PNG) in the
format its path's suffix names; `figure_path(folder, stem, fmt)` names a figure in the
format a command was given (`--figure-format png|svg|pdf`, default png), passed down
explicitly: no module state, so two callers in one process (a test run, a batch worker
beside the main process) each get the format they asked for.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

FORMATS = ("png", "svg", "pdf")
DEFAULT_FORMAT = "png"
DPI = 200  # dots per inch of PNG figures: sharp when printed at a column's width


def figure_path(folder: Path, stem: str, fmt: str | None = DEFAULT_FORMAT) -> Path:
    """folder/stem.<fmt> (None: the default, png)."""
    fmt = DEFAULT_FORMAT if fmt is None else fmt
    if fmt not in FORMATS:
        raise ValueError(f"figure format {fmt!r}: one of {', '.join(FORMATS)}")
    return Path(folder) / f"{stem}.{fmt}"


def save_figure(fig: Any, path: Path) -> Path:
    """Write `fig` to `path` atomically in the format its suffix names, close it."""
    import matplotlib.pyplot as plt

    from cosim.output import atomic_path

    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or DEFAULT_FORMAT
    try:
        with atomic_path(path) as tmp:
            # the creation date would make two identical runs' vector files differ
            fig.savefig(tmp, dpi=DPI, format=fmt,
                        metadata={"CreationDate": None} if fmt == "pdf" else
                        ({"Date": None} if fmt == "svg" else None))
    finally:
        plt.close(fig)
    return path
