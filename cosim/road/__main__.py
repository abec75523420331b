"""`python -m cosim.road NETWORK [EDGE ...]`: what the road layer makes of a SUMO
network and route (before the loop drives on it): the frame's deviation from SUMO's
lanes and its smallest radius, each track with its SUMO lane on every edge and its s
range (`--plot FILE`: and a figure of them); a network it cannot support: one line,
exit 2."""

from __future__ import annotations

import argparse
import math
import sys

from cosim.errors import InputError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cosim.road", description=__doc__)
    parser.add_argument("network", help="SUMO .net.xml")
    parser.add_argument("edges", nargs="*", help="the route's edge ids (none: the only edge)")
    parser.add_argument("--plot", metavar="FILE", default=None,
                        help="draw the road (x-y map, curvature along s) to FILE (.png/.svg/.pdf)")
    args = parser.parse_args(argv)
    from cosim.road.road import load_road

    try:
        road = load_road(args.network, args.edges or None)
    except InputError as exc:
        print(f"python -m cosim.road: {exc}", file=sys.stderr)
        return 2
    frame, q = road.frame, road.frame.quality
    radius = "inf" if math.isinf(q.min_radius) else f"{q.min_radius:.0f} m"
    print(f"route {' '.join(road.route.edges)}: {type(frame).__name__}, s 0 to "
          f"{frame.length:.2f} m, deviation from SUMO's lanes {road.max_deviation:.3f} m, "
          f"smallest radius {radius} (SUMO's largest kink "
          f"{math.degrees(q.max_kink):.2f} deg, smoothing length {q.smoothing_length:.1f} m"
          f"{'; a coarse curve, smoothed beyond max_deviation' if q.coarse else ''})")
    for sh in road.shifts:
        lo, hi = sh.window
        print(f"SUMO's lanes step {abs(sh.jump):.2f} m to the "
              f"{'left' if sh.jump > 0 else 'right'} at s {sh.s:.1f} m: the frame shifts "
              f"with them from s {lo:.1f} to {hi:.1f} m (its lanes' deviation is measured "
              "outside)")
    for c in road.corners:
        place = c.junction if " vertex " in c.junction else f"junction {c.junction}"
        print(f"{place} is drawn as a corner ({math.degrees(abs(c.turn)):.0f} "
              f"degrees to the {'left' if c.turn > 0 else 'right'}): the frame rounds it "
              f"from s {c.s_lo:.1f} to {c.s_hi:.1f} m, R {c.radius:.1f} m between "
              f"clothoids of {c.spiral:.1f} m (its lane's R "
              f"{c.lane_radius:.1f} m, {c.deviation:.2f} m from SUMO's corner; the lanes' "
              "deviation is measured outside)")
    for t in road.lanes:
        lanes = " ".join(f"{p.lane}[{p.index}]" for p in t.track.pieces if not p.internal)
        ref = " (reference)" if t.track is road.reference else ""
        if t.track.joins >= 0:  # one SV lane with the lane it joins (cosim.road.tracks)
            ref += f" (joins track {t.track.joins}: one SV lane)"
        print(f"track {t.id}{ref}: s {t.begin:.1f} to {t.end:.1f} m, centre d "
              f"{t.centre(t.begin):.3f} m, deviation {t.deviation:.3f} m: {lanes}")
    if args.plot:
        from pathlib import Path

        from cosim.plots.road import plot_road

        print(f"wrote {plot_road(road, Path(args.plot))}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
