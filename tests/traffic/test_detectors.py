"""SUMO's detectors along the SV's route (`[detectors]`, cosim.traffic.detectors), in
real SUMO: detectors.csv holds SUMO's own values (read here from its raw XML, apart from
ours), E2 densities agree with our own count of the vehicles on each stretch, a run
without detectors writes what it wrote before (with them: metrics.csv's traffic columns
added), and on a curved route of several edges and on an on-ramp every detector lies on a
lane of its track, within the lane."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from cosim.errors import InputError
from cosim.road.route import read_network
from cosim.run.loop import CoSimulation, run_scenario
from cosim.scenario import load_scenario, with_overrides
from cosim.traffic.detectors import (
    COLUMNS,
    E1_FILE,
    E2_FILE,
    LANE_END_INSET,
    place_detectors,
)
from cosim.traffic.route_lanes import load_route_road, s_of_lane_position
from cosim.traffic.traffic_measures import ROAD_DOCS

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
PERIOD = 20.0  # s


def _on(name: str, **keys: Any) -> Any:
    return with_overrides(load_scenario(SCENARIOS / f"{name}.toml"),
                          **{"detectors.enabled": True, "detectors.areas": "stretches", **keys})


def _sumo_intervals(folder: Path) -> dict[tuple[str, float], dict[str, str]]:
    """(detector id, begin) -> the attributes of SUMO's interval, from its raw XML."""
    out = {}
    for name in (E1_FILE, E2_FILE):
        for node in ET.parse(folder / name).getroot():
            if node.tag == "interval":
                out[(node.get("id"), float(node.get("begin")))] = dict(node.attrib)
    return out


@pytest.fixture(scope="module")
def dense(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """traffic_high, 60 s, loops every 500 m, 20 s periods; after every SUMO step our
    own count of the vehicles on each E2 stretch from the snapshots (cosim's track and
    body extent along s: on this straight one-edge road s is x), counted as SUMO counts
    a step: by the lane a vehicle had when the step began (SUMO changes lanes after
    moving), while any part of it is on the stretch during the step (the step it leaves
    by the end, too: its back was on it before)."""
    folder = tmp_path_factory.mktemp("sumo")
    sc = _on("traffic_high", duration=60.0, **{"detectors.period_s": PERIOD})
    sim = CoSimulation(sc, detector_output=folder)
    areas = [d for d in sim.world.measures.detectors.detectors if d.kind == "e2"]
    counts: dict[tuple[str, int], list[int]] = defaultdict(list)
    before: dict[str, tuple[int, float]] = {}  # id -> (track, back) at the step's start
    dt = sc.step

    def count(sumo: Any) -> None:
        snap = sumo.snapshot()
        k = int(math.floor((sumo.time - dt) / PERIOD + 1e-9))  # SUMO's interval of the step
        was = [before.get(v, (-1, math.inf)) for v in snap.ids]  # inserted now: not yet
        lane = np.array([w[0] for w in was])
        back = np.array([w[1] for w in was])
        front = snap.x + 0.5 * snap.length
        for d in areas:
            on = (lane == d.track) & (front > d.s) & (back < d.s + d.length)
            counts[(d.id, k)].append(int(np.count_nonzero(on)))
        before.clear()
        backs = (snap.x - 0.5 * snap.length).tolist()
        before.update(zip(snap.ids, zip(snap.lane.tolist(), backs, strict=True), strict=True))

    sim.world.sumo.add_hook(count)
    result = sim.run()
    return {"scenario": sc, "result": result, "sumo": _sumo_intervals(folder),
            "counts": counts, "layout": sim.world.measures.detectors}


def test_the_table_holds_sumos_own_values(dense: dict[str, Any]) -> None:
    """Every interval SUMO wrote is one row, and its flow, occupancy, mean speed and
    vehicles are SUMO's (-1 for no vehicle: NaN); an E2's density is SUMO's
    meanVehicleNumber over its length."""
    table, sumo = dense["result"].detectors, dense["sumo"]
    assert list(table.columns) == list(COLUMNS)
    assert len(table) == len(sumo) == 4 * len(dense["layout"].detectors)  # 3 full + 1 step
    assert {(r.detector, r.begin_s) for r in table.itertuples()} == set(sumo)
    for r in table.itertuples():
        a = sumo[(r.detector, r.begin_s)]
        assert r.end_s == float(a["end"])
        if r.kind == "e1":
            speed, vehicles = float(a["speed"]), int(a["nVehContrib"])
            assert r.flow_veh_per_h == float(a["flow"])
            assert r.occupancy_pct == float(a["occupancy"])
            assert math.isnan(r.density_veh_per_km) and math.isnan(r.length_m)
        else:
            speed, vehicles = float(a["meanSpeed"]), int(a["nVehEntered"])
            assert r.occupancy_pct == float(a["meanOccupancy"])
            assert r.density_veh_per_km == float(a["meanVehicleNumber"]) / (r.length_m / 1e3)
            assert math.isnan(r.flow_veh_per_h)
        assert r.vehicles == vehicles
        assert (math.isnan(r.mean_speed_mps) if speed == -1 else r.mean_speed_mps == speed)
    full = table[table.end_s - table.begin_s == PERIOD]
    assert (full.vehicles > 0).sum() > len(full) / 3  # the traffic passes most of them


def test_e2_density_is_our_count_of_the_vehicles_on_the_stretch(dense: dict[str, Any]
                                                                 ) -> None:
    """Over each full period, the mean number of vehicles on an E2 stretch (ours: the
    snapshots, counted as the fixture says) over its length is SUMO's density, within
    the 0.005 vehicles of its meanVehicleNumber's 2 decimals (well within 1 % on the
    busy stretches)."""
    table, counts = dense["result"].detectors, dense["counts"]
    steps = round(PERIOD / dense["scenario"].step)
    rows = table[(table.kind == "e2") & (table.end_s - table.begin_s == PERIOD)]
    assert len(rows) == 3 * 36
    busy = 0
    for r in rows.itertuples():
        seen = counts[(r.detector, int(r.begin_s // PERIOD))]
        assert len(seen) == steps
        km = r.length_m / 1e3
        ours = float(np.mean(seen)) / km
        assert ours == pytest.approx(r.density_veh_per_km, rel=0.0, abs=0.0051 / km), (
            r.detector, r.begin_s)
        if ours > 20.0:  # 10 vehicles on 500 m
            busy += 1
            assert ours == pytest.approx(r.density_veh_per_km, rel=0.01)
    assert busy > 40  # the dense traffic's stretches, not empty ones only


def test_without_detectors_a_run_writes_what_it_wrote_before(tmp_path: Path) -> None:
    """No [detectors] table and `enabled = false` write the same files, byte for byte
    (timing.csv aside), and no detectors.csv; with detectors the vehicles move alike
    (trace.csv, plans.csv the same bytes, metrics.csv the same values before the traffic's
    columns) and detectors.csv is added."""
    base = load_scenario(SCENARIOS / "traffic_high.toml")
    assert "detectors" not in base.document
    runs = {"absent": with_overrides(base, duration=10.0),
            "off": with_overrides(base, duration=10.0, **{"detectors.enabled": False}),
            "on": with_overrides(base, duration=10.0, **{"detectors.enabled": True,
                                                         "detectors.areas": "stretches",
                                                         "detectors.period_s": 5.0})}
    for name, sc in runs.items():
        run_scenario(sc, tmp_path / name, write_figures=False)
    files = {name: sorted(p.name for p in (tmp_path / name).iterdir()) for name in runs}
    assert files["absent"] == files["off"] == ["metrics.csv", "plans.csv", "timing.csv",
                                               "trace.csv"]
    for name in ("metrics.csv", "plans.csv", "trace.csv"):
        assert (tmp_path / "off" / name).read_bytes() == (tmp_path / "absent" / name
                                                          ).read_bytes()
    assert files["on"] == ["detectors.csv", *files["absent"]]
    for name in ("plans.csv", "trace.csv"):
        assert (tmp_path / "on" / name).read_bytes() == (tmp_path / "absent" / name
                                                         ).read_bytes()
    # metrics.csv: the same values, then the traffic's columns (cosim.traffic.traffic_measures)
    before = pd.read_csv(tmp_path / "absent" / "metrics.csv", dtype=str, keep_default_na=False)
    after = pd.read_csv(tmp_path / "on" / "metrics.csv", dtype=str, keep_default_na=False)
    assert list(after.columns[:len(before.columns)]) == list(before.columns)
    assert after[before.columns].equals(before)
    assert list(after.columns[len(before.columns):])[:len(ROAD_DOCS)] == list(ROAD_DOCS)
    written = pd.read_csv(tmp_path / "on" / "detectors.csv")
    layout = place_detectors(load_route_road(base.network, base.route), runs["on"].detectors)
    assert list(written.columns) == list(COLUMNS)
    assert list(written.detector[written.begin_s == 0.0]) == [d.id for d in layout.detectors]
    assert sorted(set(written.begin_s)) == [0.0, 5.0, 10.0]  # and SUMO's one step more
    e1 = written[written.kind == "e1"]
    assert e1.density_veh_per_km.isna().all() and e1.length_m.isna().all()
    assert written[written.kind == "e2"].flow_veh_per_h.isna().all()


def test_detectors_on_a_curved_route_lie_on_their_tracks_lanes(tmp_path: Path) -> None:
    """curved_traffic_high (four edges, a lane added on the right): every detector's
    lane is a lane of its track on a route edge, its positions within that lane, its s
    where that lane position is, loops every 500 m along s (at most a junction's lane
    away: moved to the next edge's start); an E2 lies on one lane between two loops.
    SUMO loads them all and measures over the run."""
    sc = _on("curved_traffic_high", duration=6.0, **{"detectors.period_s": 3.0})
    road = load_route_road(sc.network, sc.route)
    net = read_network(sc.network)
    layout = place_detectors(road, sc.detectors)
    tracks = {t.id: t for t in road.lanes}
    assert len(road.route.edges) == 4
    for d in layout.detectors:
        piece = next(p for p in tracks[d.track].track.pieces if p.lane == d.lane)
        assert not piece.internal and piece.edge in road.route.edges
        length = net.getLane(d.lane).getLength()
        assert 0.0 <= d.position <= d.end <= length + 1e-9
        assert d.s == pytest.approx(s_of_lane_position(road, d.lane, d.position))
    loops = [d for d in layout.detectors if d.kind == "e1"]
    assert {d.track for d in loops} == {0, 1, 2}  # the SV lanes, not the added one
    for d in loops:
        grid = 500.0 * round(d.s / 500.0)
        # (s read back through the lane's sampled positions: within a millimetre)
        assert -1e-3 <= d.s - grid < 40.0, d.id  # a junction's lane is shorter
    areas = [d for d in layout.detectors if d.kind == "e2"]
    starts = {(d.lane, d.position) for d in loops}
    assert areas and all((d.lane, d.position) in starts and (d.lane, d.end) in starts
                         for d in areas)
    sim = CoSimulation(sc, detector_output=tmp_path)
    result = sim.run()
    assert not [w for w in sim.world.sumo.warnings() if "etector" in w]
    table = result.detectors
    assert set(table.detector) == {d.id for d in layout.detectors}
    assert (table[table.kind == "e1"].vehicles > 0).any()


def test_lanes_that_end_get_loops_inside_their_start_and_end() -> None:
    """ramp_merge: the acceleration lane (track 0, which ends) has loops LANE_END_INSET
    inside its start and its end, beside the spacing's; the lanes that run on have none
    there."""
    sc = _on("ramp_merge")
    road = load_route_road(sc.network, sc.route)
    layout = place_detectors(road, sc.detectors)
    acc = road.lane(0)
    s = sorted(d.s for d in layout.detectors if d.kind == "e1" and d.track == 0)
    assert s == pytest.approx([0.0, acc.begin + LANE_END_INSET, acc.end - LANE_END_INSET])
    assert not [d for d in layout.detectors if d.track != 0 and d.kind == "e1"
                and abs(d.s - LANE_END_INSET) < 1.0]


def test_bad_detector_keys_are_refused_in_one_line() -> None:
    base = load_scenario(SCENARIOS / "traffic_high.toml")
    for keys, allowed in (({"detectors.period_s": 0.07}, "a whole multiple of"),
                          ({"detectors.positions_m": [7000.0]}, "[0, 6000] m"),
                          ({"detectors.positions_m": [-1.0]}, "finite numbers >= 0"),
                          ({"detectors.spacing_m": 1.0}, "[10, 100000] m")):
        with pytest.raises(InputError, match=r"detectors\.") as info:
            with_overrides(base, **keys)
        assert allowed in str(info.value) and "\n" not in str(info.value)
    user = with_overrides(base, **{"detectors.positions_m": [250.0, 1234.5]})
    layout = place_detectors(load_route_road(base.network, base.route), user.detectors)
    assert {d.s for d in layout.detectors if d.track == 1 and d.kind == "e1"} >= {250.0,
                                                                                1234.5}


def test_lane_area_detectors_only_as_asked() -> None:
    """`areas`: "none" (the default) places the loops alone; "lanes" the same loops and
    on each lane one E2 over what the stretches cover; "stretches" one between each two
    loops (traffic_high: 13 loops and 12 stretches a lane, 0 to 6000 m)."""
    base = load_scenario(SCENARIOS / "traffic_high.toml")
    road = load_route_road(base.network, base.route)
    placed = {}
    for areas in ("none", "lanes", "stretches"):
        keys = {"detectors.enabled": True} if areas == "none" else {
            "detectors.enabled": True, "detectors.areas": areas}
        spec = with_overrides(base, **keys).detectors
        assert spec.areas == areas
        placed[areas] = place_detectors(road, spec).detectors
    loops = placed["none"]
    assert len(loops) == 39 and {d.kind for d in loops} == {"e1"}
    for areas in ("lanes", "stretches"):
        assert [d for d in placed[areas] if d.kind == "e1"] == list(loops)
    lanes = [d for d in placed["lanes"] if d.kind == "e2"]
    assert [(d.track, d.s, d.length) for d in lanes] == [(k, 0.0, 6000.0) for k in range(3)]
    assert len(placed["stretches"]) == 39 + 36
    with pytest.raises(InputError, match="detectors.areas"):
        with_overrides(base, **{"detectors.areas": "all"})
