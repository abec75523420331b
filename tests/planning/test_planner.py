"""LaneChangePlanner end to end: sets, reasons, choice, re-check, the paper's cases."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cosim.errors import InputError
from cosim.params import PlannerConfig, RoadParams, VehicleParams, kmh
from cosim.planning.planner import LaneChangePlanner, Plan, SVPlanState
from cosim.planning.situation import situation
from cosim.scenario import TVSpec, load_scenario
from cosim.traffic import scripted
from cosim.traffic.v2v import V2VMessage

ROOT = Path(__file__).resolve().parents[2]
VEH = VehicleParams()


def sv_state(road: RoadParams, lane: int, speed_kmh: float, x: float = 200.0) -> SVPlanState:
    return SVPlanState(x, road.lane_center(lane), 0.0, kmh(speed_kmh), 0.0, 0.0, 0.0, lane)


def tv_msg(road: RoadParams, vid: str, lane: int, gap: float, speed_kmh: float,
           x_sv: float = 200.0) -> V2VMessage:
    spec = TVSpec(vid, lane, gap, kmh(speed_kmh), 0.0, 4.32, 1.8, None)
    return scripted.message(spec, 0.0, road, x_sv)


def plan_file(name: str, **planner: object) -> Plan:
    sc = load_scenario(ROOT / "scenarios" / f"{name}.toml")
    si = situation(sc)
    cfg = replace(sc.planner, **planner)
    return LaneChangePlanner(sc.vehicle, si.road, cfg).plan(
        si.t, si.sv, si.target_lane, si.messages, si.occupant)


def test_open_road_takes_tau_opt_of_the_stable_set() -> None:
    road = RoadParams(mu=0.6)
    p = LaneChangePlanner(VEH, road, PlannerConfig()).plan(0.0, sv_state(road, 1, 100), 2, [], 0.5)
    assert p.feasible
    assert p.stable_intervals == p.collision_free_intervals == [(p.tau_min, 10.0)]
    assert p.tau_opt == pytest.approx(p.omega * (10.0 - p.tau_min) + p.tau_min)
    assert abs(p.tau - p.tau_opt) <= 0.025 + 1e-9
    assert {r.reason for r in p.rejections} == {"unstable"}
    assert all(r.tau < p.tau_min for r in p.rejections)
    tr = p.trajectory
    assert tr is not None and tr.y_final == pytest.approx(road.lane_center(2))
    assert tr.vxf == pytest.approx(kmh(110))


def test_collision_free_set_of_two_intervals() -> None:
    """SV 110 -> 90 km/h into lane 0 behind a 90 km/h TV 15 m ahead: quick changes slot
    in behind it, slow ones pass it first, the ones in between hit it."""
    road = RoadParams(mu=0.8)
    planner = LaneChangePlanner(VEH, road, PlannerConfig())
    p = planner.plan(0.0, sv_state(road, 1, 110), 0, [tv_msg(road, "a", 0, 15.0, 90)], 0.5)
    iv = p.collision_free_intervals
    assert len(iv) == 2
    (lo1, hi1), (lo2, hi2) = iv
    assert lo1 == pytest.approx(p.tau_min) and hi1 < lo2 and hi2 == 10.0
    between = [r for r in p.rejections if hi1 < r.tau < lo2]
    assert between and all(r.reason == "collision" and r.vehicle_id == "a" for r in between)
    assert all(0.0 < r.time <= r.tau + planner.config.horizon_extra for r in between)
    assert p.tau is not None and p.collision_free[np.isclose(p.taus, p.tau)].all()


def test_no_collision_free_tau_keeps_the_lane() -> None:
    road = RoadParams(mu=0.6)
    # a car right beside the SV in the target lane, same speed
    p = LaneChangePlanner(VEH, road, PlannerConfig()).plan(
        0.0, sv_state(road, 1, 100), 2, [tv_msg(road, "b", 2, 0.0, 100)], 0.5)
    assert not p.feasible and p.tau is None and p.trajectory is None
    assert np.isnan(p.tau_opt) and p.collision_free_intervals == []
    assert {r.vehicle_id for r in p.rejections if r.reason == "collision"} == {"b"}


def test_safety_margin_shrinks_the_set() -> None:
    road = RoadParams(mu=0.4)
    msgs = [tv_msg(road, "pvc", 0, 15.0, 70)]
    base = LaneChangePlanner(VEH, road, PlannerConfig()).plan(
        0.0, sv_state(road, 0, 80), 1, msgs, 0.2)
    wide = LaneChangePlanner(VEH, road, PlannerConfig(safety_margin=0.5)).plan(
        0.0, sv_state(road, 0, 80), 1, msgs, 0.2)
    assert wide.collision_free.sum() < base.collision_free.sum()
    assert not (wide.collision_free & ~base.collision_free).any()


def test_check_a_committed_trajectory() -> None:
    road = RoadParams(mu=0.6)
    planner = LaneChangePlanner(VEH, road, PlannerConfig())
    p = planner.plan(0.0, sv_state(road, 1, 100), 2, [], 0.5)
    assert p.trajectory is not None
    assert planner.check(p.trajectory, 1.0, []) is None
    # one second in, a car appears in the target lane where the SV is heading
    x, _ = p.trajectory.position(np.array([1.0]))
    cut = V2VMessage("cut", 1.0, float(x[0]) + 8.0, road.lane_center(2), 0.0, kmh(100), 0.0,
                     2, 0.0, 4.32, 1.8, 0, None)
    rej = planner.check(p.trajectory, 1.0, [cut])
    assert rej is not None and rej.reason == "collision" and rej.vehicle_id == "cut"
    assert 1.0 <= rej.time <= p.trajectory.t_end + planner.config.horizon_extra


def test_plan_to_dict_is_json() -> None:
    road = RoadParams(mu=0.4)
    p = LaneChangePlanner(VEH, road, PlannerConfig()).plan(
        0.0, sv_state(road, 0, 80), 1, [tv_msg(road, "pvc", 0, 15.0, 70)], 0.2)
    d = json.loads(json.dumps(p.to_dict()))
    for key in ("tau_min", "tau_max", "stable", "collision_free", "tau_opt", "omega",
                "planning_time_s", "rejected"):
        assert key in d
    assert d["collision_free"] == [[pytest.approx(a), pytest.approx(b)]
                                   for a, b in p.collision_free_intervals]
    assert {r["reason"] for r in d["rejected"]} == {"unstable", "collision"}


def test_bad_requests_are_input_errors() -> None:
    road = RoadParams()
    planner = LaneChangePlanner(VEH, road, PlannerConfig())
    with pytest.raises(InputError, match="target_lane"):
        planner.plan(0.0, sv_state(road, 0, 80), 2, [], 0.5)
    with pytest.raises(InputError, match="occupant"):
        planner.plan(0.0, sv_state(road, 0, 80), 1, [], 1.5)
    with pytest.raises(InputError, match="envelope"):
        LaneChangePlanner(VEH, road, PlannerConfig(envelope="magic"))


def test_paper_case1_overtaking() -> None:
    exact = plan_file("paper_case1_overtaking")
    col = plan_file("paper_case1_overtaking", collision_test="col")
    # (the SV's tau_min is an upper bound of the envelope's: 2.78 s from the map, 2.79 s
    # with the map's interpolation error)
    assert exact.tau_min == pytest.approx(2.75, abs=0.05)
    (lo, hi), = exact.collision_free_intervals
    (_, hi_col), = col.collision_free_intervals
    assert lo == exact.tau_min
    # the paper's 6.75 s is the last point of its 0.25 s grid inside either set
    assert 6.75 <= hi <= hi_col < 7.0
    assert {r.vehicle_id for r in exact.rejections if r.reason == "collision"} == {"pvc"}
    assert exact.tau == pytest.approx(6.35, abs=0.1)  # paper 6.25 on its grid


def test_paper_case2_tv_changing_lanes() -> None:
    p = plan_file("paper_case2_tv_lane_change")
    assert p.categories == {"pvt": "C3"}
    assert p.tau_min == pytest.approx(2.56, abs=0.04)
    (lo, hi), = p.collision_free_intervals
    assert 8.56 <= hi < 8.81  # the paper's 8.56 s is the last point of its grid inside
    assert p.tau == pytest.approx(5.56, abs=0.1)


def test_paper_case3_lane_exchange() -> None:
    exact = plan_file("paper_case3_lane_exchange")
    col = plan_file("paper_case3_lane_exchange", collision_test="col")
    assert exact.categories == {"tv1": "C2", "tv2": "C1"}
    assert exact.tau_min == pytest.approx(2.23, abs=0.04)
    # only long lane changes let TV 1 (any of its stable trajectories) pass first
    (lo, hi), = exact.collision_free_intervals
    (lo_col, hi_col), = col.collision_free_intervals
    assert 6.0 < lo_col < lo and hi == hi_col == 10.0
    assert {r.vehicle_id for r in exact.rejections if r.reason == "collision"} == {"tv1"}


def test_refinement_between_samples_is_nearly_exact() -> None:
    """With the look between samples, the 0.05 s planner finds the set a 0.01 s one finds
    (case 5.1: the true boundary lies between 6.85 and 6.90 s)."""
    sc = load_scenario(ROOT / "scenarios" / "paper_case1_overtaking.toml")
    si = situation(sc)
    ends = []
    for step in (0.05, 0.01):
        p = LaneChangePlanner(sc.vehicle, si.road, sc.planner, collision_step=step).plan(
            si.t, si.sv, si.target_lane, si.messages, si.occupant)
        ends.append(p.collision_free_intervals[-1][1])
    assert 6.75 <= ends[0] <= ends[1] <= 6.9


def test_tau_min_maps_are_built_once_per_process_and_plans_do_not_depend_on_it() -> None:
    """Two planners with the same car, road and settings share one built map (0.3-0.6 s
    each); a plan made after other maps were built equals one made first."""
    sc = load_scenario(ROOT / "scenarios" / "paper_case3_lane_exchange.toml")
    si = situation(sc)
    a = LaneChangePlanner(sc.vehicle, si.road, sc.planner)
    b = LaneChangePlanner(sc.vehicle, si.road, sc.planner)
    assert a.tau_min_map(25.0, 3.75) is b.tau_min_map(25.0, 3.75)
    other = LaneChangePlanner(sc.vehicle, si.road, replace(sc.planner, safety_factor=0.7))
    assert other.tau_min_map(25.0, 3.75) is not a.tau_min_map(25.0, 3.75)
    first = b.plan(si.t, si.sv, si.target_lane, si.messages, si.occupant)
    again = LaneChangePlanner(sc.vehicle, si.road, sc.planner).plan(
        si.t, si.sv, si.target_lane, si.messages, si.occupant)
    assert first.tau == again.tau
    np.testing.assert_array_equal(first.taus, again.taus)
    assert first.collision_free_intervals == again.collision_free_intervals


def test_gently_braking_traffic_ahead_does_not_block_a_change_it_can_be_followed_in() -> None:
    """Dense traffic at ~10 m/s (density study, 60 veh/km/lane): the SV speeds up from
    8 to 9.8 m/s into a gap 9.5 m behind its new leader; a TV 76 m ahead in the target
    lane brakes at 0.34 m/s^2. The look further ahead (`_follow_horizon`) ends where the
    farthest candidate could still follow the TV as predicted, so nothing is rejected
    for it (the first version drove the SV at its end speed into the stopped TV)."""
    road = RoadParams(mu=0.8)
    planner = LaneChangePlanner(VEH, road, PlannerConfig())
    sv = SVPlanState(745.4, road.lane_center(1), 0.0, 8.0, 0.0, 0.0, 0.0, 1)

    def msg(vid: str, dx: float, speed: float, accel: float) -> V2VMessage:
        return V2VMessage(vehicle_id=vid, t=0.0, x=sv.x + dx, y=road.lane_center(2),
                          heading=0.0, speed=speed, accel=accel, lane=2, lateral_speed=0.0,
                          length=4.32, width=1.8, intention=0)

    leader = msg("leader", 9.5, 9.8, 0.0)
    braking = msg("braking", 76.1, 9.86, -0.336)
    p = planner.plan(0.0, sv, 2, [leader, braking], 0.5, vxf=9.8)
    assert p.feasible and p.collision_free_intervals
    assert not [r for r in p.rejections if r.vehicle_id == "braking"]
    # its horizon: the farthest SV (9.8 m/s) reaches the gap it can follow from
    _, follow = planner._horizon(0.0, 0.0, sv.x, 8.0, 9.8, 2, [leader, braking])
    s = follow[1]
    assert s > planner.config.tau_max + planner.config.horizon_extra

    def short(s: float) -> bool:  # closer than it can follow from, at time s
        v_tv = 9.86 - 0.336 * s
        gap = braking.x + 9.86 * s - 0.168 * s * s - (sv.x + 9.8 * s) - 0.5 * (4.32 + VEH.length)
        return gap < 2.0 + v_tv + (9.8 - v_tv) ** 2 / (2 * 0.3 * 0.8 * 9.81)

    assert short(s) and not short(s - planner.collision_step)
