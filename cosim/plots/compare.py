"""`cosim compare`'s figure: one scenario and seed under each driver, overlaid."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from cosim.plots import save_figure
from cosim.plots.labels import D_LABEL, S_LABEL, suptitle

LABELS = {"mimo": "ours, MIMO", "siso": "ours, SISO", "mimo_paper": "ours, MIMO, paper's method",
          "mimo_gap": "ours, MIMO, gap policy", "sumo": "SUMO-native"}
STYLES = {"mimo": ("C0", "-"), "siso": ("C1", "--"), "mimo_paper": ("C3", ":"),
          "mimo_gap": ("C3", ":"), "sumo": ("C2", "-")}


def compare_figure(path: Path, results: Mapping[str, Any], *, title: str) -> Path:
    """SV path in road coordinates (d against s, over the lane lines), body lateral
    acceleration, smallest gap and smallest TTC over time, one line per driver;
    `results`: driver -> RunResult."""
    fig, axes = plt.subplots(4, 1, figsize=(10, 11))
    road = next(iter(results.values())).road
    for k in range(road.n_lanes + 1):
        axes[0].axhline(road.y_right + k * road.lane_width, color="0.5", lw=0.8,
                        ls="-" if k in (0, road.n_lanes) else "--")
    for driver, result in results.items():
        colour, ls = STYLES.get(driver, ("k", "-"))
        tr = result.trace
        label = LABELS.get(driver, driver)
        axes[0].plot(tr["s_m"], tr["d_m"], color=colour, ls=ls, label=label)
        axes[1].plot(tr["t_s"], tr["ay_mps2"], color=colour, ls=ls, label=label)
        axes[2].plot(tr["t_s"], np.where(np.isfinite(tr["gap_min_m"]), tr["gap_min_m"], np.nan),
                     color=colour, ls=ls, label=label)
        axes[3].plot(tr["t_s"], np.where(np.isfinite(tr["ttc_min_s"]), tr["ttc_min_s"], np.nan),
                     color=colour, ls=ls, label=label)
    t_end = max(float(r.trace["t_s"][-1]) for r in results.values())
    for ax in axes[1:]:
        ax.set_xlim(0.0, t_end)
    axes[0].set_xlabel(S_LABEL)
    axes[0].set_ylabel(D_LABEL)
    axes[0].set_title("SV trajectories in road coordinates (s, d)", fontsize=9)
    axes[1].set_ylabel("lateral acc. (m/s^2)")
    axes[2].set_ylabel("smallest gap (m)")
    axes[3].set_ylabel("smallest TTC (s)")
    axes[2].set_ylim(bottom=0.0)
    if any(np.isfinite(r.trace["ttc_min_s"]).any() for r in results.values()):
        axes[3].set_yscale("log")
    axes[3].set_title("gaps break where no TV shares the SV's strip; TTC where no one closes in",
                      fontsize=8)
    axes[3].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8, loc="upper right")
    suptitle(fig, title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)
