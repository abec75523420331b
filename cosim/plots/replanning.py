"""Figure of the replanning study (scenarios/study_replanning.toml): success,
collisions during the SV's lane change, all collisions of the SV and lane-change
duration against traffic density, one line per driver / variant, 95 % intervals
as error bars. Reads a `cosim batch` summary.csv."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from cosim.plots import save_figure

# (summary column prefix, axis label, per cent?)
PANELS = (
    ("success", "lane change completed (%)", True),
    ("manoeuvre_collision", "runs with a collision during the SV's lane change (%)", True),
    ("collision", "runs with any collision of the SV (%)", True),
    ("lc_duration_s", "lane-change duration, median (s)", False),
)
STYLE = {  # variant -> (colour, line style, marker)
    "paper": ("C0", "-", "o"),
    "replan": ("C1", "-", "s"),
    "paper_lossy": ("C0", "--", "o"),
    "replan_lossy": ("C1", "--", "s"),
    "paper_perception": ("C0", ":", "o"),
    "replan_perception": ("C1", ":", "s"),
    "replan_margin": ("C3", "-.", "D"),
}


def _label(driver: str, variant: str) -> str:
    if driver == "sumo":
        return "SUMO-native"
    return f"{driver}, {variant}" if variant else driver


def plot_replanning(summary: pd.DataFrame, path: Path, *, title: str) -> Path:
    """Write the 2 x 2 figure to `path`."""
    summary = summary.copy()
    summary["variant"] = summary.get("variant", "").fillna("").astype(str)
    lines = list(dict.fromkeys(zip(summary["driver"], summary["variant"], strict=True)))
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), sharex=True)
    for ax, (prefix, ylabel, percent) in zip(axes.flat, PANELS, strict=True):
        for k, (driver, variant) in enumerate(lines):
            cell = summary[(summary["driver"] == driver) & (summary["variant"] == variant)]
            cell = cell.sort_values("density")
            x = cell["density"].to_numpy(float) + 0.4 * (k - len(lines) / 2)  # dodge
            if percent:
                y = 100.0 * cell[f"{prefix}_rate"].to_numpy(float)
                lo = 100.0 * cell[f"{prefix}_ci_low"].to_numpy(float)
                hi = 100.0 * cell[f"{prefix}_ci_high"].to_numpy(float)
            else:
                y = cell[f"{prefix}_p50"].to_numpy(float)  # the median, as summary.md
                lo = cell[f"{prefix}_ci_low"].to_numpy(float)
                hi = cell[f"{prefix}_ci_high"].to_numpy(float)
            err = np.vstack([np.nan_to_num(y - lo), np.nan_to_num(hi - y)])
            colour, style, marker = STYLE.get(variant, ("C2", "-", "^"))
            ax.errorbar(x, y, yerr=err, color=colour, linestyle=style, marker=marker,
                        capsize=2, markersize=4, label=_label(driver, variant))
        ax.set_ylabel(ylabel, fontsize=9)
        ax.grid(True, alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("traffic density (veh/km/lane)")
    axes[0, 0].legend(fontsize=8, loc="best")
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def main(argv: list[str] | None = None) -> int:
    """python -m cosim.plots.replanning SUMMARY_CSV OUT_PNG"""
    import sys

    args = sys.argv[1:] if argv is None else argv
    summary = pd.read_csv(args[0], keep_default_na=True)
    plot_replanning(summary, Path(args[1]),
                    title="Replanning and V2V realism over traffic density (cosim batch "
                          "scenarios/study_replanning.toml)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
