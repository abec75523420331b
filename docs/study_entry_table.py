"""The entry table of docs/gap_policy.md ("The entry rule") from a batch folder of
scenarios/study_entry.toml (the density study's base at 15-65 veh/km/lane, dry and
wet) or of scenarios/study_merge.toml:

    python docs/study_entry_table.py /tmp/study_entry [> table.md]
    python docs/study_entry_table.py /tmp/study_merge
    python docs/study_entry_table.py /tmp/study_entry --figure docs/entry_density.png

Per friction and density, the gap policy / SUMO's driver: lane changes completed of the
runs, runs whose new follower
braked harder than 3 m/s^2 (`follower_max_decel_mps2`), the smallest bumper gap and
the largest needed deceleration at the entry (`entry_follower_gap_m`,
`entry_follower_needed_decel_mps2`), the median request-to-lane time and its ratio,
SV-caused collisions, the median peak jerk, the median share of acceleration jumps
(chatter), runs braking > 3 m/s^2 after the change, and the re-check's emergency-brake
plans, aborts and replans (sums). On a merge study also the median distance left to
the acceleration lane's end at the merge."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from cosim.study.run_table import Driver, RunStatus
from cosim.study.summary import HARD_FOLLOWER_BRAKE

HARD_AFTER = 3.0  # m/s^2, the SV's own braking after the change counted as hard


def _runs(folder: Path) -> pd.DataFrame:
    runs = pd.read_csv(folder / "runs.csv")
    return runs[runs["status"] == RunStatus.OK]


def table(folder: Path) -> str:
    runs = _runs(folder)
    merge = "merge_distance_to_end_m" in runs and runs["merge_distance_to_end_m"].notna().any()
    head = ["mu", "density (veh/km/lane)", "lane changes", "follower > 3 m/s^2",
            "min entry gap m", "max needed decel m/s^2", "request to lane s (median)",
            "ratio", "SV-caused collisions", "peak jerk m/s^3 (median)",
            "ax jump share (median)", "braking > 3 after the change",
            "emergency brakes / aborts / replans"]
    if merge:
        head.append("distance left at the merge m (median)")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (mu, dens), cell in runs.groupby(["mu", "density"]):
        a, b = cell[cell["driver"] != Driver.SUMO], cell[cell["driver"] == Driver.SUMO]

        def pair(col: str, how: str, digits: int, a: pd.DataFrame = a,
                 b: pd.DataFrame = b) -> str:
            return " / ".join(f"{getattr(x[col], how)():.{digits}f}" for x in (a, b))

        def count(col: str, limit: float, a: pd.DataFrame = a, b: pd.DataFrame = b) -> str:
            return " / ".join(f"{int((x[col] > limit).sum())}" for x in (a, b))

        ra, rb = a["request_to_lane_s"].median(), b["request_to_lane_s"].median()
        ratio = ra / rb if np.isfinite(ra) and np.isfinite(rb) and rb > 0 else np.nan
        rescue = " / ".join(
            f"{int(x['emergency_brakes'].sum())}, {int(x['aborts'].sum())}, "
            f"{int(x['replans'].sum())}" for x in (a, b))
        row = [f"{mu:g}", f"{dens:g}",
               " / ".join(f"{int(x['lane_change_completed'].sum())}/{len(x)}" for x in (a, b)),
               count("follower_max_decel_mps2", HARD_FOLLOWER_BRAKE),
               pair("entry_follower_gap_m", "min", 2),
               pair("entry_follower_needed_decel_mps2", "max", 2),
               f"{ra:.2f} / {rb:.2f}", f"{ratio:.2f}",
               " / ".join(f"{int((x['collisions_sv'] > 0).sum())}" for x in (a, b)),
               pair("max_long_jerk_mps3", "median", 0),
               pair("long_accel_jump_share", "median", 3),
               count("post_change_max_decel_mps2", HARD_AFTER), rescue]
        if merge:
            row.append(pair("merge_distance_to_end_m", "median", 1))
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def figure(folder: Path, path: Path) -> None:
    """Against density, the gap policy vs SUMO's driver: the median request-to-lane time
    and the new follower's largest braking (median and max), one line per friction."""
    import matplotlib.pyplot as plt

    from cosim.plots import save_figure

    runs = _runs(folder)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for (driver, mu), d in runs.groupby([runs["driver"] == Driver.SUMO, "mu"]):
        label = f"{'SUMO' if driver else 'gap policy'}, mu {mu:g}"
        g = d.groupby("density")
        style = "s--" if driver else "o-"
        axes[0].plot(g["request_to_lane_s"].median(), style, label=label)
        axes[1].plot(g["follower_max_decel_mps2"].max(), style, label=label)
    axes[0].set_ylabel("request to lane s (median)")
    axes[1].set_ylabel("new follower's braking m/s^2 (max)")
    axes[1].axhline(HARD_FOLLOWER_BRAKE, color="k", lw=0.8)
    for ax in axes:
        ax.set_xlabel("density (veh/km/lane)")
        ax.grid(alpha=0.3)
    axes[0].legend()
    fig.tight_layout()
    save_figure(fig, path)


if __name__ == "__main__":
    from study_cli import run  # docs/ itself is on the path of a script run from it

    run(__doc__, table, figure)
