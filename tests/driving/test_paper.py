"""The paper's lane-change policy (cosim.driving.paper, its manoeuvre
cosim.driving.manoeuvre) on hand-made scenes, without SUMO: the real
planner plans against hand-made V2V messages; the SV follows its reference exactly.

For the re-check branches a planner that forces the outcome (`Forced`: the check
reports a collision, chosen targets find no tau) wraps the real one, so that each
branch of replan / abort / brake runs on the same scene."""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cosim.driving.base import DrivingContext, WorldPorts
from cosim.driving.manoeuvre import Mode
from cosim.driving.paper import PaperPolicy
from cosim.driving.recheck import GapRecheck
from cosim.driving.registry import policy_class
from cosim.driving.rule import DecisionConfig
from cosim.params import RoadParams
from cosim.planning.planner import LaneChangePlanner
from cosim.scenario import LaneChangeCommand, Scenario, load_scenario, project_root
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.v2v import V2VMessage
from cosim.traffic.world import SV_ID, Scene, SVState

sys.path.insert(0, str(Path(__file__).parent))
from doubles import Forced, Inbox, fly  # noqa: E402

ROAD = RoadParams(mu=0.8)
CFG = DecisionConfig()
DT = 0.05
BASE = load_scenario(project_root() / "scenarios/paper_case1_overtaking.toml")
X0 = 200.0


def scenario(*requests: tuple[float, int], replanning: bool = False) -> Scenario:
    sv = replace(BASE.sv, lane_changes=tuple(LaneChangeCommand(at=a, target_lane=b)
                                             for a, b in requests), decision=False, lane=0)
    return replace(BASE, sv=sv, tvs=(), road=ROAD,
                   planner=replace(BASE.planner, replanning=replanning, recheck_interval=0.5))


def empty_snapshot(t: float) -> TrafficSnapshot:
    none = np.zeros(0)
    return TrafficSnapshot(t, (), none, none, none, none, none, np.zeros(0, int), none, none,
                           none, np.zeros(0, int))


def scene_of(t: float, sv: SVState) -> Scene:
    """A road with no TV near enough for the decision rule (the messages carry them)."""
    snap = empty_snapshot(t)
    return Scene(t, sv, snap, snap, np.zeros(0))


def tv_message(t: float, x: float, lane: int, speed: float, vid: str = "tv") -> V2VMessage:
    return V2VMessage(vehicle_id=vid, t=t, x=x, y=ROAD.lane_center(lane), heading=0.0,
                      speed=speed, accel=0.0, lane=lane, lateral_speed=0.0, length=4.32,
                      width=1.8, intention=0)


class Drive:
    """A policy on hand-made scenes; the SV is exactly where its reference says."""

    def __init__(self, sc: Scenario, planner: Any = None) -> None:
        self.blinks: list[int] = []
        self.planner = planner or LaneChangePlanner(sc.vehicle, ROAD, sc.planner)
        self.policy = policy_class("paper")(DrivingContext.of(
            sc, ROAD, decision=CFG, planner=self.planner,
            ports=WorldPorts(blinker=self.blinks.append)))
        self.sv = SVState(X0, ROAD.lane_center(0), 0.0, sc.sv.speed, 0.0, 0.0)
        self.inbox = Inbox()
        self.t = 0.0
        self.modes: list[str] = []

    def step(self) -> None:
        t = self.t
        ref = self.policy.update(t, scene_of(t, self.sv), self.inbox)
        self.modes.append(self.policy.manoeuvre.mode)
        t1 = t + DT
        self.sv = fly(ref, t1)
        self.t = round(t1, 9)

    def run_until(self, t_end: float) -> None:
        while self.t < t_end - 1e-9:
            self.step()


def test_the_paper_policy_is_registered_by_name() -> None:
    assert policy_class("paper") is PaperPolicy
    assert PaperPolicy.name == "paper"


def test_request_plan_changing_settled() -> None:
    d = Drive(scenario((0.0, 1)))
    d.step()
    pol = d.policy
    m = pol.manoeuvre
    assert m.mode == Mode.CHANGING
    assert d.blinks == [1]  # left
    lc = m.active
    assert lc is not None and (lc.origin_lane, lc.target_lane, lc.trigger) == (0, 1, "scripted")
    status = pol.status(d.sv)
    assert status.changing and status.target_lane == 1 and math.isnan(status.idm_accel)
    assert [row["trigger"] for row in m.plans] == ["scripted"] and m.plans[0]["ok"] == 1
    assert m.scripted.pending == []  # served
    d.run_until(lc.t0 + lc.tau + DT)
    assert m.mode == Mode.KEEPING and m.active is None
    assert d.blinks == [1, 0]
    assert abs(d.sv.y - ROAD.lane_center(1)) < 1e-6  # settled on the target centre
    assert not pol.status(d.sv).changing
    t = np.array([0.0, d.t])
    done = pol.summary(t, np.array([ROAD.lane_center(0), d.sv.y]))
    assert done.starts == [0.0] and done.targets == [ROAD.lane_center(1)]
    assert done.requests == 1 and done.planner_calls == 1


def test_no_plan_waits_and_retries_after_the_interval() -> None:
    d = Drive(scenario((0.0, 1)))
    # a TV beside the SV in the target lane at its speed: no collision-free tau
    d.inbox.messages = [tv_message(0.0, X0, 1, d.sv.vx)]
    d.step()
    pol = d.policy
    m = pol.manoeuvre
    assert m.mode == Mode.WAITING and m.active is None
    assert m.plans[-1]["ok"] == 0 and m.plans[-1]["trigger"] == "scripted"
    assert d.blinks == []
    d.run_until(CFG.retry_interval - DT)
    assert len(m.plans) == 1  # not asked again within the interval
    assert d.modes[-1] == Mode.WAITING
    d.inbox.messages = []  # the target lane is free now
    d.run_until(CFG.retry_interval + DT)
    assert [row["trigger"] for row in m.plans] == ["scripted", "retry"]
    assert m.plans[-1]["t_s"] == pytest.approx(CFG.retry_interval)
    assert m.mode == Mode.CHANGING and m.requests == 1  # a retry is not a new request


def drive_into_recheck(*, collide: int, no_tau: set[int],
                       gap_rules: GapRecheck | None = None) -> Drive:
    sc = scenario((0.0, 1), replanning=True)
    forced = Forced(LaneChangePlanner(sc.vehicle, ROAD, sc.planner))
    d = Drive(sc, forced)
    d.policy.manoeuvre.recheck.gap_rules = gap_rules  # the gap policy's re-check rules
    d.step()  # plan adopted at t = 0
    forced.calls.clear()
    forced.collide, forced.no_tau = collide, no_tau
    d.run_until(0.5 + DT)  # the first re-check is due at recheck_interval
    return d


def test_recheck_collision_replans_to_the_target_lane() -> None:
    d = drive_into_recheck(collide=1, no_tau=set())
    pol = d.policy
    m = pol.manoeuvre
    assert d.planner.calls == [("check", -1), ("plan", 1)]
    assert m.recheck.outcomes == {"replan": 1, "abort": 0, "brake": 0}
    assert m.mode == Mode.CHANGING and m.active is not None and m.active.target_lane == 1
    assert m.plans[-1]["trigger"] == "replan"
    assert m.plans[-1]["reason"].startswith("re-check: collision with tv")
    assert m.recheck.next_check == pytest.approx(1.0)


def test_recheck_without_a_replan_aborts_to_the_origin_lane() -> None:
    d = drive_into_recheck(collide=1, no_tau={1})
    pol = d.policy
    m = pol.manoeuvre
    assert d.planner.calls == [("check", -1), ("plan", 1), ("plan", 0)]
    assert m.recheck.outcomes == {"replan": 0, "abort": 1, "brake": 0}
    lc = m.active
    assert lc is not None and (lc.origin_lane, lc.target_lane, lc.aborted) == (1, 0, True)
    assert d.blinks == [1, -1]
    # the scripted request is asked again once back in the lane
    assert m.scripted.pending and m.scripted.pending[0].target_lane == 1
    d.planner.no_tau = set()
    d.run_until(lc.t0 + lc.tau + 2 * DT)
    assert m.plans[-1]["trigger"] in ("scripted", "retry") and m.plans[-1]["ok"] == 1
    assert m.active is not None and m.active.target_lane == 1


def test_the_gap_policys_abort_ends_no_faster_than_the_sv_drives() -> None:
    """The paper's abort ends at the band rule's speed; the gap policy's at most at the
    SV's speed at the abort (it returns into the traffic it was just in)."""
    ends = {}
    for rules in (None, GapRecheck(sv_width=1.8)):
        d = drive_into_recheck(collide=1, no_tau={1}, gap_rules=rules)
        m = d.policy.manoeuvre
        assert m.recheck.outcomes["abort"] == 1
        row = m.plans[-1]
        assert row["trigger"] == "abort" and row["ok"] == 1
        ends[rules is None] = (row["vxf_mps"], row["vx0_mps"])
    paper, gap = ends[True], ends[False]
    assert paper[0] > paper[1] + 1.0  # the band rule's speed: faster than the SV drives
    assert gap[0] == pytest.approx(gap[1], abs=1e-9)


def test_recheck_without_replan_or_abort_brakes_and_stops_checking() -> None:
    d = drive_into_recheck(collide=5, no_tau={0, 1})
    pol = d.policy
    m = pol.manoeuvre
    assert m.recheck.outcomes == {"replan": 0, "abort": 0, "brake": 1}
    assert m.mode == Mode.BRAKING and m.recheck.next_check == math.inf
    row = m.plans[-1]
    assert row["trigger"] == "brake" and row["ok"] == 1
    lc = m.active
    assert lc is not None and lc.trajectory.vxf < d.sv.vx  # it brakes
    calls = len(d.planner.calls)
    d.run_until(lc.t0 + lc.tau)
    assert len(d.planner.calls) == calls  # not re-checked into another manoeuvre
    d.run_until(lc.t0 + lc.tau + DT)
    assert m.active is None and d.blinks[-1] == 0  # over: keeping its lane again, or
    assert m.mode in (Mode.KEEPING, Mode.WAITING)  # back in lane 0 and asking again (no tau yet)


def test_scripted_requests_are_served_in_order() -> None:
    # the one for the current lane is dropped, the one two lanes away is logged and
    # dropped, then 0 -> 1 and later 1 -> 2 in order
    d = Drive(scenario((0.0, 0), (0.0, 2), (0.0, 1), (8.0, 2)))
    d.step()
    pol = d.policy
    m = pol.manoeuvre
    rows = m.plans
    assert [(r["target_lane"], r["ok"], r["rejections"]) for r in rows] == [
        (2, 0, "not an adjacent lane"), (1, 1, rows[1]["rejections"])]
    assert [c.target_lane for c in m.scripted.pending] == [2]
    d.run_until(7.95)
    assert len(m.plans) == 2  # the next one is not due yet
    d.run_until(8.05)
    assert [r["target_lane"] for r in m.plans] == [2, 1, 2]
    assert m.active is not None and (m.active.origin_lane, m.active.target_lane) == (1, 2)
    assert m.requests == 3


def test_messages_are_read_only_when_planning() -> None:
    d = Drive(scenario((1.0, 1)))
    d.run_until(1.0)
    assert d.inbox.reads == 0  # lane keeping reads no message
    d.step()
    assert d.inbox.reads == 1


def test_the_sv_row_is_not_a_tv_of_the_scene() -> None:
    snap = TrafficSnapshot(0.0, (SV_ID, "a"), np.array([0.0, 10.0]), np.zeros(2), np.zeros(2),
                           np.full(2, 20.0), np.zeros(2), np.zeros(2, int), np.zeros(2),
                           np.full(2, 4.32), np.full(2, 1.8), np.zeros(2, int))
    scene = Scene.around(0.0, SVState(0.0, 0.0, 0.0, 20.0, 0.0, 0.0), snap)
    assert scene.tvs.ids == ("a",)
    np.testing.assert_allclose(scene.tv_vx, [20.0])
