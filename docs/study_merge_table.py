"""The per-density table and figure of the merge study (docs/merge_study.md, docs/roads.md
"The merge study") from a batch folder of scenarios/study_merge.toml:

    python docs/study_merge_table.py /tmp/study_merge [> table.md]
    python docs/study_merge_table.py /tmp/study_merge --figure docs/merge_density.png

Per mainline density, our gap driver (MIMO) / SUMO-native: merges out of the
acceleration lane, the median distance left to its end at the merge, the median time
stopped, the p95 and largest braking of the merge's new follower (each cell's figures
as the batch's summary.csv has them: cosim.study.summary.merge_summary), and the collisions by
our check and by SUMO's."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from cosim.run.metrics import FOLLOWER_PERCENTILE
from cosim.study.run_table import Driver, RunStatus
from cosim.study.summary import merge_summary

P95 = f"merge_follower_decel_mps2_p{FOLLOWER_PERCENTILE}"


def cells(folder: Path) -> pd.DataFrame:
    """One row per (driver, density) of the finished runs: merge_summary's columns and
    the runs with a collision by our check (`ours`) and by SUMO's (`sumo`)."""
    runs = pd.read_csv(folder / "runs.csv")
    runs = runs[runs["status"] == RunStatus.OK]
    rows = {key: {**merge_summary(g), "ours": int((g["collisions"] > 0).sum()),
                  "sumo": int((g["sumo_collisions"] > 0).sum())}
            for key, g in runs.groupby(["driver", "density"])}
    return pd.DataFrame.from_dict(rows, orient="index")


def table(folder: Path) -> str:
    c = cells(folder)
    head = ["mainline density (veh/km/lane)", "merges, ours / SUMO's",
            "distance left to the end, median (m)", "stopped, median (s)",
            "follower's max decel p95 (m/s^2)", "follower's max decel, max (m/s^2)",
            "collisions, our check / SUMO's"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for dens in sorted(c.index.get_level_values(1).unique()):
        a, b = c.loc[(Driver.MIMO, dens)], c.loc[(Driver.SUMO, dens)]

        def pair(col: str, digits: int, a: pd.Series = a, b: pd.Series = b) -> str:
            return f"{a[col]:.{digits}f} / {b[col]:.{digits}f}"

        def merges(r: pd.Series) -> str:
            return f"{round(r['merge_success_rate'] * r['merge_n'])}/{int(r['merge_n'])}"

        lines.append("| " + " | ".join([
            f"{dens:g}", f"{merges(a)} / {merges(b)}",
            pair("merge_distance_to_end_m_p50", 1), pair("stopped_time_s_p50", 1),
            pair(P95, 2), pair("merge_follower_decel_mps2_max", 2),
            f"{a['ours']:.0f}, {a['sumo']:.0f} / {b['ours']:.0f}, {b['sumo']:.0f}",
        ]) + " |")
    return "\n".join(lines) + "\n"


def figure(folder: Path, path: Path) -> None:
    """Against mainline density, our gap driver vs SUMO-native: the share of merges, the
    distance left to the lane's end at the merge (median) and the merge's new
    follower's braking (p95)."""
    import matplotlib.pyplot as plt

    from cosim.plots import save_figure

    c = cells(folder)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for driver, style, label in ((Driver.MIMO, "o-", "gap driver (MIMO)"),
                                 (Driver.SUMO, "s--", "SUMO-native (LC2013)")):
        d = c.loc[driver]
        for ax, values in zip(axes, (100.0 * d["merge_success_rate"],
                                     d["merge_distance_to_end_m_p50"], d[P95]), strict=True):
            ax.plot(d.index, values.to_numpy(), style, label=label)
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
    save_figure(fig, path)


if __name__ == "__main__":
    from study_cli import run  # docs/ itself is on the path of a script run from it

    run(__doc__, table, figure)
