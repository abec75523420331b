"""What automated vehicles announce to each other (cosim.run.announcements), on hand-made
scenes at the planner's level (no SUMO): two of them signalling into one lane from both
sides, each hearing the other through its own V2V channel with latency and loss; who
goes first, and the other yielding to its intention (C2), then to its broadcast
trajectory (C3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.params import PlannerConfig, RoadParams, VehicleParams
from cosim.planning.planner import LaneChangePlanner, Plan, PredictionOptions, SVPlanState
from cosim.planning.prediction import category
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.run.announcements import Announcements, notice
from cosim.traffic.snapshot import TrafficSnapshot
from cosim.traffic.v2v import V2VChannel, V2VMessage

ROAD = RoadParams(mu=0.8)
VEH = VehicleParams()
DT = 0.05  # s
LATENCY = 0.1  # s
LOSS = 0.3
SPEED = 27.5  # m/s, everyone's (on the C2 end-speed grid)
X0 = 200.0  # m, a (lane 0) and b (lane 2) level at t = 0 ...
LEAD = 80.0  # m, ... a SUMO driver this far ahead of them in lane 1: the gap both want
LANES = {"a": 0, "b": 2}


def snapshot(t: float, vid: str) -> TrafficSnapshot:
    """`vid` and the lane-1 driver keeping their lanes at SPEED (what SUMO shows: no
    signals)."""
    one = np.ones(2)
    x = X0 + SPEED * t + np.array([0.0, LEAD])
    y = np.array([ROAD.lane_center(LANES[vid]), ROAD.lane_center(1)])
    return TrafficSnapshot(t, (vid, "lead"), x, y, 0 * one, one * SPEED, 0 * one,
                           np.array([LANES[vid], 1]), 0 * one, one * VEH.length,
                           one * VEH.width, np.zeros(2, dtype=int))


def state(t: float, vid: str) -> SVPlanState:
    lane = LANES[vid]
    return SVPlanState(X0 + SPEED * t, ROAD.lane_center(lane), 0.0, SPEED, 0.0, 0.0, 0.0, lane)


class Pair:
    """a and b, each hearing the other through a channel of its own."""

    def __init__(self) -> None:
        self.heard = Announcements(ROAD)
        self.channels = {vid: V2VChannel(ROAD, latency=LATENCY, loss=LOSS, seed=seed)
                         for vid, seed in (("a", 1), ("b", 2))}
        self.blinkers = {vid: self.heard.blinker(vid, lambda _: None) for vid in LANES}
        # the gap policy's planner: a C2 TV ends its change at its new leader's speed
        self.planner = LaneChangePlanner(VEH, ROAD, PlannerConfig(),
                                         prediction=PredictionOptions(gap_end_speed=True))

    def step(self, t: float) -> dict[str, list[V2VMessage]]:
        """Both exchange at t: each one's raw messages (the other's, as received)."""
        self.heard.t = t
        other = {"a": "b", "b": "a"}
        return {vid: self.channels[vid].exchange(snapshot(t, other[vid]),
                                                 X0 + SPEED * t, ROAD.lane_center(LANES[vid]),
                                                 self.heard.overrides())
                for vid in LANES}

    def plan(self, t: float, vid: str, messages: list[V2VMessage]) -> Plan:
        """`vid`'s plan into lane 1 behind its driver, at its speed (the gap policy's)."""
        return self.planner.plan(t, state(t, vid), 1, messages, 0.5, vxf=SPEED)


def _of(messages: list[V2VMessage], vid: str) -> V2VMessage:
    (m,) = [m for m in messages if m.vehicle_id == vid]
    return m


@pytest.fixture(scope="module")
def run() -> dict[str, object]:
    """a signals at t = 0, b one step later; both keep signalling; a goes at 0.5 s."""
    pair = Pair()
    out: dict[str, object] = {"first_heard": {}}
    t = 0.0
    for k in range(30):
        t = k * DT
        pair.heard.t = t
        if k == 0:
            pair.blinkers["a"](+1)
        if k == 1:
            pair.blinkers["b"](-1)
        raw = pair.step(t)
        for vid, msgs in raw.items():
            if any(m.vehicle_id in LANES and m.intention != 0 for m in msgs):
                out["first_heard"].setdefault(vid, t)  # type: ignore[union-attr]
        if k == 10:  # both have heard the other's intention by now
            out["raw"] = raw
            out["kept"] = {vid: pair.heard.give_way(vid, ROAD.lane_center(LANES[vid]), m)
                           for vid, m in raw.items()}
            out["plans_raw"] = {vid: pair.plan(t, vid, m) for vid, m in raw.items()}
            out["plans"] = {vid: pair.plan(t, vid, m) for vid, m in out["kept"].items()}
            a_plan = out["plans"]["a"]
            assert a_plan.trajectory is not None
            pair.heard.flying("a", a_plan.trajectory)  # a goes: its C3 from now on
            out["t_go"] = t
        if k > 10 and "c3_heard" not in out and _of(raw["b"], "a").motion is not None:
            out["c3_heard"] = t
            kept = pair.heard.give_way("b", ROAD.lane_center(2), raw["b"])
            out["b_c3"] = kept
            out["b_plan_c3"] = pair.plan(t, "b", kept)
    return out


def test_intentions_arrive_after_the_latency_and_losses(run: dict[str, object]) -> None:
    first = run["first_heard"]
    assert isinstance(first, dict)
    assert first["b"] >= 0.0 + LATENCY - 1e-9  # b hears a's blinker no sooner
    assert first["a"] >= DT + LATENCY - 1e-9
    raw = run["raw"]
    assert isinstance(raw, dict)
    assert _of(raw["b"], "a").since == 0.0 and _of(raw["a"], "b").since == pytest.approx(DT)
    assert math.isnan(_of(raw["a"], "lead").since)  # SUMO's driver announces nothing


def test_both_signalling_each_hems_the_other_in(run: dict[str, object]) -> None:
    """Each predicting the other's C2 cluster (every change it may start now, to the same
    gap at the same speed): a has no collision-free duration left, b only its slowest
    ones (beyond a's stable durations): neither would take the gap while both signal."""
    raw = run["plans_raw"]
    assert isinstance(raw, dict)
    assert raw["a"].trajectory is None
    for vid, other in (("a", "b"), ("b", "a")):
        plan = raw[vid]
        hit = plan.stable & ~plan.collision_free
        assert {plan.vehicle_ids[i] for i in plan.hit_vehicle[hit]} == {other}
        assert plan.collision_free.sum() < 0.1 * plan.stable.sum()


def test_the_first_to_signal_goes_the_other_yields_to_its_intention(
        run: dict[str, object]) -> None:
    kept, plans = run["kept"], run["plans"]
    assert isinstance(kept, dict) and isinstance(plans, dict)
    assert category(_of(kept["a"], "b")) == "C1"  # b gives way to a: a predicts it keeping
    assert category(_of(kept["b"], "a")) == "C2"  # b keeps predicting a's intention
    a, b = plans["a"], plans["b"]
    assert a.trajectory is not None and a.collision_free.sum() > 0.5 * a.stable.sum()
    # b: every duration hit by a's cluster but its slowest few
    hit = b.stable & ~b.collision_free
    assert {b.vehicle_ids[i] for i in b.hit_vehicle[hit]} == {"a"}
    assert b.collision_free.sum() < 0.1 * b.stable.sum()


def test_the_other_yields_to_the_broadcast_trajectory(run: dict[str, object]) -> None:
    """a's lane change reaches b as C3 (the very trajectory a flies), after the latency;
    b's plans into lane 1 all hit it."""
    assert run["c3_heard"] >= run["t_go"] + LATENCY - 1e-9  # type: ignore[operator]
    kept, plan = run["b_c3"], run["b_plan_c3"]
    assert isinstance(kept, list) and isinstance(plan, Plan)
    msg = _of(kept, "a")
    assert category(msg) == "C3" and msg.motion is not None
    a_plan = run["plans"]["a"]  # type: ignore[index]
    assert msg.motion.t0 == a_plan.trajectory.t0 and msg.motion.tau == a_plan.trajectory.tau
    assert plan.trajectory is None
    assert any(r.reason == "collision" and r.vehicle_id == "a" for r in plan.rejections)


def test_right_of_way_rules() -> None:
    """Earlier intention first, equal: the smaller id; a C3 is never dropped; an
    intention into another lane is kept."""
    heard = Announcements(ROAD)
    heard.t = 1.0
    heard.blinker("b", lambda _: None)(+1)  # b: lane 0 -> 1 since 1.0
    y0 = ROAD.lane_center(0)

    def msg(vid: str, lane: int, intention: int, since: float, motion: object = None
            ) -> V2VMessage:
        return V2VMessage(vid, 1.0, X0, ROAD.lane_center(lane), 0.0, SPEED, 0.0, lane, 0.0,
                          VEH.length, VEH.width, intention, motion, since)  # type: ignore[arg-type]

    later = msg("c", 2, -1, 1.05)
    tie_bigger, tie_smaller = msg("c", 2, -1, 1.0), msg("a", 2, -1, 1.0)
    earlier = msg("d", 2, -1, 0.5)
    elsewhere = msg("e", 1, +1, 1.5)  # lane 1 -> 2
    sumo_tv = msg("f", 2, -1, math.nan)  # a SUMO driver's blinker: no announcement time
    kept = heard.give_way("b", y0, [later, tie_bigger, tie_smaller, earlier, elsewhere,
                                    sumo_tv])
    assert [m.intention for m in kept] == [0, 0, -1, -1, +1, -1]
    # a vehicle already changing lanes goes before one that only signals
    heard.flying("b", LaneChangeTrajectory(1.0, 4.0, X0, y0, SPEED, SPEED, 3.75))
    assert heard.give_way("b", y0, [earlier])[0].intention == 0
    heard.flying("b", None)  # back to keeping its lane, still signalling
    assert heard.give_way("b", y0, [earlier])[0].intention == -1
    assert heard.give_way("nobody", y0, [later])[0].intention == -1  # it does not signal


def test_notice_covers_the_latency_and_the_losses() -> None:
    """An automated vehicle signals this long before it starts a change: the latency and
    one step, more steps the more messages are lost (all of them missed: < 1e-3)."""
    assert notice(0.0, 0.0, DT) == pytest.approx(DT)
    assert notice(LATENCY, 0.0, DT) == pytest.approx(LATENCY + DT)
    assert notice(LATENCY, LOSS, DT) == pytest.approx(LATENCY + 6 * DT)  # 0.3^6 < 1e-3
    assert notice(LATENCY, 1.0, DT) == math.inf


def test_gap_requests_between_automated_vehicles_go_over_v2v() -> None:
    """A request naming an automated vehicle arrives the latency later (unless lost) at
    its policy's make_room, once per ROOM_DURATION per pair; one naming anyone else goes
    to SUMO's drivers (the forward port)."""
    from cosim.driving.gap.yielding import ROOM_DURATION
    from cosim.run.announcements import GapRequests

    forwarded: list[str] = []
    made: list[tuple[float, str]] = []

    class Policy:
        def make_room(self, t: float, vid: str) -> None:
            made.append((t, vid))

    requests = GapRequests(LATENCY, 0.0, np.random.default_rng(0))
    requests.policies["b"] = Policy()
    ask = requests.port("a", lambda t, vid: forwarded.append(vid) or True)
    assert ask(1.0, "tv7") and forwarded == ["tv7"]
    assert ask(1.0, "b") and ask(1.05, "b")  # the second is the same request: not sent
    for k in range(20, 24):
        requests.deliver(k * DT)
    assert made == [(pytest.approx(1.0 + LATENCY), "a")] and requests.sent == 1
    ask(1.0 + ROOM_DURATION, "b")  # once the room's time is up: asked again
    assert requests.sent == 2
    lossy = GapRequests(LATENCY, LOSS, np.random.default_rng(0))
    lossy.policies["b"] = Policy()
    for k in range(200):
        lossy.port(f"s{k}", lambda t, vid: None)(0.0, "b")
    assert 0.2 < lossy.lost / lossy.sent < 0.4
    off = GapRequests(LATENCY, 0.0, np.random.default_rng(0), enabled=False)
    off.policies["b"] = Policy()  # the perception mode: no request between them
    assert off.port("a", lambda t, vid: True)(0.0, "b") is False and off.sent == 0
