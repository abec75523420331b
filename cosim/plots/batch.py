"""Figures of a batch study: the main metrics against traffic density, one line
per driver (and per other grid value that varies), with confidence intervals
as error bars."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from cosim.output import atomic_path

# (summary column prefix, axis label); rates are shown in per cent.
PANELS = (
    ("success", "lane changes completed (%)"),
    ("collision", "runs with a collision (%)"),
    ("lc_duration_s", "lane-change duration (s)"),
    ("min_ttc_s", "minimum TTC (s)"),
)
DRIVER_LABELS = {"mimo": "ours, MIMO", "siso": "ours, SISO", "sumo": "SUMO-native"}
_OTHER = ("plant", "occupant", "mu")


def _label(driver: str, key: tuple, varying: list[str]) -> str:
    text = DRIVER_LABELS.get(driver, driver)
    extra = [f"{name} {value:g}" if isinstance(value, float) else f"{value}"
             for name, value in zip(_OTHER, key, strict=True) if name in varying]
    return ", ".join([text, *extra])


def plot_summary(summary: pd.DataFrame, out_dir: Path, *, title: str = "study") -> list[Path]:
    """Write `density.png` (2 x 2 panels) into `out_dir`; return the paths written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    varying = [name for name in _OTHER if summary[name].nunique() > 1]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    drivers = list(dict.fromkeys(summary["driver"]))
    colours = {d: f"C{i}" for i, d in enumerate(drivers)}
    others = sorted({tuple(r) for r in summary[list(_OTHER)].itertuples(index=False)})
    styles = ["-", "--", ":", "-."]
    markers = ["o", "s", "^", "D", "v", "P"]
    n_lines = len(drivers) * len(others)
    for ax, (prefix, ylabel) in zip(axes.flat, PANELS, strict=True):
        scale = 100.0 if prefix in ("success", "collision") else 1.0
        column = f"{prefix}_rate" if scale != 1.0 else f"{prefix}_mean"
        line = 0
        for driver in drivers:
            for j, key in enumerate(others):
                mask = (summary["driver"] == driver) & np.logical_and.reduce(
                    [summary[name] == value for name, value in zip(_OTHER, key, strict=True)]
                )
                cell = summary[mask].sort_values("density")
                if cell.empty:
                    continue
                x = cell["density"].to_numpy(float)
                # Dodge the lines sideways a little so error bars do not hide each other.
                dx = (line - (n_lines - 1) / 2) * 0.012 * (np.ptp(x) or 1.0)
                y = cell[column].to_numpy(float) * scale
                low = cell[f"{prefix}_ci_low"].to_numpy(float) * scale
                high = cell[f"{prefix}_ci_high"].to_numpy(float) * scale
                err = np.vstack([np.nan_to_num(y - low), np.nan_to_num(high - y)])
                ax.errorbar(
                    x + dx, y, yerr=err, color=colours[driver], linestyle=styles[j % 4],
                    marker=markers[j % 6], markersize=4, capsize=3, linewidth=1.4,
                    label=_label(driver, key, varying),
                )
                line += 1
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        if scale != 1.0:
            ax.set_ylim(-5, 105)
    for ax in axes[1]:
        ax.set_xlabel("traffic density (veh/km/lane)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=min(len(labels), 4), frameon=False)
    n = int(summary["runs"].max()) if len(summary) else 0
    fig.suptitle(f"{title}: means with 95 % confidence intervals (up to {n} seeds per point)",
                 y=0.995, fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    path = out_dir / "density.png"
    with atomic_path(path) as tmp:  # an interrupted study never leaves half a PNG
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return [path]
