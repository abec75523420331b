"""The per-density table and figure of the merge study (issue 24, README "The merge
study", docs/merge_study.md) from a batch folder of scenarios/study_merge.toml:

    python docs/study_merge_table.py /tmp/study_merge [> table.md]
    python docs/study_merge_table.py /tmp/study_merge --figure docs/merge_density.png

Per mainline density, our gap driver (MIMO) / SUMO-native: merges out of the
acceleration lane, the median distance left to its end at the merge, the median time
stopped, the p95 and largest braking of the merge's new follower, and the collisions by
our check and by SUMO's."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

FOLLOWER_PERCENTILE = 95  # as cosim.batch's summary (merge_follower_decel_mps2_p95)


def _runs(folder: Path) -> pd.DataFrame:
    runs = pd.read_csv(folder / "runs.csv")
    return runs[runs["status"] == "ok"]


def _p95(values: pd.Series) -> float:
    v = values.dropna().to_numpy(dtype=float)
    return float(np.percentile(v, FOLLOWER_PERCENTILE)) if v.size else float("nan")


def table(folder: Path) -> str:
    runs = _runs(folder)
    ours = runs[runs["driver"] != "sumo"]
    sumo = runs[runs["driver"] == "sumo"]
    head = ["mainline density (veh/km/lane)", "merges, ours / SUMO's",
            "distance left to the end, median (m)", "stopped, median (s)",
            "follower's max decel p95 (m/s^2)", "follower's max decel, max (m/s^2)",
            "collisions, our check / SUMO's"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for dens in sorted(runs["density"].unique()):
        a, b = ours[ours["density"] == dens], sumo[sumo["density"] == dens]

        def pair(col: str, how: str, digits: int = 1, a=a, b=b) -> str:
            va, vb = getattr(a[col], how)(), getattr(b[col], how)()
            return f"{va:.{digits}f} / {vb:.{digits}f}"

        f = "merge_follower_max_decel_mps2"
        lines.append("| " + " | ".join([
            f"{dens:g}",
            f"{int(a['merge_success'].sum())}/{len(a)} / "
            f"{int(b['merge_success'].sum())}/{len(b)}",
            pair("merge_distance_to_end_m", "median"),
            pair("stopped_time_s", "median"),
            f"{_p95(a[f]):.2f} / {_p95(b[f]):.2f}",
            pair(f, "max", 2),
            f"{int((a['collisions'] > 0).sum())}, {int((a['sumo_collisions'] > 0).sum())} / "
            f"{int((b['collisions'] > 0).sum())}, {int((b['sumo_collisions'] > 0).sum())}",
        ]) + " |")
    return "\n".join(lines) + "\n"


def figure(folder: Path, path: Path) -> None:
    """Against mainline density, our gap driver vs SUMO-native: the share of merges, the
    distance left to the lane's end at the merge (median) and the merge's new
    follower's braking (p95)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = _runs(folder)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for driver, style, label in (("mimo", "o-", "gap driver (MIMO)"),
                                 ("sumo", "s--", "SUMO-native (LC2013)")):
        d = runs[runs["driver"] == driver].groupby("density")
        axes[0].plot(d.size().index, 100.0 * d["merge_success"].mean().to_numpy(), style,
                     label=label)
        med = d["merge_distance_to_end_m"].median()
        axes[1].plot(med.index, med.to_numpy(), style, label=label)
        p95 = d["merge_follower_max_decel_mps2"].apply(_p95)
        axes[2].plot(p95.index, p95.to_numpy(), style, label=label)
    for ax, ylabel in zip(axes, ("merges (% of runs)",
                                 "distance left to the lane's end (m), median",
                                 "merge's new follower: max decel p95 (m/s^2)"), strict=True):
        ax.set_xlabel("mainline density (veh/km/lane)")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].set_ylim(0.0, 105.0)
    axes[0].legend()
    fig.suptitle(f"{folder.name}: merging from the 194.5 m acceleration lane "
                 "(networks/onramp.net.xml), 20 seeds per density")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[2] == "--figure":
        figure(Path(sys.argv[1]), Path(sys.argv[3]))
    else:
        print(table(Path(sys.argv[1])), end="")
