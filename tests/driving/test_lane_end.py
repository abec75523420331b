"""The SV on a lane that ends (cosim.driving.lane_end) on hand-made scenes,
without SUMO: an acceleration lane at d < 0 (lane 0, y_right = -lane width) ending at
END beside a three-lane mainline; the real planner and policies ("paper", "gap"); the
mainline's TVs at constant speed in lane 1 (given both as the scene and as V2V
messages); the SV follows its reference exactly.

It shows: the mandatory trigger fires once the end is within the LC2013 look-ahead and
not before; every adopted plan ends before the end; with the mainline blocked the SV
stops before the end and merges once a gap opens; a change aborted near the end still
stops before it; the decision rule does not change into a lane that ends."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cosim.driving.base import DrivingContext, WorldPorts
from cosim.driving.lane_end import (
    MERGE_ACCEL,
    MERGE_CURVATURE,
    MERGE_INSIST_DECEL,
    MERGE_PEAK_ACCEL,
    WAIT_ROOM,
    SVLaneEnds,
    stop_accel,
)
from cosim.driving.layout import LaneLayout
from cosim.driving.manoeuvre import Mode
from cosim.driving.plans import Trigger
from cosim.driving.recheck import BRAKE_DECELS, BRAKE_GRIP
from cosim.driving.registry import policy_class
from cosim.driving.rule import DecisionConfig
from cosim.params import G, RoadParams
from cosim.planning.deadline import END_MARGIN
from cosim.planning.planner import LaneChangePlanner, SVPlanState, path_curvature
from cosim.scenario import LaneChangeCommand, Scenario, load_scenario, project_root
from cosim.traffic.snapshot import TrafficSnapshot
from cosim.traffic.v2v import V2VMessage
from cosim.traffic.world import Scene, SVState

sys.path.insert(0, str(Path(__file__).parent))
from doubles import Forced, Inbox, fly  # noqa: E402

BANDS = ((60 / 3.6, 90 / 3.6),) * 4
END = 200.0
RAMP = RoadParams(mu=0.8, y_right=-3.75, speed_bands=BANDS, lane_ends=(END,))
DT = 0.05
BASE = load_scenario(project_root() / "scenarios/paper_case1_overtaking.toml")
L = BASE.vehicle.length
HALF = 0.5 * L
NEAR = 150.0  # m, TVs this close to the SV are in the scene and the messages


def scenario(speed: float, *, requests: tuple[tuple[float, int], ...] = (),
             decision: bool = False, replanning: bool = False,
             road: RoadParams = RAMP) -> Scenario:
    sv = replace(BASE.sv, lane_changes=tuple(LaneChangeCommand(at=a, target_lane=b)
                                             for a, b in requests),
                 decision=decision, lane=0, speed=speed, desired_speed=speed)
    return replace(BASE, sv=sv, tvs=(), road=road,
                   planner=replace(BASE.planner, replanning=replanning, recheck_interval=0.5))


@dataclass
class Stream:
    """TVs in one lane at x0 + v t; `until`: the stream's tail (a TV whose x0 is below
    it does not exist: the gap behind the last one is open)."""

    x0: np.ndarray
    v: float
    lane: int = 1
    tail: float = -math.inf

    def at(self, t: float, near: float) -> tuple[np.ndarray, np.ndarray]:
        keep = self.x0 >= self.tail
        x = self.x0[keep] + self.v * t
        ids = np.flatnonzero(keep)
        sel = np.abs(x - near) <= NEAR
        return x[sel], ids[sel]


class Drive:
    """A policy on the ramp; the SV is exactly where its reference says."""

    def __init__(self, name: str, sc: Scenario, x0: float, stream: Stream | None = None,
                 planner: Any = None, road: RoadParams = RAMP, lane: int = 0) -> None:
        self.road = road
        self.planner = planner or LaneChangePlanner(sc.vehicle, road, sc.planner)
        self.asked: list[tuple[float, str]] = []  # t, TV id
        ports = WorldPorts(ask_gap=lambda t, tv: self.asked.append((t, tv)))
        self.policy = policy_class(name)(DrivingContext.of(
            sc, road, decision=DecisionConfig(), planner=self.planner, ports=ports))
        self.sv = SVState(x0, road.lane_center(lane), 0.0, sc.sv.speed, 0.0, 0.0)
        self.stream = stream
        self.inbox = Inbox()
        self.t = 0.0
        self.track: list[tuple[float, float, float, float]] = []  # t, x, y, vx

    def scene(self) -> Scene:
        t, road = self.t, self.road
        if self.stream is None:
            xs, ids = np.zeros(0), np.zeros(0, int)
            v, lane = 0.0, 1
        else:
            xs, ids = self.stream.at(t, self.sv.x)
            v, lane = self.stream.v, self.stream.lane
        n = xs.size
        z = np.zeros(n)
        names = tuple(f"tv{i}" for i in ids)
        snap = TrafficSnapshot(t, names, xs, np.full(n, road.lane_center(lane)), z,
                               np.full(n, v), z, np.full(n, lane), z, np.full(n, 4.32),
                               np.full(n, 1.8), np.zeros(n, int))
        self.inbox.messages = [
            V2VMessage(vehicle_id=names[i], t=t, x=float(xs[i]), y=road.lane_center(lane),
                       heading=0.0, speed=v, accel=0.0, lane=lane, lateral_speed=0.0,
                       length=4.32, width=1.8, intention=0) for i in range(n)]
        return Scene(t, self.sv, snap, snap, np.full(n, v))

    def step(self) -> None:
        t = self.t
        ref = self.policy.update(t, self.scene(), self.inbox)
        t1 = t + DT
        self.sv = fly(ref, t1)
        self.t = round(t1, 9)
        self.track.append((self.t, self.sv.x, self.sv.y, self.sv.vx))

    def run(self, t_end: float) -> None:
        while self.t < t_end - 1e-9:
            self.step()

    @property
    def plans(self) -> list[dict[str, Any]]:
        return self.policy.manoeuvre.plans

    def in_ending_lane(self) -> np.ndarray:
        """(t, front x) of every step where the SV's body touches lane 0."""
        tr = np.array(self.track)
        lo, _ = LaneLayout(self.road).lanes_touched(tr[:, 2], 0.9)
        on = lo <= 0
        return np.column_stack([tr[on, 0], tr[on, 1] + HALF])


def assert_plans_end_before_the_end(d: Drive) -> None:
    """Every adopted plan out of lane 0 ends with the front END_MARGIN before END."""
    flown = [lc for lc in d.policy.manoeuvre.lane_changes if lc.start_lane == 0]
    for lc in flown:
        tr = lc.plan.trajectory
        x_end = float(tr.position(tr.t0 + tr.tau)[0])
        assert x_end + HALF + END_MARGIN <= END + 1e-6, (lc.trigger, x_end)


# ------------------------------------------------------------------ the trigger


@pytest.mark.parametrize("name", ["paper", "gap"])
def test_the_mandatory_trigger_fires_within_the_look_ahead_and_not_before(name: str) -> None:
    road = replace(RAMP, lane_ends=(2000.0,))
    v = 20.0
    horizon = v * 10.0 * 2.0 + 2.0 * (L + 2.5)  # LC2013's, to the left: 417.3 m
    x0 = 2000.0 - HALF - horizon - 30.0  # 30 m (1.5 s) before it is due
    d = Drive(name, scenario(v, road=road), x0, road=road)
    end = d.policy.manoeuvre.ends.ahead(0, x0, v)
    assert end is not None and end.horizon == pytest.approx(horizon) and not end.due
    d.run(1.45)
    assert d.plans == [] and d.policy.manoeuvre.active is None
    d.run(1.6)
    assert [p["trigger"] for p in d.plans] == [Trigger.MANDATORY] and d.plans[0]["ok"] == 1
    assert d.plans[0]["t_s"] == pytest.approx(1.5, abs=DT + 1e-9)
    lc = d.policy.manoeuvre.active
    assert lc is not None
    assert (lc.start_lane, lc.target_lane, lc.trigger) == (0, 1, Trigger.MANDATORY)


def test_it_overrides_a_scripted_request_and_the_speed_band_rule() -> None:
    # a scripted request for lane 1 later, and the paper's rule on: the change is asked
    # for as mandatory at once, the scripted request stays pending (served: same lane)
    d = Drive("paper", scenario(20.0, requests=((5.0, 1),), decision=True), 60.0)
    d.step()
    assert [p["trigger"] for p in d.plans] == [Trigger.MANDATORY]
    assert [c.target_lane for c in d.policy.manoeuvre.scripted.pending] == [1]


def test_no_trigger_without_lane_ends_and_none_on_the_mainline() -> None:
    d = Drive("gap", scenario(20.0, road=replace(RAMP, lane_ends=())), 150.0,
              road=replace(RAMP, lane_ends=()))
    d.run(1.0)
    assert d.plans == []
    m = Drive("gap", scenario(20.0), 150.0, lane=1)
    m.run(1.0)
    assert m.plans == []


# ------------------------------------------------------------------ the deadline


@pytest.mark.parametrize("name", ["paper", "gap"])
@pytest.mark.parametrize("x0", [60.0, 140.0, 150.0])
def test_every_plan_ends_before_the_lane_end(name: str, x0: float) -> None:
    # a free mainline: it goes at once; the nearer the end, the shorter the plan
    d = Drive(name, scenario(20.0), x0)
    d.step()
    assert d.plans[0]["trigger"] == Trigger.MANDATORY and d.plans[0]["ok"] == 1
    assert_plans_end_before_the_end(d)
    lc = d.policy.manoeuvre.active
    assert lc is not None
    if x0 >= 140.0:
        assert "lane end:" in d.plans[0]["rejections"]  # the long taus were cut
    d.run(lc.t0 + lc.tau + DT)
    assert abs(d.sv.y - RAMP.lane_center(1)) < 1e-6
    front = d.in_ending_lane()
    assert front[:, 1].max() <= END - END_MARGIN + 1e-6


@pytest.mark.parametrize("name", ["paper", "gap"])
def test_a_change_that_cannot_end_in_time_is_not_flown(name: str) -> None:
    # 28 m to the end at 20 m/s: no stable plan ends before it, at any end speed
    d = Drive(name, scenario(20.0), 170.0)
    d.step()
    assert d.plans and all(p["trigger"] == Trigger.MANDATORY and p["ok"] == 0 for p in d.plans)
    assert all("lane end:" in p["rejections"] for p in d.plans)
    assert d.policy.manoeuvre.active is None


def test_the_urgency_law_asks_more_of_the_follower_as_the_end_nears() -> None:
    from cosim.driving.gap.decision import mandatory_config, urgent_decel
    from cosim.driving.gap.geometry import GapConfig

    cfg = GapConfig()
    assert urgent_decel(cfg, 0.0) == cfg.plan_decel
    assert urgent_decel(cfg, 1.0) == cfg.insist_decel
    assert urgent_decel(cfg, 0.5) == pytest.approx(0.5 * (cfg.plan_decel + cfg.insist_decel))
    # in the policy (a mandatory change's settings: up to the follower's decel, 4.5
    # m/s^2, as LC2013 asks of a blocking follower): a TV 50 m behind in lane 1 at 21
    # m/s, 1 m/s faster than the SV, would brake more than 1 m/s^2 for an entry now:
    # refused just after the change became due (urgency 0.02: 1.05 m/s^2 allowed),
    # taken 50 m before the end (urgency 0.89: 4.1 m/s^2)
    cfg = mandatory_config(cfg)
    assert cfg.insist_decel == MERGE_INSIST_DECEL
    road = replace(RAMP, lane_ends=(430.0,))
    went = {}
    for x0 in (20.0, 380.0):
        d = Drive("gap", scenario(20.0, road=road), x0,
                  Stream(np.array([x0 - 50.0, x0 + 300.0]), 21.0), road=road)
        d.step()
        due = d.policy.manoeuvre.ends.due(0, d.sv)
        assert due is not None
        last = d.policy.last
        assert last is not None
        went[x0] = (last.plan_now, due.urgency)
        if last.plan_now:
            assert last.follower_decel == pytest.approx(urgent_decel(cfg, due.urgency), abs=0.02)
            assert d.plans[-1]["trigger"] == Trigger.MANDATORY and d.plans[-1]["ok"] == 1
    assert not went[20.0][0] and went[20.0][1] < 0.1
    assert went[380.0][0] and went[380.0][1] > 0.8


def test_a_mandatory_change_asks_no_more_than_the_urgency_law_however_long_it_seeks() -> None:
    # the scene above just after the change became due: the entry would ask the TV 50 m
    # behind for more than the urgency law allows yet; seeking longer than
    # GapConfig.patience does not make it insist (a change by choice would ask for
    # insist_decel then): its follower's limit grows only as the end nears (an insisted
    # merge would make its new follower brake at its full 4.5 m/s^2)
    from cosim.driving.gap.geometry import GapConfig

    road = replace(RAMP, lane_ends=(430.0,))
    d = Drive("gap", scenario(20.0, road=road), 20.0,
              Stream(np.array([-30.0, 320.0]), 21.0), road=road)
    d.policy.seeking_since = -2.0 * GapConfig().patience  # it has sought a while already
    d.step()
    last = d.policy.last
    assert last is not None and last.target_lane == 1 and not last.plan_now
    assert d.plans == []


def test_an_urgent_entry_that_asks_its_follower_nothing_is_not_held_to_the_insist_margin(
) -> None:
    # the shipped ramp's start (a 194.5 m acceleration lane, the SV 20 m in at 70 km/h):
    # lane 1 holds a TV 54 m behind and one 62 m ahead, both at 24.4 m/s. An entry now
    # asks the one behind for nothing; the check an insisting entry also passes (the TVs
    # behind 1 m/s faster) would flip its predicted braking to 4.5 m/s^2. Not insisting,
    # it goes (refused, the SV would stop at its stop line on a near-empty mainline)
    road = replace(RAMP, lane_ends=(194.5,))
    d = Drive("gap", scenario(19.44, road=road), 20.0,
              Stream(np.array([20.0 - 54.0, 20.0 + 62.0]), 24.4), road=road)
    d.step()
    due = d.policy.manoeuvre.ends.due(0, d.sv)
    assert due is not None and due.urgency > 0.5
    assert d.policy.last is not None and d.policy.last.plan_now
    assert [p["ok"] for p in d.plans] == [1] and d.plans[0]["trigger"] == Trigger.MANDATORY


# ------------------------------------------------------------------ the stop


def test_a_merge_from_a_slow_start_ends_at_the_speed_it_reaches_comfortably() -> None:
    # from 6.4 m/s (a ramp's corners) the band's 16.7 m/s is out of comfortable reach
    # in a 3.5 s merge: it ends at 6.4 + 2.6 * 3.5 m/s, accelerating at most 3.9 m/s^2
    ends = SVLaneEnds(LaneLayout(RAMP), L)
    sv = SVState(END - 150.0, RAMP.lane_center(0), 0.0, 6.4, 0.0, 0)
    slow = ends.limits(0, sv, 1, None, True, 3.5)
    assert slow.vxf == pytest.approx(6.4 + MERGE_ACCEL * 3.5) and slow.vxf < BANDS[1][0]
    assert slow.accel == MERGE_PEAK_ACCEL
    planner = LaneChangePlanner(BASE.vehicle, RAMP, BASE.planner)
    plan = planner.plan(0.0, SVPlanState(sv.x, sv.y, 0.0, slow.vx0, 0.0, 0.0, 0.0, 0), 1, [],
                        0.5, vxf=slow.vxf, x_limit=slow.x_limit, max_accel=slow.accel)
    assert plan.tau is not None and 1.5 * (slow.vxf - 6.4) / plan.tau <= MERGE_PEAK_ACCEL + 1e-6
    # near the band's speed the band's speed; a change by choice is not bound, nor the
    # paper's policy's merge (no merge duration)
    assert ends.limits(0, replace(sv, vx=15.0), 1, None, True, 3.5).vxf == BANDS[1][0]
    free = ends.limits(0, sv, 1, None, False)
    assert free.vxf is None and free.accel == math.inf
    paper = ends.limits(0, sv, 1, None, True)
    assert paper.vxf == BANDS[1][0] and paper.accel == math.inf


def test_the_stop_law_stops_at_the_stop_line() -> None:
    assert stop_accel(20.0, math.inf, 2.0) == math.inf
    assert stop_accel(20.0, 300.0, 2.0) > 0.0  # far: no braking
    assert stop_accel(20.0, 60.0, 2.0) < -1.0  # near: braking
    assert stop_accel(0.0, 2.0, 2.0) == 0.0  # at its standstill gap: stays


@pytest.mark.parametrize("name", ["paper", "gap"])
def test_with_the_mainline_blocked_it_stops_before_the_end_and_merges_once_a_gap_opens(
        name: str) -> None:
    # a platoon at 15 m/s, 12 m apart (bumper gaps 7.7 m: no gap for the SV), its last
    # car starting at x = -560: it passes the end of the ramp at about t = 50 s
    stream = Stream(np.arange(-560.0, 400.0, 12.0), 15.0, tail=-560.0)
    d = Drive(name, scenario(15.0), 40.0, stream)
    d.run(40.0)
    m = d.policy.manoeuvre
    assert m.active is None and m.lane_changes == []  # no gap: it has not gone
    assert all(p["trigger"] == Trigger.MANDATORY and p["ok"] == 0 for p in m.plans)
    # it stopped before the end, WAIT_ROOM short of it, and waits there
    assert d.sv.vx < 0.05
    assert d.sv.x + HALF < END - WAIT_ROOM + 0.5
    assert d.sv.x + HALF > END - WAIT_ROOM - 5.0
    if name == "gap":  # it asked the platoon to make room (the traffic's courtesy)
        assert d.asked
    d.run(75.0)
    ok = [p for p in m.plans if p["ok"] == 1]
    assert ok and ok[0]["trigger"] == Trigger.MANDATORY
    assert ok[0]["vx0_mps"] >= 1.0 - 1e-9  # from a standstill: the creep speed
    assert_plans_end_before_the_end(d)
    assert abs(d.sv.y - RAMP.lane_center(1)) < 1e-6  # merged
    front = d.in_ending_lane()
    assert front[:, 1].max() <= END - END_MARGIN + 1e-6
    # it merged behind the platoon's last car (level with the SV's stop line, 47 m
    # before the end, at about t = 47 s)
    assert ok[0]["t_s"] > 40.0
    # on a path a car can steer from a standstill, to 8-13 m/s (the room's 7-10 s plans)
    lc = m.lane_changes[0]
    tr = lc.plan.trajectory
    kappa = path_curvature(lc.plan.sv, tr.vxf, tr.width, np.array([tr.tau]))
    assert kappa[0] <= MERGE_CURVATURE + 1e-9 and 5.0 < tr.vxf < 13.0


@pytest.mark.parametrize("name", ["paper", "gap"])
def test_a_standstill_read_a_hair_below_zero_still_merges(name: str) -> None:
    # the two-track plant standing at the stop line reads vx = -1e-12 m/s: a standstill.
    # A speed test on the merge (vx >= 0) would keep such an SV from ever merging while
    # the queue it had asked to make room stood beside it; lane 1 is free here
    d = Drive(name, scenario(0.0), END - WAIT_ROOM - HALF)
    m = d.policy.manoeuvre
    assert m.ends.due(0, replace(d.sv, vx=20.0)) is not None  # due since it came at speed
    d.sv = replace(d.sv, vx=-1e-12)
    d.step()
    # planned at once (at the slower end speed that fits the room) and flying it
    assert {p["trigger"] for p in d.plans} == {Trigger.MANDATORY} and d.plans[-1]["ok"] == 1
    assert m.mode == Mode.CHANGING


# ------------------------------------------------------------------ abort near the end


@pytest.mark.parametrize("name", ["paper", "gap"])
@pytest.mark.parametrize(("x0", "speed"), [(100.0, 20.0), (130.0, 15.0)])
def test_an_aborted_change_near_the_end_still_stops_before_it(name: str, x0: float,
                                                               speed: float) -> None:
    sc = scenario(speed, replanning=True)
    forced = Forced(LaneChangePlanner(sc.vehicle, RAMP, sc.planner))
    d = Drive(name, sc, x0, planner=forced)
    d.step()
    m = d.policy.manoeuvre
    assert m.mode == Mode.CHANGING and m.active is not None
    forced.collide, forced.no_tau = 1, {1}  # the re-check fails, no replan into lane 1
    d.run(0.5 + DT)
    assert m.recheck.outcomes == {"replan": 0, "abort": 0, "brake": 1}
    # no planner abort back into the ending lane: the brake, to the nearest centre
    assert ("plan", 0) not in forced.calls
    assert m.mode == Mode.BRAKING and m.plans[-1]["trigger"] == "brake"
    d.run(20.0)
    # it stopped in lane 0 before the end and waits (lane 1 still refused)
    assert d.sv.vx < 0.05 and abs(d.sv.y - RAMP.lane_center(0)) < 1e-3
    front = d.in_ending_lane()
    assert front[:, 1].max() <= END - END_MARGIN
    assert m.plans[-1]["trigger"] == Trigger.MANDATORY and m.plans[-1]["ok"] == 0
    # lane 1 opens: it merges from the standstill
    forced.no_tau = set()
    d.run(30.0)
    assert abs(d.sv.y - RAMP.lane_center(1)) < 1e-6
    assert d.in_ending_lane()[:, 1].max() <= END - END_MARGIN


@pytest.mark.parametrize(("failing", "decel"), [(0, 1.0), (1, 2.0), (3, None)])
def test_a_brake_is_as_gentle_as_the_re_check_allows(failing: int, decel: float | None
                                                     ) -> None:
    # the re-check fails with neither a replan nor an abort left: the brake is the
    # gentlest of BRAKE_DECELS (mean deceleration over its tau) whose own check passes,
    # and is re-checked; when none passes, the grip's, not re-checked (it was always the
    # grip's: 4.1-4.8 m/s^2 in 26 of the merge study's 100 runs, for collisions
    # predicted 3.4-6.9 s ahead)
    road = replace(RAMP, lane_ends=())
    sc = scenario(25.0, requests=((0.0, 2),), replanning=True, road=road)
    forced = Forced(LaneChangePlanner(sc.vehicle, road, sc.planner))
    d = Drive("paper", sc, 50.0, planner=forced, road=road, lane=1)
    d.step()
    m = d.policy.manoeuvre
    assert m.mode == Mode.CHANGING
    forced.collide, forced.no_tau = 1 + failing, {1, 2}
    d.run(0.5 + DT)
    assert m.recheck.outcomes == {"replan": 0, "abort": 0, "brake": 1} and m.mode == Mode.BRAKING
    brake = m.active.trajectory
    mean = (brake.vx0 - brake.vxf) / brake.tau
    grip = BRAKE_GRIP * road.mu * G / 1.5
    assert mean == pytest.approx(grip if decel is None else decel, rel=1e-9)
    assert math.isfinite(m.recheck.next_check) == (decel is not None)
    if decel is not None:  # re-checked: failing again, it brakes anew from where it is
        forced.collide = 1 + sum(1 for b in BRAKE_DECELS if b < grip)  # every gentle one
        d.run(1.0 + DT)
        assert m.recheck.outcomes["brake"] == 2 and not math.isfinite(m.recheck.next_check)


# ------------------------------------------------------------------ into an ending lane


def test_the_decision_rule_does_not_change_into_a_lane_that_ends() -> None:
    # on lane 1 behind a slow leader, lane 2 blocked by a TV beside: lane 0 (the ramp,
    # ending within the look-ahead) is free and faster by its band, but not taken
    bands = ((60 / 3.6, 120 / 3.6),) + ((60 / 3.6, 90 / 3.6),) * 3
    road = replace(RAMP, speed_bands=bands)
    for name in ("paper", "gap"):
        d = Drive(name, scenario(25.0, decision=True, road=road), 60.0,
                  Stream(np.array([90.0]), 10.0, lane=1), road=road, lane=1)
        d.run(2.0)
        assert all(p["target_lane"] != 0 for p in d.plans), name


# ------------------------------------------------------------------ letting TVs in


def ramp_tv_scene(d: Drive, x: float, speed: float) -> Scene:
    """The SV on lane 1 and one TV on the ramp (lane 0) at x."""
    snap = TrafficSnapshot(d.t, ("ramp",), np.array([x]), np.array([RAMP.lane_center(0)]),
                           np.zeros(1), np.array([speed]), np.zeros(1), np.zeros(1, int),
                           np.zeros(1), np.array([4.32]), np.array([1.8]), np.zeros(1, int))
    return Scene(d.t, d.sv, snap, snap, np.array([speed]))


@pytest.mark.parametrize(("gap", "tv_speed", "yields"), [
    (20.0, 19.0, True),  # ahead, a little slower: the SV makes room (ACC: -1.6 m/s^2)
    (2.0, 10.0, False),  # too close and much slower: it would brake hard; not let in
])
def test_the_gap_policy_lets_a_merging_tv_in(gap: float, tv_speed: float,
                                             yields: bool) -> None:
    accels = {}
    for road in (RAMP, replace(RAMP, lane_ends=())):
        d = Drive("gap", scenario(20.0, road=road), 100.0, road=road, lane=1)
        x_tv = 100.0 + HALF + gap + 2.16
        d.policy.update(0.0, ramp_tv_scene(d, x_tv, tv_speed), d.inbox)
        accels[bool(road.lane_ends)] = d.policy.following.accel
    if yields:
        assert accels[True] < accels[False] - 0.1  # it brakes for the ramp's TV
        assert accels[True] >= -2.0 - 1e-9
    else:
        assert accels[True] == accels[False]
    # the paper's SV does not (its car following is the paper's rule)
    p = Drive("paper", scenario(20.0), 100.0, lane=1)
    p.policy.update(0.0, ramp_tv_scene(p, 100.0 + HALF + gap + 2.16, tv_speed), p.inbox)
    q = Drive("paper", scenario(20.0, road=replace(RAMP, lane_ends=())), 100.0,
              road=replace(RAMP, lane_ends=()), lane=1)
    q.policy.update(0.0, ramp_tv_scene(q, 100.0 + HALF + gap + 2.16, tv_speed), q.inbox)
    assert p.policy.following.accel == q.policy.following.accel


# ------------------------------------------------------------------ lanes that begin


@pytest.mark.parametrize("name", ["paper", "gap"])
def test_no_change_into_a_lane_before_it_begins_beside_the_sv(name: str) -> None:
    """A route from an on-ramp: lane 0 (the ramp's lane, then the acceleration lane)
    from the start, the mainline's lanes only from BEGIN on. The change out of lane 0 is
    due long before (its end is 200 m on), but neither planned nor sought until the whole
    SV is beside lane 1; then it is asked for as mandatory and flown, ending in time; a
    scripted request for lane 1 before it waits the same way."""
    begin = 100.0
    road = replace(RAMP, lane_begins=(-math.inf, begin, begin, begin))
    x0, v = 20.0, 20.0
    d = Drive(name, scenario(v, requests=((0.5, 1),), road=road), x0, road=road)
    ends = d.policy.manoeuvre.ends
    assert not ends.begun(1, x0) and ends.begun(0, x0) and ends.begun(1, begin + HALF)
    assert ends.due(0, d.sv) is None  # within its look-ahead, but lane 1 is not there yet
    reach = (begin + HALF - x0) / v  # s, when the SV's rear passes BEGIN
    d.run(reach - 0.1)
    assert d.plans == [] and d.policy.manoeuvre.active is None
    d.run(reach + 0.5)
    assert d.plans and d.plans[0]["ok"] == 1
    assert d.plans[0]["t_s"] == pytest.approx(reach, abs=DT + 1e-9)
    lc = d.policy.manoeuvre.active
    assert lc is not None and (lc.start_lane, lc.target_lane) == (0, 1)
    assert lc.trigger == Trigger.MANDATORY
    assert_plans_end_before_the_end(d)


def test_a_lane_in_two_is_left_before_its_first_end_and_entered_after_its_begin() -> None:
    """From an on-ramp over an off-ramp (RoadParams.lane_begins): lane 0 is the ramp's
    lane and acceleration lane to 200 m and the deceleration lane from 400 m; lanes 1, 2
    (the mainline) begin at 100 m and exit at 600 m. On lane 0 the change is into lane 1;
    on lane 1, lane 0 is closed between its two parts, and the change back into it is due
    once the deceleration lane runs beside the whole SV; from lane 2 it is into lane 1."""
    road = RoadParams(mu=0.8, speed_bands=BANDS[:3], lane_ends=(200.0, 600.0, 600.0),
                      lane_begins=(400.0, 100.0, 100.0))
    ends = SVLaneEnds(LaneLayout(road), L)

    def at(x: float, lane: int) -> SVState:
        return SVState(x, road.lane_center(lane), 0.0, 25.0, 0.0, lane)

    assert ends.begun(0, 50.0) and not ends.begun(0, 300.0) and ends.begun(0, 400.0 + HALF)
    first = ends.due(0, at(150.0, 0))
    assert first is not None and first.target == 1 and first.end_s == 200.0
    assert ends.ahead(1, 150.0, 25.0) is None  # nothing runs on past the exit yet
    assert ends.closed(0, at(150.0, 1)) and ends.closed(0, at(300.0, 1))
    assert ends.ahead(1, 300.0, 25.0).target == 0 and ends.due(1, at(300.0, 1)) is None
    due = ends.due(1, at(400.0 + HALF, 1))
    assert due is not None and due.target == 0 and due.end_s == 600.0
    assert not ends.closed(0, at(400.0 + HALF, 1))
    assert ends.ahead(2, 300.0, 25.0).target == 1
