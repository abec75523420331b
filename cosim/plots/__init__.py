"""Matplotlib figures (Agg backend), one module per subject.

Every figure is saved through `save_figure` (atomically, at `DPI` for PNG) in
the format the command chose (`--figure-format png|svg|pdf`, `set_format`);
`figure_path` names a figure with that format's suffix.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

FORMATS = ("png", "svg", "pdf")
DPI = 200  # dots per inch of PNG figures: sharp when printed at a column's width
_format = ["png"]  # the format of this process's figures (a command's --figure-format)


def set_format(fmt: str) -> None:
    """Choose the format of every figure this process writes from now on."""
    if fmt not in FORMATS:
        raise ValueError(f"figure format {fmt!r}: one of {', '.join(FORMATS)}")
    _format[0] = fmt


def figure_format() -> str:
    return _format[0]


def figure_path(folder: Path, stem: str) -> Path:
    """folder/stem.<format>."""
    return Path(folder) / f"{stem}.{_format[0]}"


def save_figure(fig: Any, path: Path) -> Path:
    """Write `fig` to `path` atomically in the format its suffix names, close it."""
    import matplotlib.pyplot as plt

    from cosim.output import atomic_path

    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or _format[0]
    try:
        with atomic_path(path) as tmp:
            # the creation date would make two identical runs' vector files differ
            fig.savefig(tmp, dpi=DPI, format=fmt,
                        metadata={"CreationDate": None} if fmt == "pdf" else
                        ({"Date": None} if fmt == "svg" else None))
    finally:
        plt.close(fig)
    return path
