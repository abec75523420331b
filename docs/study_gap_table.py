"""The table of docs/gap_policy.md's "Measured: the density study" from a batch
folder of scenarios/study_gap.toml, one row per driver and variant:

    python docs/study_gap_table.py /tmp/study_gap [> table.md]
    python docs/study_gap_table.py /tmp/study_gap --figure docs/gap_density.png

Per row: lane changes completed at each density, runs with an SV-caused collision by our
check and runs with a collision by SUMO's, the p95 of the new follower's braking per
density (`follower_max_decel_mps2` over the runs that have one), the median lane-change
time and the median minimum TTC per density. The figure is the batch's own density
figure (cosim.plots.batch.plot_summary) of the folder's summary.csv."""

from __future__ import annotations

import json
import math
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from cosim.study.run_table import NO_VARIANT, Driver, RunStatus

# (driver, variant, label), in the order of scenarios/study_gap.toml
ROWS = (
    (Driver.MIMO, "gap", "gap (courtesy), perfect V2V"),
    (Driver.MIMO, "gap_lossy", "gap (courtesy), 100 ms + 10 % loss"),
    (Driver.MIMO, "gap_perception", "gap (courtesy), perception only"),
    (Driver.MIMO, "gap_alone", "gap without courtesy"),
    (Driver.MIMO, "gap_v2v_coop", "gap, cooperative V2V instead of courtesy"),
    (Driver.MIMO, "paper", "paper's method, perfect V2V"),
    (Driver.MIMO, "paper_lossy", "paper's method, 100 ms + 10 % loss"),
    (Driver.MIMO, "paper_perception", "paper's method, perception only"),
    (Driver.SUMO, NO_VARIANT, "SUMO-native"),
)


def _rows(table: pd.DataFrame, driver: str, variant: str) -> pd.DataFrame:
    mine = table[table["driver"] == driver]
    return mine[mine["variant"].fillna(NO_VARIANT).astype(str) == variant]


def _per_density(runs: pd.DataFrame, densities: list[float],
                 cell: Callable[[pd.DataFrame], str]) -> str:
    return " / ".join(cell(runs[runs["density"] == d]) for d in densities)


def _number(column: str, digits: int) -> Callable[[pd.DataFrame], str]:
    """A cell of the summary's `column` (one row per density): "-" where it has none."""
    def cell(row: pd.DataFrame) -> str:
        value = float(row[column].iloc[0]) if len(row) else math.nan
        return f"{value:.{digits}f}" if math.isfinite(value) else "-"
    return cell


def table(folder: Path) -> str:
    """The per-density statistics (the follower's p95, the median minimum TTC) are the
    batch's summary.csv's (cosim.study.summary.summarize); the counts and the lane-change
    time's median over all densities are the runs'."""
    from cosim.run.metrics import FOLLOWER_PERCENTILE
    from cosim.study.summary import summarize

    everything = pd.read_csv(folder / "runs.csv")
    summary = summarize(everything)
    runs = everything[everything["status"] == RunStatus.OK]
    densities = sorted(runs["density"].unique())
    at = " / ".join(f"{d:g}" for d in densities)
    head = ["driver", f"lane changes / 20 runs at {at} veh/km/lane",
            "runs with an SV-caused collision (our check) / with a collision (SUMO's)",
            "`follower_max_decel_mps2` p95 per density (m/s^2)",
            "lane-change time, median (s)", "min TTC, median per density (s)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for driver, variant, label in ROWS:
        rows, cells = _rows(runs, driver, variant), _rows(summary, driver, variant)
        if rows.empty:
            continue
        lines.append("| " + " | ".join([
            label,
            _per_density(rows, densities,
                         lambda r: f"{int(r['lane_change_completed'].sum())}"),
            f"{int((rows['collisions_sv'] > 0).sum())} / "
            f"{int((rows['sumo_collision'] > 0).sum())}",
            _per_density(cells, densities,
                         _number(f"follower_decel_mps2_p{FOLLOWER_PERCENTILE}", 2)),
            f"{rows['lane_change_duration_s'].median():.2f}",
            _per_density(cells, densities, _number("min_ttc_s_p50", 1)),
        ]) + " |")
    return "\n".join(lines) + "\n"


def figure(folder: Path, path: Path) -> None:
    """The batch's density figure of the folder's summary.csv, written to `path`."""
    from cosim.plots.batch import plot_summary

    summary = pd.read_csv(folder / "summary.csv")
    study = folder / "study.json"
    title = json.loads(study.read_text())["title"] if study.is_file() else folder.name
    with tempfile.TemporaryDirectory() as tmp:
        [made] = plot_summary(summary, Path(tmp), title=title, fmt=path.suffix.lstrip("."))
        shutil.move(made, path)


if __name__ == "__main__":
    from study_cli import run  # docs/ itself is on the path of a script run from it

    run(__doc__, table, figure)
