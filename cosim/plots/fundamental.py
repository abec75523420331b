"""The fundamental diagram of a study (plots/fundamental.png, cosim.study.fundamental): per
lane and for the road (the mean over its lanes, per lane), flow against density (top) and
speed against density (bottom), every run a point, each line's medians per density cell
joined, its capacity starred."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from cosim.plots import figure_path, save_figure
from cosim.plots.labels import suptitle
from cosim.study.fundamental import LINE, ROAD

KMH = 3.6  # km/h per m/s, for the axes only


def _label(key: tuple[object, ...], varying: list[str]) -> str:
    values = dict(zip(LINE, key, strict=True))
    parts = [str(values["driver"])]
    parts += [f"{name} {values[name]}" for name in varying if values[name] not in ("", None)]
    return ", ".join(parts)


def plot_fundamental(pts: pd.DataFrame, fd: pd.DataFrame, cap: pd.DataFrame, out_dir: Path,
                     *, title: str = "study", fmt: str | None = None) -> Path:
    """Write fundamental.<fmt> (default png) into `out_dir` and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    lanes = sorted((x for x in set(fd.lane) if x != ROAD), key=int) + [ROAD]
    varying = [c for c in LINE[1:] if fd[c].nunique() > 1]
    keys = list(dict.fromkeys(map(tuple, fd[list(LINE)].itertuples(index=False))))
    colours = plt.get_cmap("tab10")
    fig, axes = plt.subplots(2, len(lanes), figsize=(3.6 * len(lanes) + 1.0, 6.8),
                             sharex=True, squeeze=False, layout="constrained")
    for col, lane in enumerate(lanes):
        top, bottom = axes[0, col], axes[1, col]
        for i, key in enumerate(keys):
            colour = colours(i % 10)
            match = (fd[list(LINE)].apply(tuple, axis=1) == key) & (fd.lane == lane)
            # joined along the measured density (a cell SUMO could not fill lies left of
            # its grid value)
            line = fd[match].sort_values("density_veh_per_km_p50")
            mine = pts[(pts[list(LINE)].apply(tuple, axis=1) == key) & (pts.lane == lane)]
            label = _label(key, varying)
            top.plot(mine.density_veh_per_km, mine.flow_veh_per_h, ".", color=colour,
                     alpha=0.35, markersize=4)
            top.plot(line.density_veh_per_km_p50, line.flow_veh_per_h_p50, "-o", color=colour,
                     markersize=4, label=f"{label}: runs (dots), cell medians")
            bottom.plot(mine.density_veh_per_km, mine.speed_mps * KMH, ".", color=colour,
                        alpha=0.35, markersize=4)
            bottom.plot(line.density_veh_per_km_p50, line.speed_mps_p50 * KMH, "-o",
                        color=colour, markersize=4)
            peak = cap[(cap[list(LINE)].apply(tuple, axis=1) == key) & (cap.lane == lane)]
            for r in peak.itertuples():
                top.plot(r.critical_density_veh_per_km, r.capacity_veh_per_h, "*",
                         color=colour, markersize=14, markeredgecolor="black",
                         label=f"capacity {r.capacity_veh_per_h:.0f} veh/h at "
                               f"{r.critical_density_veh_per_km:.1f} veh/km")
        name = "the road, per lane" if lane == ROAD else f"lane {lane}"
        unit = "/lane" if lane == ROAD else ""
        top.set_title(name, fontsize=10)
        top.set_ylabel(f"flow (veh/h{unit})")
        bottom.set_ylabel("space-mean speed (km/h)")
        bottom.set_xlabel(f"measured density (veh/km{unit})")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
            ax.set_xlim(left=0.0)
            ax.set_ylim(bottom=0.0)
        top.legend(fontsize=7, loc="lower right")
    suptitle(fig, f"{title}: fundamental diagram from SUMO's detectors (every run a dot, the "
                  "medians per density cell joined, the capacity starred)", fontsize=10)
    path = figure_path(out_dir, "fundamental", fmt)
    save_figure(fig, path)
    return path
