"""Figures of the SUMO traffic: speed distribution per lane against its band, a top view.

    python -m cosim.plots.traffic --density 16 --seed 1 --out results/traffic_speeds.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib.pyplot as plt  # Agg: cosim/plots/__init__.py selects it
import numpy as np
from matplotlib.patches import Rectangle

from cosim.params import RoadParams
from cosim.plots import save_figure
from cosim.traffic.demand import LaneSpeeds, sample_lane_speeds
from cosim.traffic.network import DEFAULT_NETWORK
from cosim.traffic.sumo import TrafficSnapshot

KMH = 3.6  # km/h per m/s, for the axes only
LANE_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")


def plot_lane_speeds(samples: LaneSpeeds, path: Path) -> Path:
    """Histogram of TV speeds per lane (km/h) over its band (shaded); writes `path`."""
    n = len(samples.speeds)
    fig, axes = plt.subplots(n, 1, figsize=(7.5, 1.9 * n + 0.8), sharex=True)
    axes = np.atleast_1d(axes)
    inside = samples.inside()
    all_v = np.concatenate([v for v in samples.speeds if len(v)] or [np.zeros(1)]) * KMH
    edges = np.arange(np.floor(all_v.min()) - 2.0, np.ceil(all_v.max()) + 3.0, 1.0)
    for lane in range(n - 1, -1, -1):  # leftmost lane on top, as seen from above
        ax = axes[n - 1 - lane]
        lo, hi = (b * KMH for b in samples.bands[lane])
        ax.axvspan(lo, hi, color=LANE_COLOURS[lane % 5], alpha=0.12, label="band")
        v = samples.speeds[lane] * KMH
        ax.hist(v, bins=edges, color=LANE_COLOURS[lane % 5], density=True)
        ax.set_ylabel(f"lane {lane}")
        ax.text(
            0.01, 0.92, f"{lo:.0f}-{hi:.0f} km/h: {100 * inside[lane]:.1f} % inside, "
            f"median {np.median(v) if len(v) else float('nan'):.1f} km/h, n = {len(v)}",
            transform=ax.transAxes, va="top", fontsize=8,
        )  # fmt: skip
        ax.set_yticks([])
    axes[-1].set_xlabel("speed (km/h)")
    fig.suptitle(
        f"TV speeds per lane: {samples.density:g} veh/km/lane, {samples.duration:g} s, "
        f"{samples.lane_changes} TV lane changes",
        fontsize=10,
    )
    fig.tight_layout()
    save_figure(fig, path)
    return Path(path)


def plot_snapshot(
    snap: TrafficSnapshot,
    road: RoadParams,
    path: Path,
    x_range: tuple[float, float],
    highlight: tuple[str, ...] = (),
) -> Path:
    """Top view of the road between x_range (m): every vehicle's body rectangle."""
    lo, hi = x_range
    fig, ax = plt.subplots(figsize=(12, 2.6))
    top = road.y_right + road.n_lanes * road.lane_width
    for k in range(road.n_lanes + 1):
        y = road.y_right + k * road.lane_width
        ax.axhline(y, color="0.3", lw=1.2 if k in (0, road.n_lanes) else 0.6,
                   ls="-" if k in (0, road.n_lanes) else "--")  # fmt: skip
    shown = (snap.x > lo - 10.0) & (snap.x < hi + 10.0)
    for i in np.flatnonzero(shown):
        length, width, h = snap.length[i], snap.width[i], snap.heading[i]
        c, s = np.cos(h), np.sin(h)
        # Rectangle takes the rear-right corner and turns about it
        corner = (
            snap.x[i] - 0.5 * (length * c - width * s),
            snap.y[i] - 0.5 * (length * s + width * c),
        )
        colour = "tab:red" if snap.ids[i] in highlight else LANE_COLOURS[max(snap.lane[i], 0) % 5]
        ax.add_patch(Rectangle(corner, length, width, angle=np.degrees(h), color=colour))
        ax.text(snap.x[i], snap.y[i] + 0.6 * width, f"{snap.speed[i] * KMH:.0f}", fontsize=6,
                ha="center")  # fmt: skip
    ax.set_xlim(lo, hi)
    ax.set_ylim(road.y_right - 0.5, top + 0.5)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"t = {snap.time:.2f} s (numbers: km/h)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
    return Path(path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cosim.plots.traffic", description=__doc__)
    parser.add_argument("--density", type=float, default=16.0, help="veh/km/lane")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--duration", type=float, default=60.0, help="s")
    parser.add_argument("--network", type=Path, default=DEFAULT_NETWORK)
    parser.add_argument("--out", type=Path, default=Path("results/traffic_speeds.png"))
    args = parser.parse_args(argv)
    samples = sample_lane_speeds(args.network, args.density, args.seed, args.duration)
    print(f"wrote {plot_lane_speeds(samples, args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
