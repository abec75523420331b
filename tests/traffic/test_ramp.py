"""Lanes that end, in real SUMO: the SUMO-driven SV merges from the on-ramp's
acceleration lane and is never teleported or removed (a removal fails the run); TVs on
an ending SV lane read that lane; on-ramp traffic; the merge metrics of a SUMO-native
ramp run."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from cosim.errors import SimulationError
from cosim.run.loop import simulate
from cosim.scenario.load import load_scenario
from cosim.traffic.demand import UPSTREAM_LENGTH, populate, ramp_flow, ramps
from cosim.traffic.network import NETWORK_DIR
from cosim.traffic.sumo import SumoSim

ROOT = Path(__file__).resolve().parents[2]
NET = NETWORK_DIR / "onramp.net.xml"


def _ramp_merge(**traffic: float):
    sc = load_scenario(ROOT / "scenarios" / "ramp_merge.toml")
    sc = dataclasses.replace(sc, sv=dataclasses.replace(sc.sv, controller="sumo"))
    if traffic:
        sc = dataclasses.replace(sc, traffic=dataclasses.replace(sc.traffic, **traffic))
    return sc


@pytest.mark.parametrize("density", [20.0, 45.0])
def test_the_sumo_driven_sv_merges_from_the_acceleration_lane_and_stays(density: float
                                                                        ) -> None:
    """SUMO-native on ramp_merge: never teleported or removed (SumoSim.step raises a
    SimulationError if it were: this run would fail), no event about the SV, the merge
    metrics of the trace."""
    sc = _ramp_merge(density=density)
    result = simulate(sc)
    assert not [e for e in result.events if " sv:" in e or " sv " in e]
    m = result.metrics
    assert m["duration_s"] == pytest.approx(sc.duration) and m["collisions"] == 0
    end = result.road.lane_end(0)
    assert 180.0 < end < 200.0
    assert m["merge_success"] == 1
    t, s, lane = result.trace["t_s"], result.trace["s_m"], result.trace["lane"]
    k = int(np.flatnonzero(lane != 0)[0])
    assert lane[0] == 0 and lane[k] == 1  # from the acceleration lane into lane 1
    assert m["merge_distance_to_end_m"] == pytest.approx(end - s[k])
    assert 0.0 < m["merge_distance_to_end_m"] < end
    assert m["stopped_time_s"] == pytest.approx(
        float(np.sum(np.diff(t)[result.trace["vx_mps"][:-1] < 0.1])))
    decel = m["merge_follower_max_decel_mps2"]
    assert math.isnan(decel) or 0.0 <= decel < 9.0


def test_a_removed_sumo_driven_sv_fails_the_run() -> None:
    """The detection is live: the SV gone from SUMO (removed behind our back, as SUMO
    removes a vehicle it cannot place) raises at the next step."""
    with SumoSim(NET, 0.05, 1, route=["acc", "main1", "main2"]) as sim:
        pose = sim.centre_pose(0, 30.0)
        sim.add_driven("sv", 0, pose, 20.0, 25.0, 4.32, 1.8, own_lane_changes=True)
        sim.step()
        sim.controlled.release("sv")
        sim.step()
        assert sim.api.vehicle.getLaneID("sv") == "acc_0"
        assert sim.snapshot().lane[0] == 0  # the acceleration lane is SV lane 0
        sim.api.vehicle.remove("sv")
        with pytest.raises(SimulationError, match="sv is no longer in SUMO"):
            sim.step()
        assert [e.kind for e in sim.events] == ["lost"]
    with SumoSim(NET, 0.05, 1, route=["acc", "main1", "main2"]) as sim:
        end = sim.lanes.table(1).end  # SUMO removes it at the end of its route
        sim.add_driven("sv", 1, sim.centre_pose(1, end - 10.0), 25.0, 25.0, 4.32, 1.8,
                       own_lane_changes=True)
        sim.step()
        sim.controlled.release("sv")
        with pytest.raises(SimulationError, match="SUMO removed sv: it arrived"):
            for _ in range(40):
                sim.step()


def test_ramp_traffic_comes_up_the_ramp_and_reads_lane_0_on_the_acceleration_lane() -> None:
    with SumoSim(NET, 0.1, 3, route=["acc", "main1", "main2"]) as sim:
        found = ramps(sim)
        assert [(r.edge, r.lane, r.track, r.route_index) for r in found] == \
            [("ramp", 0, 0, 0)]
        hook = ramp_flow(sim, 1800.0, 3)
        assert hook is not None
        lanes: dict[str, set[int]] = {}
        for _ in range(400):  # 40 s: 400 m of ramp, then the acceleration lane
            sim.step()
            snap = sim.snapshot()
            for vid, lane in zip(snap.ids, snap.lane, strict=True):
                lanes.setdefault(vid, set()).add(int(lane))
        assert 10 <= len(lanes) <= 30  # ~20 at 1800 veh/h
        assert all(vid.startswith("tv") for vid in lanes)
        # off the route on the ramp (-1), then lane 0 (acc_0) and into lane 1
        merged = [v for v, seen in lanes.items() if {-1, 0, 1} <= seen]
        assert merged
        assert not sim.events  # nobody teleported


def test_random_traffic_enters_before_the_route_out_of_the_svs_sight() -> None:
    """Route `acc main1 main2` (the ramp merge): the mainline that feeds it from `main0`
    is filled UPSTREAM_LENGTH m back at t = 0 at the density, and the inflow enters there,
    so no TV first appears within 300 m behind the route's start (where an SV that
    starts on the acceleration lane would see it appear close behind it)."""
    density = 20.0
    with SumoSim(NET, 0.1, 3, route=["acc", "main1", "main2"]) as sim:
        start = sim.lanes.route_road.frame.to_cartesian(0.0, 0.0)[0]  # x of the route's start
        populate(sim, sim.road(), density, 3, 1500.0)
        sim.step()
        snap = sim.snapshot()
        before = (snap.x < start) & (snap.x >= start - UPSTREAM_LENGTH)
        expected = density * UPSTREAM_LENGTH / 1000.0 * 3  # three mainline lanes
        assert abs(int(before.sum()) - expected) <= 0.15 * expected
        placed = {str(v) for v in snap.ids}
        first: dict[str, float] = {}  # where each TV of the inflow is first seen
        for _ in range(300):  # 30 s
            sim.step()
            snap = sim.snapshot()
            for vid, x in zip(snap.ids, snap.x, strict=True):
                if str(vid) not in placed:
                    first.setdefault(str(vid), float(x))
    assert len(first) >= 0.5 * density * 30.0 * 25.0 / 1000.0 * 3  # ~25 m/s, 3 lanes
    assert max(first.values()) < start - 300.0


@pytest.mark.parametrize("density", [10.0, 40.0])
def test_our_gap_driver_merges_from_the_shipped_ramp_by_its_mandatory_change(
        density: float) -> None:
    """Our SV (gap policy, MIMO) on the shipped ramp_merge, as the merge study runs it
    (seed 1): its lane's end asks for the change ("mandatory": the acceleration lane is
    inside LC2013's look-ahead from its start), it merges into a gap in lane 1
    before the end with no collision by either check and is never dropped; the merge's
    follower is watched until the SV's next change begins, not to the run's end (at
    10 veh/km/lane it braked 6.8 m/s^2 22 s later, for another vehicle)."""
    sc = load_scenario(ROOT / "scenarios" / "ramp_merge.toml")
    sc = dataclasses.replace(sc, duration=25.0, traffic=dataclasses.replace(
        sc.traffic, density=density))
    result = simulate(sc)
    m = result.metrics
    assert m["merge_success"] == 1 and m["lane_end_reached"] == 0
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0
    plans = result.plans
    out = [p for p in plans if p["origin_lane"] == 0]  # the plans out of the ending lane
    assert out and out[0]["trigger"] == "mandatory"
    # then re-checks under way: a replan, or a brake in the lane; never an abort back
    # into the ending lane (its change is due from the start)
    assert {p["trigger"] for p in out} <= {"mandatory", "replan", "brake"}
    end = result.road.lane_end(0)
    assert 0.0 < m["merge_distance_to_end_m"] < end - 20.0
    assert m["stopped_time_s"] == 0.0
    # the merge's new follower brakes no harder than a Krauss follower's decel
    assert m["merge_follower_max_decel_mps2"] <= 4.5 + 1e-6
    # the trace's SUMO lane is SUMO's index on its edge, the track the route's: at a lane
    # centre the track is the lane the SV is in, and past the acceleration lane (gone
    # from main1) SUMO's index is one less (the track read from the route's numbering
    # as if it were SUMO's was one more, or none, on main1)
    tr = result.trace
    settled = np.abs(tr["d_m"] - result.road.lane_center(1)) < 0.2
    for k in range(2, result.road.n_lanes):
        settled |= np.abs(tr["d_m"] - result.road.lane_center(k)) < 0.2
    assert settled.sum() > 100 and np.array_equal(tr["track"][settled], tr["lane"][settled])
    on_main1 = settled & (tr["edge"] == result.edges.index("main1"))
    assert on_main1.sum() > 100
    assert np.array_equal(tr["sumo_lane"][on_main1], tr["lane"][on_main1] - 1)


def test_with_no_gap_our_sv_stops_before_the_end_of_the_ramp_and_waits_there() -> None:
    """The shipped ramp at 60 veh/km/lane with no courtesy from the mainline (nobody
    makes room): our SV stops at its stop line, WAIT_ROOM before the end of the
    acceleration lane, and waits there; a merge started from the standstill that the
    re-check no longer finds free is not aborted back into the ending lane (an abort
    drives to the band's speed: it drove to the lane's end) but braked; never past the
    end, no collision by either check."""
    from cosim.driving.lane_end import WAIT_ROOM

    sc = load_scenario(ROOT / "scenarios" / "ramp_merge.toml")
    sc = dataclasses.replace(sc, traffic=dataclasses.replace(
        sc.traffic, density=60.0, courtesy=False))
    result = simulate(sc)
    m, tr = result.metrics, result.trace
    assert m["duration_s"] == pytest.approx(sc.duration)  # ran to its end
    assert m["lane_end_reached"] == 0 and m["merge_success"] == 0
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0
    assert m["stopped_time_s"] > 15.0
    end = result.road.lane_end(0)
    front = tr["s_m"] + 0.5 * sc.vehicle.length
    assert front.max() < end - WAIT_ROOM + 2.0  # at its stop line at most
    assert "abort" not in {p["trigger"] for p in result.plans}


def test_our_sv_on_the_acceleration_lane_is_moved_there_and_merges_by_a_scripted_change(
) -> None:
    """Our SV (MIMO) starts on the ending acceleration lane: moveToXY with that lane as
    the hint keeps SUMO's SV on acc_0, then, as its scripted change to lane 1 crosses
    the line, on acc_1 and main1_0; never lost; the merge metrics see the merge."""
    from cosim.scenario.load import read_toml, scenario_from_dict

    path = ROOT / "scenarios" / "ramp_merge.toml"
    doc = read_toml(path)
    doc["sv"].update(decision=False, lane_changes=[{"at_s": 1.0, "target_lane": 1}])
    doc["traffic"].update(density_veh_per_km_lane=0.0, ramp_flow_veh_per_h=0.0)
    doc["scenario"]["duration_s"] = 12.0
    result = simulate(scenario_from_dict(doc, path=path))
    assert not result.events
    trace = result.trace
    edges = [result.edges[int(k)] for k in trace["edge"]]
    sumo_lane = [f"{e}_{int(i)}" for e, i in zip(edges, trace["sumo_lane"], strict=True)]
    assert sumo_lane[0] == "acc_0" and trace["lane"][0] == 0
    assert "acc_1" in sumo_lane and edges[-1] == "main1"
    # SUMO's lane follows the SV (the hint is the lane its front is in): the acceleration
    # lane while its centre is there, never once its centre is in lane 1
    in_acc0 = np.array([s == "acc_0" for s in sumo_lane])
    assert (trace["d_m"][in_acc0] < 0.0).all()
    assert not in_acc0[trace["lane"] == 1].any()
    m = result.metrics
    assert m["merge_success"] == 1 and m["lane_changes"] == 1 and m["collisions"] == 0
    assert 0.0 < m["merge_distance_to_end_m"] < result.road.lane_end(0)


@pytest.mark.parametrize(("change", "message"), [
    ({"route": '["main0", "acc", "main1", "main2"]', "edge": '"acc"'},
     "lane 0 of 'acc' begins along the route"),
    ({"lane_speeds_kmh": "[[60, 90], [90, 110]]"},
     r"3 \[min, max\] pairs in km/h, one per lane that runs through the route"),
])
def test_what_cannot_be_driven_is_refused_in_one_line_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], change: dict[str, str],
        message: str) -> None:
    import re

    from cosim.cli import main

    text = (ROOT / "scenarios" / "ramp_merge.toml").read_text(encoding="utf-8")
    text = text.replace('"networks/onramp.net.xml"', repr(str(NET)).replace("'", '"'))
    for key, value in change.items():
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        assert n == 1, key
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(path), "--no-figures", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and re.search(message, err), err
    assert not out.exists()
