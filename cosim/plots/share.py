"""The figure of a study over the automated vehicles' share (plots/share.png): the fleet's
and the traffic's figures (summary.csv's means, cosim.study.fleet_summary) against the
share, one colour per driver (the SV's, and the fleet's where the study varies it), one
line style per density, the 95 % intervals as error bars; the runs at share 0 (no
automated vehicle, one run for every fleet driver) start each fleet driver's line."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from cosim.plots import figure_path, save_figure

# (summary column stem, axis label)
PANELS = (
    ("fleet_lane_changes_per_vehicle", "lane changes per AV"),
    ("fleet_caused_collisions", "AV-caused collisions per run"),
    ("fleet_max_long_jerk_mps3", "AV peak jerk, median over AVs (m/s^3)"),
    ("fleet_follower_max_decel_mps2", "AV follower's max decel (m/s^2)"),
    ("fleet_mean_speed_mps", "AV mean speed (m/s)"),
    ("outflow_veh_per_h", "outflow (veh/h)"),
    ("speed_spread_space_mps", "speed spread along the route (m/s)"),
    ("ssm_conflicts_per_vehicle_km", "SSM conflicts per vehicle-km"),
)
STYLES = ["-", "--", ":", "-."]


def _driver(row: pd.Series, by_fleet: bool) -> str:
    return f"fleet {row['fleet_driver']}" if by_fleet else f"SV {row['driver']}"


def plot_share(summary: pd.DataFrame, out_dir: Path, *, title: str = "study",
               fmt: str | None = None) -> list[Path]:
    """Write `share.<fmt>` (2 x 4 panels, those the summary has) into `out_dir`; return
    the paths written (none when the share does not vary)."""
    if "share" not in summary or summary["share"].nunique() < 2:
        return []
    out_dir.mkdir(parents=True, exist_ok=True)
    by_fleet = "fleet_driver" in summary and summary["fleet_driver"].nunique() > 1
    if by_fleet:  # a study's one run at share 0 (no AV) starts every fleet driver's line
        zero = summary[summary["share"] == 0.0]
        summary = pd.concat([summary[summary["share"] > 0.0], *(
            zero.assign(fleet_driver=d) for d in summary["fleet_driver"].unique())])
    summary = summary.assign(line=[_driver(r, by_fleet) for _, r in summary.iterrows()])
    drivers = list(dict.fromkeys(summary["line"]))
    densities = sorted(set(summary["density"]))
    palette = plt.get_cmap("tab10")
    fig, axes = plt.subplots(2, 4, figsize=(18, 7.5), sharex=True)
    shares = summary["share"].to_numpy(float)
    width = float(np.ptp(shares)) or 1.0
    for ax, (stem, ylabel) in zip(axes.flat, PANELS, strict=True):
        column = f"{stem}_mean"
        if column not in summary or not np.isfinite(summary[column].to_numpy(float)).any():
            ax.set_visible(False)
            continue
        n = len(drivers) * len(densities)
        for i, (driver, density) in enumerate((d, k) for d in drivers for k in densities):
            cell = summary[(summary["line"] == driver) & (summary["density"] == density)]
            cell = cell.sort_values("share")
            x = cell["share"].to_numpy(float) + (i - (n - 1) / 2) * 0.006 * width
            y = cell[column].to_numpy(float)
            low = cell[f"{stem}_ci_low"].to_numpy(float)
            high = cell[f"{stem}_ci_high"].to_numpy(float)
            err = np.clip(np.vstack([np.nan_to_num(y - low), np.nan_to_num(high - y)]), 0, None)
            ax.errorbar(x, y, yerr=err, color=palette(drivers.index(driver) % palette.N),
                        linestyle=STYLES[densities.index(density) % len(STYLES)], marker="o",
                        markersize=3, capsize=2, linewidth=1.2,
                        label=f"{driver}, {density:g} veh/km/lane")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("automated vehicles' share")
    for ax in axes.flat:
        ax.tick_params(labelbottom=True)
    visible = [ax for ax in axes.flat if ax.get_visible()]
    handles, labels = (visible[0].get_legend_handles_labels() if visible else ([], []))
    counts = sorted(set(summary["ok"].astype(int)))
    runs = f"{counts[0]}" if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"
    fig.suptitle(f"{title}: means with 95 % confidence intervals ({runs} finished runs "
                 "per point)", fontsize=11)
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.955),
               ncol=min(len(labels), 4) or 1, frameon=False, fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.88))
    path = figure_path(out_dir, "share", fmt)
    save_figure(fig, path)
    return [path]
