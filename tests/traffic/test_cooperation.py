"""Cooperative V2V through real SUMO (libsumo): does a TV asked to open a gap open it?
And does SUMO's follower brake for an SV entering its lane as the SV predicts it
(cosim.planning.interaction)?"""

from __future__ import annotations

import numpy as np
import pytest

from cosim.planning.interaction import FollowerModel, predict_follower
from cosim.traffic.cooperation import (
    COURTESY,
    COURTESY_DECEL,
    CooperationChannel,
    CooperationConfig,
    done_yielding,
)
from cosim.traffic.network import DEFAULT_NETWORK
from cosim.traffic.process import SumoOptions
from cosim.traffic.sumo import TV_TYPE, SumoSim

STEP = 0.05  # s
L, W = 4.32, 1.8  # m
V = 22.0  # m/s


def run_side_by_side(cfg: CooperationConfig, seconds: float = 14.0, request_at: float = 2.0,
                     changing_at: float = np.inf
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """SV (moved by us) in lane 1 at V; a SUMO-driven TV in lane 0 alongside it at V
    (no dawdling); the SV's change (for the channel) begins at `changing_at`. Returns
    t, gap (SV rear - TV front along x) and the TV's speed."""
    with SumoSim(DEFAULT_NETWORK, STEP, 1, SumoOptions(lanechange_duration=3.0)) as sim:
        road = sim.road()
        sim.api.vehicletype.setImperfection(TV_TYPE, 0.0)
        x_sv = 600.0
        sim.add_controlled("sv", x_sv, road.lane_center(1), 0.0, V, (L, W), 1)
        sim.add_traffic("tv", 0, x_sv - 2.0, 1.0, speed=V)
        sim.api.vehicle.setMaxSpeed("tv", V)
        sim.api.vehicle.setLaneChangeMode("tv", 0)
        channel = CooperationChannel(cfg, np.random.default_rng(7))
        ts, gaps, speeds = [], [], []
        t = 0.0
        while t < seconds:
            sim.step()
            t = sim.time
            if abs(t - request_at) < 1e-6:
                channel.request(t, "tv")
            present = set(sim.api.vehicle.getIDList())
            channel.changing(sim.api, "sv", t >= changing_at - 1e-9, present)
            channel.deliver(t, sim.api, "sv", present)
            x_sv += V * STEP
            sim.move("sv", x_sv, road.lane_center(1), 0.0, V)
            if "tv" in sim.api.vehicle.getIDList():
                xf = sim.api.vehicle.getPosition("tv")[0]
                ts.append(t)
                gaps.append((x_sv - 0.5 * L) - xf)
                speeds.append(sim.api.vehicle.getSpeed("tv"))
        return np.array(ts), np.array(gaps), np.array(speeds), channel.honoured


def test_a_tv_asked_to_open_a_gap_opens_it() -> None:
    cfg = CooperationConfig(enabled=True, latency=0.5, time_headway=1.5, space_headway=5.0,
                            max_decel=2.0)
    t, gap, v, honoured = run_side_by_side(cfg)
    assert honoured == 1
    # nothing before the request arrives (2.0 s + 0.5 s latency): it stays alongside
    before = t < 2.5 - 1e-9
    assert np.all(gap[before] < 0.0) and np.all(np.abs(v[before] - V) < 0.05)
    # then it falls back behind the SV, braking no harder than asked
    decel = -np.diff(v) / np.diff(t)
    assert decel.max() <= cfg.max_decel + 0.1
    assert gap[-1] >= cfg.space_headway + 0.8 * cfg.time_headway * V
    # and speeds up again behind the SV (openGap spreads the change: slowly)
    assert v[-1] > v.min() + 2.0 and v[-1] <= V + 0.05


def test_a_yielding_tv_brakes_gently_once_the_sv_changes_lanes() -> None:
    """Firmly (max_decel) while the SV waits beside the gap, at most changing_decel from
    the step the SV's change begins."""
    cfg = CooperationConfig(enabled=True, latency=0.0, max_decel=1.0, changing_decel=0.1)
    t, gap, v, honoured = run_side_by_side(cfg, seconds=8.0, changing_at=5.0)
    assert honoured == 1
    decel = -np.diff(v) / np.diff(t)
    waiting = (t[1:] > 2.0 + 1e-9) & (t[1:] < 5.0 - 1e-9)
    assert decel[waiting].max() == pytest.approx(cfg.max_decel, abs=0.02)
    after = t[1:] > 5.0 + STEP + 1e-9  # the new request acts from the next step
    assert decel[after].max() == pytest.approx(cfg.changing_decel, abs=1e-6)
    assert gap[-1] < cfg.space_headway + cfg.time_headway * v[-1]  # still making room


def test_the_courtesy_makes_room_before_the_change_and_then_only_holds_its_speed() -> None:
    """The traffic's courtesy (COURTESY): up to a comfortable 2 m/s^2 while the SV waits;
    once its change is under way the TV neither brakes for the rest of its 2 s gap
    (which, with SUMO's dawdling on top, the new follower would feel through the whole
    change) nor speeds up toward the SV."""
    t, gap, v, honoured = run_side_by_side(COURTESY, seconds=8.0, changing_at=4.0)
    assert honoured == 1
    assert COURTESY.max_decel == COURTESY_DECEL == 2.0
    decel = -np.diff(v) / np.diff(t)
    waiting = (t[1:] > 2.0 + 1e-9) & (t[1:] < 4.0 - 1e-9)
    assert decel[waiting].max() == pytest.approx(COURTESY_DECEL, abs=0.05)
    after = t[1:] > 4.0 + STEP + 1e-9
    assert decel[after].max() <= COURTESY.changing_decel + 1e-6 <= 0.01 + 1e-6
    held = v[t > 4.0 + STEP + 1e-9]
    assert held.max() - held.min() < 0.05  # holds its speed: no braking, no closing in
    assert held[0] < V - 2.0  # the room made while the SV waited is kept


@pytest.mark.parametrize("cfg", [CooperationConfig(enabled=True, compliance=0.0),
                                 CooperationConfig(enabled=False)],
                         ids=["refused", "off"])
def test_no_gap_without_a_honoured_request(cfg: CooperationConfig) -> None:
    t, gap, v, honoured = run_side_by_side(cfg, seconds=8.0)
    assert honoured == 0
    assert np.all(gap < 0.0)  # still alongside
    assert np.all(np.abs(v - V) < 0.05)


def test_sumo_follower_brakes_as_predicted_when_the_sv_cuts_in() -> None:
    # the SV moves from lane 1 into lane 0 in one step, 12 m (bumpers) ahead of a TV
    # there that drives 5 m/s faster: SUMO's Krauss follower against ours
    v_tv, v_sv = 25.0, 20.0
    with SumoSim(DEFAULT_NETWORK, STEP, 1, SumoOptions(lanechange_duration=3.0)) as sim:
        road = sim.road()
        sim.api.vehicletype.setImperfection(TV_TYPE, 0.0)
        x_tv = 600.0
        x_sv = x_tv + 0.5 * L + 12.0 + 0.5 * L
        sim.add_controlled("sv", x_sv, road.lane_center(1), 0.0, v_sv, (L, W), 1)
        sim.add_traffic("tv", 0, x_tv, 1.0, speed=v_tv)
        sim.api.vehicle.setMaxSpeed("tv", v_tv)
        sim.api.vehicle.setLaneChangeMode("tv", 0)
        sim.step()
        x_sv += v_sv * STEP
        sim.move("sv", x_sv, road.lane_center(1), 0.0, v_sv)
        sim.step()
        # now in lane 0: written this step, SUMO sees it from the next step on
        rear, speeds, front0 = [], [], None
        for k in range(120):
            x_sv += v_sv * STEP
            sim.move("sv", x_sv, road.lane_center(0), 0.0, v_sv)
            if k == 0:
                front0 = sim.api.vehicle.getPosition("tv")[0]
                v0 = sim.api.vehicle.getSpeed("tv")
            rear.append(x_sv - 0.5 * L)
            sim.step()
            speeds.append(sim.api.vehicle.getSpeed("tv"))
    assert front0 is not None
    t = np.arange(len(rear)) * STEP
    pred = predict_follower(t, np.array(rear), np.full(t.size, v_sv), 0.0, front0, v0,
                            FollowerModel())
    sumo_v = np.array(speeds)
    # SUMO's follower brakes (hard: the cut-in is well inside its secure gap)
    assert sumo_v.min() < v_sv
    sumo_decel = float(np.max(-np.diff(np.concatenate([[v0], sumo_v])) / STEP))
    assert sumo_decel > 4.0
    # our prediction follows SUMO's speeds within one step of braking (measured: 0.225
    # m/s, SUMO sees the move a step later) and gets its hardest braking (9.0 m/s^2)
    assert np.max(np.abs(pred.speed[1:] - sumo_v[:-1])) < 0.3
    assert pred.max_decel == pytest.approx(sumo_decel, rel=0.05)


def run_passing(release: bool, seconds: float = 16.0) -> tuple[np.ndarray, np.ndarray]:
    """The TV alongside is asked to yield at 1 s (courtesy: at once); from 3 s the SV
    slows to a crawl, so the TV passes it. Returns t and the TV's speed."""
    with SumoSim(DEFAULT_NETWORK, STEP, 1, SumoOptions(lanechange_duration=3.0)) as sim:
        road = sim.road()
        sim.api.vehicletype.setImperfection(TV_TYPE, 0.0)
        x_sv, v_sv = 600.0, V
        sim.add_controlled("sv", x_sv, road.lane_center(1), 0.0, V, (L, W), 1)
        sim.add_traffic("tv", 0, x_sv - 2.0, 1.0, speed=V)
        sim.api.vehicle.setMaxSpeed("tv", V)
        sim.api.vehicle.setLaneChangeMode("tv", 0)
        channel = CooperationChannel(CooperationConfig(enabled=True, latency=0.0),
                                     np.random.default_rng(7))
        ts, speeds = [], []
        t = 0.0
        while t < seconds:
            sim.step()
            t = sim.time
            if abs(t - 1.0) < 1e-6:
                channel.request(t, "tv")
            channel.deliver(t, sim.api, "sv", ("tv",))
            x_tv = sim.api.vehicle.getPosition("tv")[0] - 0.5 * L  # centre
            if release:
                channel.release(sim.api, ("tv",), np.array([x_tv > x_sv]))
            if t >= 3.0:
                v_sv = max(v_sv - 4.0 * STEP, 2.0)
            x_sv += v_sv * STEP
            sim.move("sv", x_sv, road.lane_center(1), 0.0, v_sv)
            ts.append(t)
            speeds.append(sim.api.vehicle.getSpeed("tv"))
        return np.array(ts), np.array(speeds)


def test_a_yielding_tv_that_passes_the_sv_is_released() -> None:
    """openGap keeps the SV as the TV's leader: once ahead of it, the TV would stop and
    wait for it for good (a deadlock in traffic_jam.toml); `release` ends it."""
    t, v = run_passing(release=True)
    assert v[-1] > V - 0.5  # back to its own speed, the SV far behind
    t, v_held = run_passing(release=False)
    # SUMO without it: still slowing down for the SV far behind it
    assert v_held[-1] < V - 5.0 and np.all(np.diff(v_held[t > 8.0]) <= 1e-9)


def run_beside_standing_sv(rule: str, seconds: float = 14.0) -> tuple[float, float]:
    """The SV stands (at a stop line, say); a TV 15 m behind it in the next lane at 7 m/s
    is asked to yield (courtesy, at once, 2 m/s^2): too close to stop behind the SV's rear.
    `rule` says which TVs are released: "centre" (past the SV's centre) or "level" (also
    standing level with it, `done_yielding`). Returns the TV's speed and x offset to the
    SV."""
    with SumoSim(DEFAULT_NETWORK, STEP, 1, SumoOptions(lanechange_duration=3.0)) as sim:
        road = sim.road()
        sim.api.vehicletype.setImperfection(TV_TYPE, 0.0)
        x_sv = 600.0
        sim.add_controlled("sv", x_sv, road.lane_center(1), 0.0, 0.0, (L, W), 1)
        sim.add_traffic("tv", 0, x_sv - 15.0, 1.0, speed=7.0)
        sim.api.vehicle.setMaxSpeed("tv", 7.0)
        sim.api.vehicle.setLaneChangeMode("tv", 0)
        channel = CooperationChannel(COURTESY, np.random.default_rng(7))
        channel.request(0.0, "tv")
        t = 0.0
        while t < seconds:
            sim.step()
            t = sim.time
            channel.deliver(t, sim.api, "sv", ("tv",))
            x_tv = sim.api.vehicle.getPosition("tv")[0] - 0.5 * L  # centre
            v_tv = sim.api.vehicle.getSpeed("tv")
            ahead = (done_yielding(np.array([x_tv]), np.array([L]), np.array([v_tv]), x_sv, L)
                     if rule == "level" else np.array([x_tv > x_sv]))
            channel.release(sim.api, ("tv",), ahead)
            sim.move("sv", x_sv, road.lane_center(1), 0.0, 0.0)
        return sim.api.vehicle.getSpeed("tv"), x_tv - x_sv


def test_a_yielding_tv_level_with_a_standing_sv_is_released() -> None:
    """A TV asked to yield that cannot stop behind the standing SV stops level with it
    (openGap: the SV is its leader) and stays there for good, and the SV beside it never
    finds an entry; released once it stands there, it drives on."""
    v, dx = run_beside_standing_sv("level")
    assert v > 6.5 and dx > 30.0
    v, dx = run_beside_standing_sv("centre")
    assert v < 0.1 and abs(dx) < L  # without it: standing beside the SV


def test_only_a_tv_standing_level_with_the_sv_or_ahead_of_it_is_done_yielding() -> None:
    # centres -3, -3, -10 and +1 m from the SV's (both 4.32 m long): level and standing,
    # level and still rolling (the SV may be setting off in front of it), behind, ahead
    x = np.array([-3.0, -3.0, -10.0, 1.0])
    done = done_yielding(x, np.full(4, L), np.array([0.0, 1.4, 0.0, 5.0]), 0.0, L)
    assert list(done) == [True, False, False, True]
