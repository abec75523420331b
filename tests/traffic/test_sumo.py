"""The SUMO adapter against real libsumo: poses, lanes, events, collisions, determinism."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cosim.errors import SimulationError
from cosim.traffic.demand import populate
from cosim.traffic.network import DEFAULT_NETWORK
from cosim.traffic.process import SumoOptions
from cosim.traffic.sumo import (
    SumoSim,
    centre_from_front,
    front_from_centre,
    heading_from_angle,
    sumo_angle,
)

STEP = 0.05  # s
L, W = 4.32, 1.8  # m, the Table 1 car


def make_sim(seed: int = 1, *, strict: bool = True, **options: Any) -> SumoSim:
    """A simulation of the default network; `options`: SumoOptions' fields."""
    return SumoSim(DEFAULT_NETWORK, STEP, seed,
                   SumoOptions(**{"lanechange_duration": 3.0, **options}), strict=strict)


def test_angle_and_front_bumper_conversions() -> None:
    assert sumo_angle(0.0) == pytest.approx(90.0)  # along +x is east
    assert sumo_angle(math.pi / 2) == pytest.approx(0.0)  # +y is north
    assert sumo_angle(-0.1) == pytest.approx(90.0 + math.degrees(0.1))
    for h in (-3.0, -0.2, 0.0, 0.05, 1.5, 3.1):
        assert heading_from_angle(sumo_angle(h)) == pytest.approx(h, abs=1e-12)
        xf, yf = front_from_centre(10.0, 2.0, h, L)
        assert math.hypot(xf - 10.0, yf - 2.0) == pytest.approx(L / 2)
        assert centre_from_front(xf, yf, h, L) == pytest.approx((10.0, 2.0), abs=1e-12)


def test_pose_written_is_pose_read_back_to_a_micrometre() -> None:
    with make_sim() as sim:
        road = sim.road()
        x, y, h = 200.0, road.lane_center(1), 0.0
        sim.add_controlled("sv", x, y, h, 30.0, (L, W), 1)
        api = sim.api
        for k in range(60):
            sim.step()
            # what SUMO holds is the front bumper and navigational degrees of our CG pose
            xf, yf = front_from_centre(x, y, h, L)
            assert api.vehicle.getPosition("sv") == pytest.approx((xf, yf), abs=1e-6)
            assert api.vehicle.getAngle("sv") == pytest.approx(sumo_angle(h), abs=1e-9)
            assert sim.reader.pose("sv") == pytest.approx((x, y, h), abs=1e-6)
            snap = sim.snapshot()
            i = snap.index("sv")
            assert (snap.x[i], snap.y[i], snap.heading[i]) == pytest.approx((x, y, h), abs=1e-6)
            h = 0.08 * math.sin(0.2 * k)
            x, y = x + 30.0 * STEP * math.cos(h), y + 30.0 * STEP * math.sin(h)
            sim.move("sv", x, y, h, 30.0)
        # the speed written is the speed SUMO reports (what following TVs react to)
        assert sim.reader.speed("sv") == pytest.approx(30.0, abs=0.05)


def test_lane_index_follows_the_lateral_position() -> None:
    with make_sim() as sim:
        road = sim.road()
        x, y = 300.0, road.lane_center(0)
        sim.add_controlled("sv", x, y, 0.0, 25.0, (L, W), 0)
        seen = set()
        while y < road.lane_center(2):
            sim.step()
            snap = sim.snapshot()
            lane = int(snap.lane[snap.index("sv")])
            edge_dist = abs((y - road.y_right) / road.lane_width - round(
                (y - road.y_right) / road.lane_width)) * road.lane_width
            if edge_dist > 0.05:  # away from a lane line, no ambiguity
                assert lane == road.lane_of(y), (y, lane)
            seen.add(lane)
            x, y = x + 25.0 * STEP, y + 0.05
            sim.move("sv", x, y, 0.0, 25.0)
        assert seen == {0, 1, 2}


def test_scripted_vehicle_shows_its_lateral_speed_and_blinker() -> None:
    """A moved TV (scripted) is seen by the snapshot as it moves: SUMO itself reports 0."""
    with make_sim() as sim:
        sim.add_controlled("s1", 100.0, 1.875, 0.0, 25.0, (L, W), 0, vtype="scripted")
        sim.set_blinker("s1", 1)
        y = 1.875
        for k in range(1, 21):
            sim.step()
            snap = sim.snapshot()
            i = snap.index("s1")
            assert snap.y[i] == pytest.approx(y, abs=1e-6)
            assert snap.intention[i] == (1 if k <= 10 else 0)
            if k > 1:
                assert snap.lateral_speed[i] == pytest.approx(1.0)
                assert sim.api.vehicle.getLateralSpeed("s1") == 0.0
            if k == 10:
                sim.set_blinker("s1", 0)
            y += 0.05
            sim.move("s1", 100.0 + 1.25 * k, y, math.atan2(1.0, 25.0), 25.0)


def test_leaving_the_network_is_detected() -> None:
    with make_sim() as sim:
        end = sim.lanes.length  # m, s of the road's end (s = x on this network)
        sim.add_controlled("sv", end - 30.0, 5.625, 0.0, 30.0, (L, W), 1)
        sim.step()
        with pytest.raises(SimulationError, match=r"sv left the network at x = 59\d\d\.\d\d m"):
            for k in range(1, 40):
                sim.move("sv", end - 30.0 + 30.0 * STEP * k, 5.625, 0.0, 30.0)
                sim.step()
        assert [e.kind for e in sim.events] == ["lost"]
        assert sim.events[0].vehicle_id == "sv"
        assert sim.events[0].time == pytest.approx(sim.time)
        x_lost = float(sim.events[0].detail.split("x = ")[1].split(" m")[0])
        assert end - L / 2 <= x_lost < end  # lost as soon as the front bumper passes the end
    # off the side of the road, recorded only when not strict
    with make_sim(strict=False) as sim:
        sim.add_controlled("sv", 500.0, 5.625, 0.0, 30.0, (L, W), 1)
        sim.step()
        sim.move("sv", 501.5, -8.0, 0.0, 30.0)
        sim.step()
        assert [(e.kind, e.vehicle_id) for e in sim.events] == [("lost", "sv")]
        assert "y = -8.00" in sim.events[0].detail


def _blocked_road(sim: SumoSim) -> None:
    """Three stopped controlled vehicles side by side, a TV coming up behind them."""
    road = sim.road()
    for k in range(3):
        sim.add_controlled(f"block{k}", 300.0, road.lane_center(k), 0.0, 0.0, (L, W), k)
    sim.add_traffic("tv", 0, 200.0, 0.5)
    for _ in range(int(3.0 / STEP)):
        for k in range(3):
            if f"block{k}" in sim.reader.vehicle_ids():
                sim.move(f"block{k}", 300.0, road.lane_center(k), 0.0, 0.0)
        sim.step()


def test_teleports_are_recorded_and_off_by_default() -> None:
    with make_sim() as sim:  # --time-to-teleport -1: a standing controlled vehicle stays
        _blocked_road(sim)
        assert sim.events == []
        assert sim.reader.pose("block0")[0] == pytest.approx(300.0)
    with make_sim(strict=False, extra_args=("--time-to-teleport", "1")) as sim:
        _blocked_road(sim)
        kinds = {(e.kind, e.vehicle_id) for e in sim.events}
        assert ("teleport", "block0") in kinds and ("lost", "block0") in kinds
        assert all(e.time == pytest.approx(1.1) for e in sim.events)
        assert "teleported" in [e for e in sim.events if e.kind == "lost"][0].detail


def test_forced_overlap_is_reported_by_sumo_with_the_warn_action() -> None:
    with make_sim() as sim:
        road = sim.road()
        sim.add_traffic("tv", 1, 400.0, 0.5)
        sim.add_controlled("sv", 380.0, road.lane_center(1), 0.0, 27.0, (L, W), 1)
        sim.step()
        assert sim.collisions() == []
        x_tv, _, _ = sim.reader.pose("tv")
        sim.move("sv", x_tv - 1.0, road.lane_center(1), 0.0, 27.0)  # 1 m behind: overlapping
        sim.step()
        pairs = sim.collisions()
        assert pairs and set(pairs[0]) == {"sv", "tv"}
        assert set(sim.reader.vehicle_ids()) == {"sv", "tv"}  # warn: nobody teleported or removed
        assert not [e for e in sim.events if e.kind == "teleport"]
    # SUMO's warning was captured (complete once SUMO has closed its log), not printed
    assert any("collision with vehicle 'tv'" in w for w in sim.warnings())


def test_leader_is_the_next_vehicle_ahead_in_the_lane() -> None:
    with make_sim() as sim:
        road = sim.road()
        sim.add_traffic("ahead", 1, 460.0, 0.5)
        sim.add_traffic("other_lane", 2, 430.0, 0.5)
        sim.add_controlled("sv", 400.0, road.lane_center(1), 0.0, 27.0, (L, W), 1)
        sim.step()
        found = sim.reader.leader("sv")
        assert found is not None
        vid, gap = found
        x_ahead = sim.reader.pose("ahead")[0]
        assert vid == "ahead"
        assert gap == pytest.approx(x_ahead - 400.0 - L, abs=0.5)  # bumper to bumper
        assert sim.reader.leader("ahead") is None


def _run_traffic(seed: int) -> list:
    out = []
    with make_sim(seed) as sim:
        populate(sim, sim.road(), 16.0, seed, 1500.0, exclude_zone=(480.0, 520.0))
        sim.add_controlled("sv", 500.0, 5.625, 0.0, 28.0, (L, W), 1)
        for k in range(200):
            sim.step()
            sim.move("sv", 500.0 + 28.0 * STEP * (k + 1), 5.625, 0.0, 28.0)
            if k % 20 == 0:
                out.append(sim.snapshot(exclude=("sv",)))
    return out


def test_same_seed_gives_identical_snapshots() -> None:
    a, b, c = _run_traffic(7), _run_traffic(7), _run_traffic(8)
    for sa, sb in zip(a, b, strict=True):
        assert sa.ids == sb.ids
        for name in ("x", "y", "heading", "speed", "accel", "lane", "lateral_speed", "signals"):
            np.testing.assert_array_equal(getattr(sa, name), getattr(sb, name))
    assert "sv" not in a[-1].ids
    last_a, last_c = a[-1], c[-1]
    assert last_a.ids != last_c.ids or not np.array_equal(last_a.x, last_c.x)


def test_close_flushes_a_pending_move() -> None:
    """A moveToXY still pending at close must not reach the next simulation."""
    with make_sim() as sim:
        sim.add_controlled("sv", 100.0, 5.625, 0.0, 30.0, (L, W), 1)
        sim.step()
        sim.move("sv", 900.0, 5.625, 0.0, 30.0)
    with make_sim() as sim:
        sim.add_traffic("sv", 1, 100.0, 0.5)
        sim.step()
        assert sim.reader.pose("sv")[0] == pytest.approx(100.0, abs=2.0)
        assert sim.time == pytest.approx(STEP)


def test_one_simulation_at_a_time() -> None:
    with make_sim(), pytest.raises(SimulationError, match="another SUMO simulation"):
        make_sim().start()


def test_traci_backend_runs_the_same_adapter() -> None:
    """The --gui code path (traci) with the headless binary: same poses as libsumo."""
    with make_sim(traci=True) as sim:
        assert sim.api.__name__ == "traci"
        sim.add_controlled("sv", 200.0, 5.625, 0.0, 30.0, (L, W), 1)
        sim.add_traffic("tv", 2, 260.0, 0.5)
        for k in range(1, 6):
            sim.step()
            x = 200.0 + 1.5 * (k - 1)
            assert sim.reader.pose("sv") == pytest.approx((x, 5.625, 0.0), abs=1e-6)
            sim.move("sv", x + 1.5, 5.625, 0.0, 30.0)
        assert len(sim.snapshot(exclude=("sv",))) == 1


def test_sublane_option_gives_gradual_lateral_motion() -> None:
    """--lateral-resolution instead of --lanechange.duration: lateral speed ramps up."""
    lateral: list[float] = []
    with SumoSim(DEFAULT_NETWORK, STEP, 3, SumoOptions(sublane=True)) as sim:
        assert "--lateral-resolution" in sim.command()
        assert "--lanechange.duration" not in sim.command()
        populate(sim, sim.road(), 16.0, 3, 1000.0)
        for _ in range(int(12.0 / STEP)):
            sim.step()
            snap = sim.snapshot()
            lateral += list(np.abs(snap.lateral_speed[snap.changing]))
    assert len(lateral) > 50
    speeds = np.round(lateral, 2)
    assert len(np.unique(speeds)) > 5  # a trapezoid, not the constant W/D of the other model
    assert speeds.max() <= 1.0 + 1e-9  # SUMO's default maxSpeedLat


def test_command_line_of_each_mode() -> None:
    """What SUMO is started with: collisions as real overlaps, no teleports, quiet;
    --gui swaps only the binary (sumo-gui through traci)."""
    cmd = make_sim(seed=42).command()
    pairs = dict(zip(cmd[1::2], cmd[2::2], strict=True))
    assert pairs["--collision.action"] == "warn"
    assert pairs["--collision.mingap-factor"] == "0"
    assert pairs["--time-to-teleport"] == "-1"
    assert pairs["--seed"] == "42" and pairs["--step-length"] == "0.05"
    assert pairs["--lanechange.duration"] == "3.0" and pairs["--no-warnings"] == "true"
    assert Path(cmd[0]).name == "sumo"
    gui = make_sim(gui=True)
    assert gui.use_traci and Path(gui.command()[0]).name == "sumo-gui"
    assert "--start" in gui.command()
    custom = make_sim(extra_args=("--time-to-teleport", "5")).command()
    assert custom.count("--time-to-teleport") == 1 and custom[-1] == "5"


def test_every_tv_has_its_current_lanes_band_after_every_step() -> None:
    """SpeedBands sees lane changes through the lanes' vehicle lists: after each step
    every TV's desired speed is its place in the band of the lane SUMO has it in."""
    changes = 0
    with make_sim(11) as sim:
        road = sim.road()
        populate(sim, road, 16.0, 11, 2000.0)
        bands = sim.bands
        lane_was: dict[str, int] = {}
        for _ in range(int(40.0 / STEP)):
            sim.step()
            snap = sim.snapshot()
            for vid, lane in zip(snap.ids, snap.lane.tolist(), strict=True):
                changes += int(lane_was.get(vid, lane) != lane)
                lane_was[vid] = lane
                want = bands.speed(lane, bands.quantile[vid])
                assert sim.api.vehicle.getMaxSpeed(vid) == pytest.approx(want, abs=1e-9), vid
    assert changes >= 3  # the test saw TVs change lanes


def test_snapshot_near_drops_vehicles_that_arrive_between_refreshes() -> None:
    """snapshot_near reads SUMO's ID list only at its refreshes: vehicles that reach the
    road's end in between must leave its answer the step they go, as a full read says."""
    with make_sim() as sim:
        end = sim.lanes.length  # m, s of the road's end (s = x on this network)
        for i, x in enumerate(np.arange(end - 190.0, end - 20.0, 25.0)):
            sim.add_traffic(f"tv{i}", (0, 2)[i % 2], float(x), 1.0, speed=30.0)
        x_sv = end - 150.0
        sim.add_controlled("sv", x_sv, 5.625, 0.0, 5.0, (L, W), 1)
        sim.step()
        assert not sim.reader.pending()  # every vehicle is a candidate from the first read on
        sim.snapshot_near("sv", 150.0)
        arrived = 0
        for _ in range(1, 80):
            x_sv += 5.0 * STEP
            sim.move("sv", x_sv, 5.625, 0.0, 5.0)
            sim.step()
            arrived += len(sim.api.simulation.getArrivedIDList())
            near = sim.snapshot_near("sv", 150.0)
            full = sim.snapshot()
            i = full.index("sv")
            inside = np.hypot(full.x - full.x[i], full.y - full.y[i]) <= 150.0
            assert set(near.ids) == {v for v, m in zip(full.ids, inside, strict=True) if m}
        assert arrived >= 4  # the road's end took vehicles while the candidates stood


def test_every_vehicle_type_is_of_the_class_the_lane_check_assumes() -> None:
    """cosim.scenario.rules refuses lanes closed to `network.PASSENGER` before SUMO starts:
    the types cosim makes (traffic, controlled, driven) must be of that class."""
    from cosim.traffic.network import PASSENGER

    with make_sim(1) as sim:
        sim.add_traffic("t0", 0, 500.0, 0.5)
        sim.add_controlled("c0", 700.0, sim.road().lane_center(1), 0.0, 25.0, (4.5, 1.8), 1)
        sim.add_driven("d0", 2, sim.centre_pose(2, 900.0), 30.0, 30.0, 4.5, 1.8)
        sim.step()
        classes = {vid: sim.api.vehicle.getVehicleClass(vid) for vid in ("t0", "c0", "d0")}
    assert classes == {"t0": PASSENGER, "c0": PASSENGER, "d0": PASSENGER}


def test_snapshot_sizes_follow_a_vehicle_added_again_under_its_id() -> None:
    """The scene read keeps its vehicles' sizes while they stay; a vehicle removed and
    added again under the same id with another size is read with the new one."""
    with make_sim() as sim:
        y = sim.road().lane_center(1)
        sim.add_controlled("sv", 200.0, y, 0.0, 20.0, (L, W), 1)
        sim.add_controlled("tv", 230.0, y, 0.0, 20.0, (4.0, 1.7), 1, vtype="tv_scripted")
        sim.step()
        for _ in range(2):  # the second read takes the sizes kept from the first
            near = sim.snapshot_near("sv", 100.0)
            i = near.index("tv")
            assert (near.length[i], near.width[i]) == (4.0, 1.7)
        sim.remove("tv")
        sim.add_controlled("tv", 240.0, y, 0.0, 20.0, (12.0, 2.5), 1, vtype="truck")
        sim.move("sv", 201.0, y, 0.0, 20.0)
        sim.step()
        near = sim.snapshot_near("sv", 100.0)
        i = near.index("tv")
        assert (near.length[i], near.width[i]) == (12.0, 2.5)
        assert near.x[i] == pytest.approx(240.0, abs=1e-6)  # the centre from the new length


def test_select_keeps_the_masked_rows_of_every_column_in_order() -> None:
    """`TrafficSnapshot.select` (rows taken by index) equals masking each column, on
    strided columns (a read's x, y are views into one position array) and with the
    Cartesian columns of a road-coordinate view."""
    from cosim.traffic.snapshot import TrafficSnapshot

    rng = np.random.default_rng(3)
    n = 9
    pos = rng.uniform(-50.0, 50.0, (n, 2))
    cols = {k: rng.uniform(-1.0, 1.0, n) for k in ("heading", "speed", "accel", "lateral_speed",
                                                   "length", "width", "cx", "cy", "ch")}
    snap = TrafficSnapshot(time=1.5, ids=tuple(f"v{i}" for i in range(n)), x=pos[:, 0],
                           y=pos[:, 1], lane=rng.integers(-1, 3, n),
                           signals=rng.integers(0, 3, n), **cols)
    mask = rng.random(n) < 0.5
    got = snap.select(mask)
    assert got.ids == tuple(v for v, m in zip(snap.ids, mask, strict=True) if m)
    for name in ("x", "y", "heading", "speed", "accel", "lane", "lateral_speed", "length",
                 "width", "signals", "cx", "cy", "ch"):
        assert np.array_equal(getattr(got, name), getattr(snap, name)[mask]), name
        assert getattr(got, name).dtype == getattr(snap, name).dtype
    assert len(snap.select(np.zeros(n, dtype=bool))) == 0
