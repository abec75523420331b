"""Figures of a batch study: the main metrics against traffic density, one line
per driver (and per other grid value that varies), with confidence intervals
as error bars."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from cosim.plots import figure_path, save_figure
from cosim.run.metrics import FOLLOWER_PERCENTILE
from cosim.study.run_table import NO_PLANT, NO_VARIANT, Driver

# (summary column prefix, axis label); rates are shown in per cent.
PANELS = (
    ("success", "lane changes completed\n(% of finished runs)"),
    ("collision", "runs with a collision (%):\nours (filled), SUMO's (open)"),
    ("sv_collision", "runs with an SV-caused collision (%)"),
    ("follower_decel_mps2", "new follower's max decel, p95 (m/s^2)"),
    ("lc_duration_s", "lane-change duration, median (s)"),
    ("min_ttc_s", "minimum TTC, median (s)"),
)
RATES = ("success", "collision", "sv_collision")
DRIVER_LABELS = {Driver.MIMO: "ours, MIMO", Driver.SISO: "ours, SISO",
                 Driver.SUMO: "SUMO-native"}
_OTHER = ("variant", "plant", "occupant", "mu", "share")


def _variant(row: pd.Series, varying: list[str]) -> str:
    """The line's grid values besides driver and density, as a label part."""
    parts = []
    for name in varying:
        value = row[name]
        if name == "variant":
            if isinstance(value, str) and value:  # a study's named scenario overrides
                parts.append(value)
        elif name == "plant":
            if value != NO_PLANT:  # the SUMO-native driver runs no plant of ours
                parts.append(str(value))
        else:
            parts.append(f"{'p' if name == 'occupant' else name} {value:g}")
    return ", ".join(parts)


def plot_summary(summary: pd.DataFrame, out_dir: Path, *, title: str = "study",
                 fmt: str | None = None) -> list[Path]:
    """Write `density.<fmt>` (2 x 3 panels; default png) into `out_dir`; return the paths
    written.
    One colour per line (driver and variant), one line style per driver."""
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = _labelled(summary)
    lines = _lines(summary)
    fig, axes = plt.subplots(2, 3, figsize=(15, 7.5), sharex=True)
    for ax, (prefix, ylabel) in zip(axes.flat, PANELS, strict=True):
        _draw_panel(ax, summary, lines, prefix, ylabel)
    _finish(fig, axes, summary, title)
    path = figure_path(out_dir, "density", fmt)
    save_figure(fig, path)
    return [path]


@dataclass(frozen=True)
class _Line:
    """One line of every panel: a driver and the label of its other grid values."""

    driver: str
    variant: str  # the label of the line's grid values besides driver and density
    colour: Any
    style: str  # one per driver
    marker: str


def _labelled(summary: pd.DataFrame) -> pd.DataFrame:
    """The summary with `variant` replaced by each row's label of the grid values that
    vary besides driver and density (`_variant`)."""
    summary = summary.copy()
    if "variant" not in summary:
        summary["variant"] = NO_VARIANT
    summary["variant"] = summary["variant"].fillna(NO_VARIANT).astype(str)
    plants = summary.loc[summary["plant"] != NO_PLANT, "plant"]
    varying = [name for name in _OTHER
               if (plants if name == "plant" else summary[name]).nunique() > 1]
    summary["variant"] = [_variant(row, varying) for _, row in summary.iterrows()]
    return summary


def _lines(summary: pd.DataFrame) -> list[_Line]:
    """The lines drawn, in the order of the drivers, then of the labels."""
    drivers = list(dict.fromkeys(summary["driver"]))
    variants = sorted(set(summary["variant"]))
    cells = [(d, v) for d in drivers for v in variants
             if ((summary["driver"] == d) & (summary["variant"] == v)).any()]
    palette = plt.get_cmap("tab10" if len(cells) <= 10 else "tab20")
    styles = {d: s for d, s in zip(drivers, ["-", "--", ":", "-."] * 4, strict=False)}
    markers = ["o", "s", "^", "D", "v", "P", "X", "*", "<", ">"]
    return [_Line(d, v, palette(i % palette.N), styles[d], markers[i % len(markers)])
            for i, (d, v) in enumerate(cells)]


def _draw_panel(ax: Any, summary: pd.DataFrame, lines: list[_Line], prefix: str,
                ylabel: str) -> None:
    """One panel: each line's statistic of `prefix` against density, with its interval
    as error bars (rates in per cent); nothing if the summary lacks the column."""
    scale = 100.0 if prefix in RATES else 1.0
    # rates, medians of durations and TTC, the follower's p95: summary.md's statistics
    column = (f"{prefix}_rate" if scale != 1.0 else
              f"{prefix}_p{FOLLOWER_PERCENTILE}" if prefix == "follower_decel_mps2" else
              f"{prefix}_p50")
    if column not in summary:
        return
    for i, line in enumerate(lines):
        cell = summary[(summary["driver"] == line.driver) & (summary["variant"] == line.variant)]
        cell = cell.sort_values("density")
        x = cell["density"].to_numpy(float)
        # Dodge the lines sideways a little so error bars do not hide each other.
        dx = (i - (len(lines) - 1) / 2) * 0.012 * (np.ptp(x) or 1.0)
        y = cell[column].to_numpy(float) * scale
        err = None
        if f"{prefix}_ci_low" in cell:  # the p95 has no interval here
            low = cell[f"{prefix}_ci_low"].to_numpy(float) * scale
            high = cell[f"{prefix}_ci_high"].to_numpy(float) * scale
            # clip: a Wilson bound equals the rate up to rounding at 0 % and 100 %
            err = np.clip(np.vstack([np.nan_to_num(y - low), np.nan_to_num(high - y)]),
                          0, None)
        label = ", ".join(filter(None, [DRIVER_LABELS.get(line.driver, line.driver),
                                        line.variant]))
        ax.errorbar(
            x + dx, y, yerr=err, color=line.colour, linestyle=line.style,
            marker=line.marker, markersize=4, capsize=3, linewidth=1.4, label=label,
        )
        if prefix == "collision" and "sumo_collision_rate" in cell:
            # SUMO's cross-check beside ours: open markers, thin line, no error bars
            ax.plot(x + dx, cell["sumo_collision_rate"].to_numpy(float) * scale,
                    color=line.colour, linestyle=line.style, linewidth=0.7,
                    marker=line.marker, markersize=6, markerfacecolor="none")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    if scale != 1.0:
        ax.set_ylim(-5, 105)
    else:
        ax.set_ylim(0.0, ax.get_ylim()[1] * 1.08)


def _finish(fig: Any, axes: Any, summary: pd.DataFrame, title: str) -> None:
    """Axis labels, the title with the finished runs per point, one legend for all."""
    for ax in axes[1]:
        ax.set_xlabel("traffic density (veh/km/lane)")
    for ax in axes.flat:
        ax.tick_params(labelbottom=True)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    counts = sorted(set(summary["ok"].astype(int)))
    n = f"{counts[0]}" if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"
    fig.suptitle(f"{title}: rates and medians with 95 % confidence intervals "
                 f"({n} finished runs per point)", fontsize=11)
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.955),
               ncol=min(len(labels), 5), frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.91))
