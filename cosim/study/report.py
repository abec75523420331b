"""A study's report beside runs.csv: summary.csv (cosim.study.summary's table),
summary.md and comfort.md (its main and its comfort figures as Markdown tables) and the
density figure in DIR/plots/ (cosim.plots.batch); with SUMO's detectors in the runs, the
fundamental diagram (cosim.study.fundamental: fundamental.csv, fundamental.md,
plots/fundamental.png)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd

from cosim.output import atomic_write_csv, atomic_write_text
from cosim.run.metrics import FOLLOWER_PERCENTILE
from cosim.study.intervals import CONFIDENCE
from cosim.study.run_table import NO_PLANT
from cosim.study.summary import summarize


def write_report(runs: pd.DataFrame, out_dir: Path, *, title: str, plots: bool,
                 figure_format: str | None) -> tuple[pd.DataFrame, list[Path]]:
    """Summarise runs.csv's table and write the tables and, if `plots` and there are runs,
    the figure; return the summary and the figures written."""
    summary = summarize(runs)
    write_tables(runs, summary, out_dir)
    figures: list[Path] = []
    if plots and len(runs):
        from cosim.plots.batch import plot_summary

        figures = plot_summary(summary, out_dir / "plots", title=title, fmt=figure_format)
        from cosim.plots.share import plot_share

        figures += plot_share(summary, out_dir / "plots", title=title, fmt=figure_format)
    figures += write_fundamental(runs, out_dir, title=title, plots=plots,
                                 figure_format=figure_format)
    return summary, figures


def write_fundamental(runs: pd.DataFrame, out_dir: Path, *, title: str, plots: bool,
                      figure_format: str | None) -> list[Path]:
    """With SUMO's detectors in the runs (cosim.study.fundamental): fundamental.csv (the
    medians per line, lane and density cell), fundamental.md (capacity and critical
    density) and, if `plots`, plots/fundamental.png; nothing otherwise. Returns the figures."""
    from cosim.study import fundamental as fdm

    if not fdm.traffic_columns(runs):
        return []
    pts = fdm.points(runs)
    fd = fdm.medians(pts)
    cap = fdm.capacity(fd)
    atomic_write_csv(out_dir / "fundamental.csv", fd)
    atomic_write_text(out_dir / "fundamental.md", fdm.capacity_markdown(cap))
    if not plots or fd.empty:
        return []
    from cosim.plots.fundamental import plot_fundamental

    return [plot_fundamental(pts, fd, cap, out_dir / "plots", title=title, fmt=figure_format)]


def comfort_markdown(summary: pd.DataFrame) -> str:
    """The comfort columns of summary.csv as a Markdown table (comfort.md)."""
    head = ["driver", "variant", "mu", "density (veh/km/lane)",
            "max jerk m/s^3: median / max", "ax jumps > 5 m/s^2: median share",
            "merge time gap s: median / min", "decel after change m/s^2: median / max",
            "runs braking > 3 m/s^2 after change", "request to target lane s: median"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def num(value: Any, digits: int = 2) -> str:
        return "-" if not (isinstance(value, float | int) and math.isfinite(value)) \
            else f"{value:.{digits}f}"

    for _, r in summary.iterrows():
        if "max_long_jerk_mps3_p50" not in r:
            continue
        lines.append("| " + " | ".join([
            str(r["driver"]), str(r["variant"]), f"{r['mu']:g}", f"{r['density']:g}",
            f"{num(r['max_long_jerk_mps3_p50'], 0)} / {num(r['max_long_jerk_mps3_max'], 0)}",
            num(r["long_accel_jump_share_p50"], 3),
            f"{num(r['merge_time_gap_s_p50'])} / {num(r['merge_time_gap_s_min'])}",
            f"{num(r['post_change_max_decel_mps2_p50'])} / "
            f"{num(r['post_change_max_decel_mps2_max'])}",
            num(r["hard_post_change_brakes"], 0), num(r["request_to_lane_s_p50"])]) + " |")
    return "\n".join(lines) + "\n"


def interval(low: float, high: float, digits: int = 2, scale: float = 1.0) -> str:
    """A confidence interval as "[low, high]": no hyphen that could read as a minus."""
    return f"[{scale * low:.{digits}f}, {scale * high:.{digits}f}]"


def summary_markdown(summary: pd.DataFrame) -> str:
    """The main figures of summary.csv as a Markdown table (for docs and READMEs):
    rates with Wilson intervals, durations and TTC as medians with the median's
    distribution-free interval (the statistic the plots show too)."""

    def pct(row: pd.Series, name: str) -> str:
        if not math.isfinite(row[f"{name}_rate"]):
            return "-"
        return (f"{100 * row[f'{name}_rate']:.0f} "
                + interval(row[f"{name}_ci_low"], row[f"{name}_ci_high"], 0, 100.0))

    def median(row: pd.Series, name: str) -> str:
        if not math.isfinite(row[f"{name}_p50"]):
            return "-"
        text = f"{row[f'{name}_p50']:.2f}"
        if math.isfinite(row[f"{name}_ci_low"]):
            text += " " + interval(row[f"{name}_ci_low"], row[f"{name}_ci_high"])
            if row[f"{name}_ci_coverage"] < CONFIDENCE:  # too few runs for 95 %
                text += f" ({100 * row[f'{name}_ci_coverage']:.0f} %)"
        return text

    def follower(row: pd.Series) -> str:
        p95 = row.get(f"follower_decel_mps2_p{FOLLOWER_PERCENTILE}", math.nan)
        if not math.isfinite(p95):
            return "-"
        return f"{p95:.2f} / {row['follower_decel_mps2_max']:.2f}"

    def collisions(row: pd.Series) -> str:  # ours, then SUMO's in parentheses
        ours = pct(row, "collision")
        sumo = row.get("sumo_collision_rate", math.nan)
        return ours if not math.isfinite(sumo) else f"{ours} ({100 * sumo:.0f})"

    ours = summary[summary["plant"] != NO_PLANT]
    varying = [c for c in ("variant", "plant", "occupant", "mu", "share", "fleet_driver")
               if c in summary and (ours if c == "plant" else summary)[c].nunique() > 1]
    head = ["driver", *varying, "density (veh/km/lane)", "runs ok / failed",
            "unfinished", "success % of finished [95 % CI]",
            "collision % [95 % CI] (SUMO's %)", "SV-caused collision % [95 % CI]",
            "lane-change duration s: median [95 % CI]", "min TTC s: median [95 % CI]",
            "new follower's max decel m/s^2: p95 / max"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, row in summary.iterrows():
        cells = [str(row["driver"]), *(f"{row[c]}" for c in varying), f"{row['density']:g}",
                 f"{row['ok']} / {row['failed']}", f"{row.get('unfinished', 0)}",
                 pct(row, "success"), collisions(row),
                 pct(row, "sv_collision"), median(row, "lc_duration_s"),
                 median(row, "min_ttc_s"), follower(row)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_tables(runs: pd.DataFrame, summary: pd.DataFrame, out_dir: Path) -> None:
    """runs.csv, summary.csv, summary.md and comfort.md, each replaced atomically."""
    atomic_write_csv(out_dir / "runs.csv", runs)
    atomic_write_csv(out_dir / "summary.csv", summary)
    atomic_write_text(out_dir / "summary.md", summary_markdown(summary))
    atomic_write_text(out_dir / "comfort.md", comfort_markdown(summary))
    if has_fleet_figures(summary):
        atomic_write_text(out_dir / "fleet.md", fleet_markdown(summary))


# (summary column, table heading, digits) of fleet.md
FLEET_TABLE = (
    ("fleet_vehicles", "AVs", 1),
    ("fleet_lane_changes_per_vehicle", "lane changes per AV", 2),
    ("fleet_collisions", "AV collisions (ours)", 2),
    ("fleet_caused_collisions", "AV-caused", 2),
    ("fleet_sumo_collisions", "SUMO's", 2),
    ("fleet_max_long_jerk_mps3", "AV peak jerk m/s^3 (median over AVs)", 1),
    ("fleet_follower_max_decel_mps2", "AV follower's max decel m/s^2", 2),
    ("fleet_mean_speed_mps", "AV mean speed m/s", 2),
    ("traffic_speed_mps", "traffic speed m/s", 2),
    ("outflow_veh_per_h", "outflow veh/h", 0),
    ("speed_spread_space_mps", "speed spread m/s", 2),
    ("ssm_conflicts_per_vehicle_km", "SSM conflicts per veh-km", 3),
)


def has_fleet_figures(summary: pd.DataFrame) -> bool:
    """Whether the study varies the share or its runs have fleet figures (fleet.md)."""
    return ("share" in summary and summary["share"].nunique() > 1) or any(
        f"{name}_mean" in summary for name, _, _ in FLEET_TABLE[:2])


def fleet_markdown(summary: pd.DataFrame) -> str:
    """fleet.md: per cell the automated vehicles' and the traffic's means over the runs
    with their 95 % Student-t intervals (cosim.study.fleet_summary), columns the runs lack
    left out."""
    from cosim.study.fleet_summary import mean_text

    columns = [(n, h, d) for n, h, d in FLEET_TABLE if f"{n}_mean" in summary]
    keys = [c for c in ("driver", "fleet_driver", "variant", "mu")
            if c in summary and summary[c].nunique() > 1]
    head = [*keys, "share", "density (veh/km/lane)", "runs ok",
            *(h for _, h, _ in columns)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, row in summary.iterrows():
        # share 0: no automated vehicle, one run whatever the fleet driver
        cells = [*("-" if k == "fleet_driver" and row.get("share", 0.0) == 0.0 else str(row[k])
                   for k in keys), f"{row.get('share', 0.0):g}",
                 f"{row['density']:g}", f"{row['ok']}",
                 *(mean_text(row, n, d) for n, _, d in columns)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
