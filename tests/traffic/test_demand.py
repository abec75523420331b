"""Random traffic by density with lane speed bands, in real SUMO."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from cosim.errors import InputError
from cosim.traffic.demand import placement, populate, start_zone
from cosim.traffic.network import DEFAULT_NETWORK
from cosim.traffic.process import SumoOptions
from cosim.traffic.sumo import TV_LENGTH, SumoSim

SV_ID = "sv"

STEP = 0.05  # s
KMH = 3.6


def make_sim(seed: int) -> SumoSim:
    return SumoSim(DEFAULT_NETWORK, STEP, seed, SumoOptions(lanechange_duration=3.0))


@pytest.mark.parametrize("density", [8.0, 16.0, 28.0])
def test_traffic_is_placed_along_the_road_at_the_requested_density(density: float) -> None:
    with make_sim(3) as sim:
        populate(sim, sim.road(), density, 3, 2000.0)
        sim.step()  # every placed TV is inserted in the first step
        assert sim.reader.pending() == ()
        snap = sim.snapshot()
    for lane in range(3):
        x = snap.x[snap.lane == lane]
        assert len(x) / 2.0 == pytest.approx(density, rel=0.10)
        per_km = np.histogram(x, bins=[0.0, 1000.0, 2000.0])[0]
        assert np.all(np.abs(per_km - density) <= max(1.0, 0.1 * density))  # no empty stretch


def test_exclude_zone_is_free_at_the_start() -> None:
    with make_sim(4) as sim:
        traffic = populate(sim, sim.road(), 28.0, 4, 2000.0, exclude_zone=(480.0, 530.0))
        sim.step()
        snap = sim.snapshot()
    assert sum(len(v) for v in traffic.placed.values()) == len(snap)
    rear, front = snap.x - snap.length / 2, snap.x + snap.length / 2
    assert not np.any((front >= 480.0) & (rear <= 530.0))
    assert np.sum((snap.x > 300.0) & (snap.x < 700.0)) > 20  # but the rest is full


def test_lane_zone_cuts_one_lane_and_leaves_the_rest_as_the_seed_drew_it() -> None:
    def placed(lane_zones: dict[int, tuple[float, float]] | None) -> dict[int, np.ndarray]:
        with make_sim(5) as sim:
            populate(sim, sim.road(), 40.0, 5, 1500.0, lane_zones=lane_zones)
            sim.step()
            snap = sim.snapshot()
        return {lane: np.sort(snap.x[snap.lane == lane]) for lane in range(3)}

    full, cut = placed(None), placed({1: (500.0, 600.0)})
    np.testing.assert_array_equal(cut[0], full[0])
    np.testing.assert_array_equal(cut[2], full[2])
    outside = (full[1] + TV_LENGTH / 2 < 500.0) | (full[1] - TV_LENGTH / 2 > 600.0)
    np.testing.assert_array_equal(cut[1], full[1][outside])
    assert len(cut[1]) < len(full[1])


@pytest.mark.parametrize("seed", [2, 3])
def test_a_car_placed_at_speed_in_its_start_zone_does_not_hit_the_dense_queue(seed: int) -> None:
    """At 50 veh/km/lane SUMO starts the queue at ~13 m/s; a car placed at 100 km/h
    with only 2 car lengths kept free hit its leader at t = 0.6 s (the density study
    before the start zone). With `start_zone` SUMO's own driver brakes in time."""
    speed, length = 100.0 / KMH, 4.32
    with make_sim(seed) as sim:
        x0 = 600.0  # m, s along the road
        zone = start_zone(x0, length, speed, sim.road().speed_bands[1][1])
        populate(sim, sim.road(), 50.0, seed, 1500.0, exclude_zone=(x0 - 8.64, x0 + 8.64),
                 lane_zones={1: zone})
        sim.add_driven(SV_ID, 1, sim.centre_pose(1, x0), speed, speed, length, 1.82,
                       own_lane_changes=False)
        sim.step()
        sim.controlled.release(SV_ID)
        hits = 0
        for _ in range(80):  # 4 s: the start-up transient
            sim.step()
            hits += sum(SV_ID in pair for pair in sim.collisions())
    assert hits == 0
    assert zone[1] - x0 > 2.0 * speed  # the rule: 2 s of its speed ahead, at least


def test_placement_spacing_is_jittered_but_never_overlapping() -> None:
    rng = np.random.default_rng(0)
    x = placement(rng, 28.0, 0.0, 2000.0)
    gaps = np.diff(x)
    assert len(x) == 56
    assert gaps.min() > TV_LENGTH + 5.0
    assert gaps.std() > 1.0  # not a regular lattice


def test_bad_densities_and_lengths_are_input_errors() -> None:
    with make_sim(1) as sim:
        with pytest.raises(InputError, match="density"):
            populate(sim, sim.road(), -1.0, 1, 1000.0)
        with pytest.raises(InputError, match="length"):
            populate(sim, sim.road(), 10.0, 1, 1e6)
        assert populate(sim, sim.road(), 0.0, 1, 1000.0).placed == {}


@dataclass
class Run:
    speeds: dict[int, np.ndarray]  # km/h of TVs per lane, sampled along the run
    band_ok: float  # fraction of samples whose desired speed sits in its lane's band
    lane_changes: int  # lane changes TVs made themselves
    density_end: float  # veh/km/lane on [0, 2500] m at the end
    bands_kmh: tuple[tuple[float, float], ...]


@pytest.fixture(scope="module")
def run16() -> Run:
    """40 s of 16 veh/km/lane traffic (closed before the tests use it)."""
    speeds: dict[int, list[float]] = {0: [], 1: [], 2: []}
    ok = total = changes = 0
    with make_sim(11) as sim:
        road = sim.road()
        populate(sim, road, 16.0, 11, 2000.0)
        lanes: dict[str, int] = {}
        for k in range(int(40.0 / STEP)):
            sim.step()
            snap = sim.snapshot()
            for vid, lane in zip(snap.ids, snap.lane, strict=True):
                changes += int(vid in lanes and lanes[vid] != lane)
                lanes[vid] = int(lane)
            if k % 10:
                continue
            window = (snap.x > 300.0) & (snap.x < 2500.0)  # away from the inflow
            for lane in range(3):
                speeds[lane] += list(snap.speed[window & (snap.lane == lane)] * KMH)
            for vid, lane in zip(snap.ids, snap.lane, strict=True):
                lo, hi = road.speed_bands[lane]
                desired = sim.api.vehicle.getMaxSpeed(vid)
                ok += int(lo - 1e-6 <= desired <= hi + 1e-6)
                total += 1
        m = snap.x < 2500.0
        density_end = float(np.sum(m)) / 3 / 2.5
        bands = tuple((lo * KMH, hi * KMH) for lo, hi in road.speed_bands)
    return Run({k: np.array(v) for k, v in speeds.items()}, ok / total, changes, density_end, bands)


def test_each_lane_keeps_its_speed_band(run16: Run) -> None:
    for lane, (lo, hi) in enumerate(run16.bands_kmh):
        v = run16.speeds[lane]
        assert len(v) > 500
        inside = np.mean((v >= lo - 0.5) & (v <= hi + 0.5))
        assert inside >= 0.95, (lane, inside, np.percentile(v, [1, 50, 99]))
    # and the lanes are ordered, slow on the right
    medians = [np.median(run16.speeds[k]) for k in range(3)]
    assert medians[0] < medians[1] < medians[2]


def test_tvs_change_lanes_and_take_their_new_lanes_band(run16: Run) -> None:
    assert run16.lane_changes >= 20  # SUMO's lane-change model, not scripted
    assert run16.band_ok == 1.0  # desired speed always from the current lane's band


def test_inflow_keeps_the_density(run16: Run) -> None:
    assert run16.density_end == pytest.approx(16.0, rel=0.10)
