"""SUMO's own detectors along the SV's route (`[detectors]`): SUMO measures, cosim places
them and turns what SUMO wrote into one tidy table (detectors.csv).

Placement (`place_detectors`), on every SV lane of the route (route_lanes.sv_tracks: the
tracks through or ending on it): an induction loop (E1) at s = 0, spacing, 2 spacing, ...
up to the lane's end, LANE_END_INSET inside the start and the end of each lane that ends
(an acceleration lane, a lane drop) and at each of the user's positions; lane-area
detectors (E2) only as `areas` asks, at least MIN_AREA_LENGTH long, on one SUMO lane
each: with "lanes" one over each SUMO lane of a track from its first loop to its last,
with "stretches" one over each stretch between two consecutive loops on one SUMO lane (a
stretch across a junction gets none). None by default for their cost: SUMO follows every
vehicle on an E2 every step, and the cost grows with the road they cover and with their
number (docs/outputs.md: per stretch 25-35 % of a dense run's CPU, per lane about 10 %,
the loops a few %). Per lane, "lanes" measures what "stretches" does on average (an
E2's vehicles and their speeds add up over the stretches it covers).
A point s of a track maps to SUMO's (lane, lane position) through RouteLanes.place (on a
junction's lane: the start of the next edge), and a detector's s is read back from where
it is (route_lanes.s_of_lane_position), so s_m says where SUMO measures.

SUMO writes its outputs (every detector's intervals of `period`) into a folder the caller
gives (run_scenario: its temporary folder, like fcd.xml); once SUMO has closed, `table`
reads them (ElementTree) into rows of COLUMNS. The detectors are passive: the vehicles
move alike with or without them.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cosim.road.road import Road
from cosim.scenario.model import DetectorSpec
from cosim.traffic.route_lanes import RouteLanes, s_of_lane_position

LANE_END_INSET = 3.0  # m, loops inside a lane that ends: a car waiting at its end covers it
# m, a stretch between two loops shorter than this (a few cars) gets no lane-area detector:
# a density over it says no more than the loop at its start
MIN_AREA_LENGTH = 10.0
S_RESOLUTION = 0.1  # m, loops of a track closer along s than this are one
E1_FILE = "detectors-e1.xml"  # SUMO's outputs, in the caller's folder
E2_FILE = "detectors-e2.xml"

COLUMNS = ("begin_s", "end_s", "detector", "kind", "lane", "track", "s_m", "length_m",
           "flow_veh_per_h", "density_veh_per_km", "occupancy_pct", "mean_speed_mps",
           "vehicles")


@dataclass(frozen=True)
class Detector:
    """One SUMO detector: an induction loop (kind "e1") or a lane-area detector ("e2")."""

    id: str  # SUMO's id: e1_t<track>_s<s>, e2_t<track>_s<s>-<s of its end>
    kind: str  # "e1" or "e2"
    lane: str  # SUMO lane id
    track: int  # the route's track (cosim.road.tracks) the lane belongs to
    position: float  # m, SUMO lane position (an E2's start)
    end: float  # m, an E2's end lane position (an E1's: its position)
    s: float  # m, along the route (an E2's start)

    @property
    def length(self) -> float:
        """m, an E2's length on its lane (an E1: 0)."""
        return self.end - self.position


@dataclass(frozen=True)
class DetectorLayout:
    """The detectors of a run and their aggregation period."""

    detectors: tuple[Detector, ...]
    period: float  # s

    def additional(self, folder: Path) -> str:
        """SUMO's additional file declaring them, their outputs going into `folder`."""
        root = ET.Element("additional")
        files = {"e1": str(Path(folder) / E1_FILE), "e2": str(Path(folder) / E2_FILE)}
        for d in self.detectors:
            common = {"id": d.id, "lane": d.lane, "pos": repr(d.position),
                      "period": repr(self.period), "file": files[d.kind]}
            if d.kind == "e1":
                ET.SubElement(root, "inductionLoop", common)
            else:
                ET.SubElement(root, "laneAreaDetector", {**common, "endPos": repr(d.end)})
        ET.indent(root)
        return ET.tostring(root, encoding="unicode") + "\n"

    def table(self, folder: Path, t0: float = 0.0) -> Any:
        """detectors.csv's rows (a pandas DataFrame of COLUMNS) from SUMO's outputs in
        `folder`, one per interval and detector, by interval then detector (the layout's
        order); times on the run's clock (SUMO's minus `t0`, the warm-up)."""
        import pandas as pd

        by_id = {d.id: (k, d) for k, d in enumerate(self.detectors)}
        rows = []
        for name in (E1_FILE, E2_FILE):
            path = Path(folder) / name
            if not path.is_file():  # no detector of that kind
                continue
            for interval in ET.parse(path).getroot().iter("interval"):
                k, d = by_id[interval.attrib["id"]]
                rows.append((float(interval.attrib["begin"]), k, _row(d, interval.attrib, t0)))
        rows.sort(key=lambda r: (r[0], r[1]))
        return pd.DataFrame([r[2] for r in rows], columns=list(COLUMNS))


def _speed(value: str) -> float:
    """m/s, SUMO's mean speed (-1: no vehicle, NaN)."""
    v = float(value)
    return math.nan if v < 0 else v


def _row(d: Detector, a: dict[str, str], t0: float) -> tuple[Any, ...]:
    """One output row of detector `d` from the attributes of its SUMO interval."""
    begin, end = float(a["begin"]) - t0, float(a["end"]) - t0
    if d.kind == "e1":
        return (begin, end, d.id, d.kind, d.lane, d.track, d.s, math.nan, float(a["flow"]),
                math.nan, float(a["occupancy"]), _speed(a["speed"]), int(a["nVehContrib"]))
    density = float(a["meanVehicleNumber"]) / (d.length / 1000.0)
    return (begin, end, d.id, d.kind, d.lane, d.track, d.s, d.length, math.nan, density,
            float(a["meanOccupancy"]), _speed(a["meanSpeed"]), int(a["nVehEntered"]))


def _name(s: float) -> str:
    """s (m) in a detector's id: to S_RESOLUTION, never "-0"."""
    return f"{round(s, 1) + 0.0:g}"


def loop_positions(lanes: RouteLanes, track: int, spec: DetectorSpec) -> list[float]:
    """s (m) of a track's loops, ascending: the spacing's grid (the first from s = 0),
    the start and end of a lane that ends (LANE_END_INSET inside) and the user's
    positions, those where the track runs (held to its ends), one per S_RESOLUTION."""
    table = lanes.table(track)
    begin, end = table.begin, table.end
    wanted = [k * spec.spacing for k in range(int(math.floor(end / spec.spacing)) + 1)]
    if track not in {t.id for t in lanes.through} and end - begin > 2 * LANE_END_INSET:
        wanted += [begin + LANE_END_INSET, end - LANE_END_INSET]
    wanted += list(spec.positions)
    # a track on a curve begins a little off s = 0 (the frame's projection): 1 m's slack
    found = sorted({min(max(s, begin), end) for s in wanted if begin - 1.0 <= s <= end})
    kept: list[float] = []
    for s in found:
        if not kept or s - kept[-1] >= S_RESOLUTION:
            kept.append(s)
    return kept


def _area_ends(loops: list[Detector], areas: str) -> list[tuple[Detector, Detector]]:
    """The (first, last) loops of each lane-area detector of a track's loops (by s):
    "stretches", each two consecutive loops on one SUMO lane; "lanes", the first and the
    last loop of each run of loops on one SUMO lane; "none", none."""
    if areas == "none":
        return []
    if areas == "stretches":
        return [(a, b) for a, b in zip(loops, loops[1:], strict=False) if a.lane == b.lane]
    runs: list[list[Detector]] = []
    for d in loops:
        if runs and runs[-1][-1].lane == d.lane:
            runs[-1].append(d)
        else:
            runs.append([d])
    return [(run[0], run[-1]) for run in runs if len(run) > 1]


def place_detectors(route_road: Road, spec: DetectorSpec) -> DetectorLayout:
    """The run's detectors on the route's SV lanes (see the module docstring)."""
    lanes = RouteLanes(route_road)
    loops: list[Detector] = []
    areas: list[Detector] = []
    ids: set[str] = set()

    def unique(name: str) -> str:  # (two s rounding alike: never on SUMO's ids)
        k, found = 1, name
        while found in ids:
            k, found = k + 1, f"{name}_{k + 1}"
        ids.add(found)
        return found

    for table in lanes.sv:
        placed: list[Detector] = []
        seen: set[tuple[str, float]] = set()
        for s in loop_positions(lanes, table.id, spec):
            place = lanes.place(table.id, s)
            piece = table.track.piece_on(place.edge)
            assert piece is not None  # place() names one of the track's edges
            if (piece.lane, place.position) in seen:  # two s on one spot (a junction's)
                continue
            seen.add((piece.lane, place.position))
            at = s_of_lane_position(route_road, piece.lane, place.position)
            placed.append(Detector(unique(f"e1_t{table.id}_s{_name(at)}"), "e1", piece.lane,
                                   table.id, place.position, place.position, at))
        loops += placed
        for a, b in _area_ends(placed, spec.areas):
            if b.position - a.position >= MIN_AREA_LENGTH:
                areas.append(Detector(unique(f"e2_t{table.id}_s{_name(a.s)}-{_name(b.s)}"),
                                      "e2", a.lane, table.id, a.position, b.position, a.s))
    return DetectorLayout(tuple(loops + areas), spec.period)
