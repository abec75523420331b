"""The per-density table of docs/gap_policy.md's "Driving quality" section (issue 22)
from a batch folder of scenarios/study_comfort.toml (or its wet twin):

    python docs/study_comfort_table.py /tmp/study_comfort [> table.md]

Per density: lane changes completed, SV-caused collisions, the SV's peak jerk and the
share of steps with an acceleration jump > 5 m/s^2 (medians), runs braking > 3 m/s^2
within 3 s after the change, the median time from request to the target lane and the
new follower's median braking, each for the gap policy / SUMO's driver."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd


def table(folder: Path) -> str:
    runs = pd.read_csv(folder / "runs.csv")
    runs = runs[runs["status"] == "ok"]
    ours = runs[runs["driver"] != "sumo"]
    sumo = runs[runs["driver"] == "sumo"]
    head = ["density (veh/km/lane)", "lane changes", "SV-caused collisions",
            "peak jerk m/s^3 (median)", "share of |da| > 5 m/s^2 (median)",
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


if __name__ == "__main__":
    print(table(Path(sys.argv[1])), end="")
