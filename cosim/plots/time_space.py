"""The time-space diagram of a run (time_space.png): per SV lane, every vehicle's position
along the route over time coloured by its speed, from SUMO's floating-car data
(cosim.traffic.fcd); the SV drawn in black. A stop-and-go wave shows as a band of low
speed whose edges run backwards (upstream) against the traffic.

`cosim run --fcd` draws it for the whole route; a stretch of it, from a run's folder:

    python -m cosim.plots.time_space results/traffic_jam--controller_sumo \
        scenarios/traffic_jam.toml --s 300 1500 --out time_space_jam.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from cosim.plots import save_figure
from cosim.plots.labels import S_LABEL, suptitle
from cosim.traffic.fcd import RouteRecords

KMH = 3.6  # km/h per m/s, for the colour bar only
DRAW_EVERY = 0.5  # s, the records drawn: a wave's edges move over seconds


def time_space(path: Path, records: RouteRecords, tracks: list[int], sv_id: str,
               title: str = "", v_max: float | None = None,
               s_limits: tuple[float, float] | None = None) -> Path:
    """Write the diagram: one panel per track in `tracks` (the leftmost lane on top, as
    seen from above), time across, s up (within `s_limits`, m, if given), each record a
    dot coloured by speed (0 to `v_max` m/s, default the fastest record); `sv_id`'s
    records on that lane in black."""
    top = float(np.max(records.speed)) if v_max is None and len(records.speed) else (v_max or 1.0)
    n = len(tracks)
    fig, axes = plt.subplots(n, 1, figsize=(10, 2.4 * n + 1.0), sharex=True, squeeze=False,
                             layout="constrained")
    sv = records.of(sv_id)
    dots = None
    for row, k in enumerate(sorted(tracks, reverse=True)):
        ax = axes[row, 0]
        on = records.track == k
        other = on & ~sv
        dots = ax.scatter(records.t[other], records.s[other], c=records.speed[other] * KMH,
                          cmap="RdYlGn", vmin=0.0, vmax=top * KMH, s=1.5, linewidths=0,
                          rasterized=True)
        mine = on & sv
        if mine.any():
            ax.plot(records.t[mine], records.s[mine], ".", color="black", markersize=2.5,
                    label="SV")
            ax.legend(loc="upper left", fontsize=8, markerscale=3)
        ax.set_ylabel(f"lane {k}\n{S_LABEL}", fontsize=9)
        if s_limits is not None:
            ax.set_ylim(*s_limits)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time t (s)")
    if dots is not None:
        bar = fig.colorbar(dots, ax=axes[:, 0].tolist(), fraction=0.03, pad=0.01)
        bar.set_label("speed (km/h)")
    if title:
        suptitle(fig, title, fontsize=10)
    save_figure(fig, path)
    return Path(path)


def main(argv: list[str] | None = None) -> int:
    """Draw a run folder's fcd.xml (`cosim run --fcd`) over a stretch of s."""
    from cosim.scenario import load_scenario
    from cosim.traffic.fcd import read_route_records
    from cosim.traffic.route_lanes import load_route_road, sv_tracks
    from cosim.traffic.world import SV_ID

    parser = argparse.ArgumentParser(prog="python -m cosim.plots.time_space",
                                     description=main.__doc__)
    parser.add_argument("run", type=Path, help="the run's folder (with fcd.xml)")
    parser.add_argument("scenario", type=Path, help="its scenario file")
    parser.add_argument("--s", type=float, nargs=2, metavar=("FROM", "TO"),
                        help="the stretch of s drawn (m)")
    parser.add_argument("--out", type=Path, required=True, help="the figure (.png/.svg/.pdf)")
    args = parser.parse_args(argv)
    sc = load_scenario(args.scenario)
    road = load_route_road(sc.network, sc.route)
    records = read_route_records(args.run / "fcd.xml", road, every=DRAW_EVERY)
    top = max(hi for _, hi in sc.road.speed_bands)
    where = f", s {args.s[0]:g}-{args.s[1]:g} m" if args.s else ""
    time_space(args.out, records, [t.id for t in sv_tracks(road)], SV_ID,
               f"{sc.name}: time-space diagram{where}, every vehicle every {DRAW_EVERY:g} s, "
               "coloured by speed", v_max=top, s_limits=(args.s[0], args.s[1]) if args.s else None)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
