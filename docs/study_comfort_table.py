"""The per-density table of docs/gap_policy.md's "Driving quality" section
from a batch folder of scenarios/study_comfort.toml (or its wet twin):

    python docs/study_comfort_table.py /tmp/study_comfort [> table.md]
    python docs/study_comfort_table.py /tmp/study_comfort --figure docs/comfort_density.png

Per density: lane changes completed, SV-caused collisions, the SV's peak jerk and the
share of steps with an acceleration jump > 5 m/s^2 (medians), runs braking > 3 m/s^2
within 3 s after the change, the median time from request to the target lane and the
new follower's median braking, each for the gap policy / SUMO's driver."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from cosim.study.run_table import Driver, RunStatus


def table(folder: Path) -> str:
    runs = pd.read_csv(folder / "runs.csv")
    runs = runs[runs["status"] == RunStatus.OK]
    ours = runs[runs["driver"] != Driver.SUMO]
    sumo = runs[runs["driver"] == Driver.SUMO]
    head = ["density (veh/km/lane)", "lane changes", "SV-caused collisions",
            "peak jerk m/s^3 (median)", "share of ax jumps > 5 m/s^2 (median)",
            "runs braking > 3 m/s^2 after the change", "request to lane s (median)",
            "ratio", "follower braking m/s^2 (median)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for dens in sorted(runs["density"].unique()):
        a, b = ours[ours["density"] == dens], sumo[sumo["density"] == dens]

        def pair(col: str, how: str, digits: int = 2, a=a, b=b) -> str:
            va, vb = getattr(a[col], how)(), getattr(b[col], how)()
            return f"{va:.{digits}f} / {vb:.{digits}f}"

        ra, rb = a["request_to_lane_s"].median(), b["request_to_lane_s"].median()
        lines.append("| " + " | ".join([
            f"{dens:g}",
            f"{int(a['lane_change_completed'].sum())}/{len(a)} / "
            f"{int(b['lane_change_completed'].sum())}/{len(b)}",
            f"{int((a['collisions_sv'] > 0).sum())} / {int((b['collisions_sv'] > 0).sum())}",
            pair("max_long_jerk_mps3", "median", 0),
            pair("long_accel_jump_share", "median", 3),
            f"{int((a['post_change_max_decel_mps2'] > 3.0).sum())} / "
            f"{int((b['post_change_max_decel_mps2'] > 3.0).sum())}",
            f"{ra:.2f} / {rb:.2f}", f"{ra / rb:.2f}",
            pair("follower_max_decel_mps2", "median"),
        ]) + " |")
    return "\n".join(lines) + "\n"


def figure(folder: Path, path: Path) -> None:
    """Medians against density, the gap policy vs SUMO's driver: peak jerk, request to
    the target lane, the merge's time gap, braking after the change, the new
    follower's braking (and the per-run maximum of the braking after the change)."""
    import matplotlib.pyplot as plt

    from cosim.plots import save_figure

    runs = pd.read_csv(folder / "runs.csv")
    runs = runs[runs["status"] == RunStatus.OK]
    panels = [("max_long_jerk_mps3", "peak jerk (m/s^3), median"),
              ("request_to_lane_s", "request to target lane (s), median"),
              ("merge_time_gap_s", "time gap at the merge (s), median"),
              ("post_change_max_decel_mps2", "braking after the change (m/s^2), median"),
              ("follower_max_decel_mps2", "new follower's braking (m/s^2), median")]
    fig, axes = plt.subplots(1, len(panels) + 1, figsize=(22, 4))
    for (col, label), ax in zip(panels, axes, strict=False):
        for driver, style in ((Driver.MIMO, "o-"), (Driver.SUMO, "s--")):
            d = runs[runs["driver"] == driver].groupby("density")[col].median()
            ax.plot(d.index, d.to_numpy(), style,
                    label="gap policy (MIMO)" if driver == Driver.MIMO else "SUMO-native")
        ax.set_xlabel("density (veh/km/lane)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    ax = axes[-1]
    for driver, style in ((Driver.MIMO, "o-"), (Driver.SUMO, "s--")):
        d = runs[runs["driver"] == driver].groupby("density")["post_change_max_decel_mps2"]
        ax.plot(d.max().index, d.max().to_numpy(), style)
    ax.axhline(3.0, color="k", lw=0.8)
    ax.set_xlabel("density (veh/km/lane)")
    ax.set_ylabel("braking after the change (m/s^2), max")
    ax.grid(alpha=0.3)
    axes[0].legend()
    fig.suptitle(f"{folder.name}: the gap policy vs SUMO's driver, "
                 f"mu {', '.join(f'{m:g}' for m in sorted(runs['mu'].unique()))}")
    fig.tight_layout()
    save_figure(fig, path)


if __name__ == "__main__":
    from study_cli import run  # docs/ itself is on the path of a script run from it

    run(__doc__, table, figure)
