"""V2V: messages, the reconstructed lane change of a SUMO TV, and the channel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.errors import InputError
from cosim.params import RoadParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.traffic.demand import populate
from cosim.traffic.network import DEFAULT_NETWORK
from cosim.traffic.process import SumoOptions
from cosim.traffic.sumo import SumoSim, TrafficSnapshot
from cosim.traffic.v2v import LateralMotion, Override, V2VChannel, lateral_motion, messages

ROAD = RoadParams()
STEP = 0.05  # s


def snapshot(t: float, x: list[float], y: list[float], **kw: list[float]) -> TrafficSnapshot:
    n = len(x)

    def col(name: str, default: float, dtype: type = float) -> np.ndarray:
        return np.array(kw.get(name, [default] * n), dtype=dtype)

    return TrafficSnapshot(
        time=t,
        ids=tuple(f"v{i}" for i in range(n)),
        x=np.array(x, dtype=float),
        y=np.array(y, dtype=float),
        heading=col("heading", 0.0),
        speed=col("speed", 25.0),
        accel=col("accel", 0.0),
        lane=np.array([ROAD.lane_of(v) for v in y]),
        lateral_speed=col("lateral_speed", 0.0),
        length=col("length", 4.32),
        width=col("width", 1.8),
        signals=col("signals", 0, int),
    )


def test_linear_motion_evaluates_sumo_style_and_quintic_matches_the_planner() -> None:
    lin = LateralMotion(t0=2.0, tau=3.0, x0=100.0, y0=1.875, vx0=20.0, vxf=20.0,
                        width=3.75, profile="linear")  # fmt: skip
    x, y = lin.position(np.array([1.0, 2.0, 3.5, 5.0, 7.0]))
    np.testing.assert_allclose(x, [80.0, 100.0, 130.0, 160.0, 200.0])
    np.testing.assert_allclose(y, [1.875, 1.875, 3.75, 5.625, 5.625])
    quint = LateralMotion(t0=1.0, tau=4.0, x0=10.0, y0=2.0, vx0=25.0, vxf=20.0, width=3.75)
    ref = LaneChangeTrajectory(t0=1.0, tau=4.0, x0=10.0, y0=2.0, vx0=25.0, vxf=20.0, width=3.75)
    t = np.linspace(1.0, 7.0, 25)
    np.testing.assert_allclose(quint.position(t), ref.position(t), atol=1e-9)
    assert quint.position(0.0)[1] == pytest.approx(2.0)


def test_lateral_motion_is_rebuilt_from_one_measurement() -> None:
    """A synthetic SUMO lane change: the front moves at W/D, the body turned by atan(vy/vx)."""
    vx, vy, length = 25.0, 3.75 / 3.0, 4.32
    h = math.atan2(vy, vx)
    for elapsed in (0.3, 1.5, 2.9):
        y_front = ROAD.lane_center(0) + vy * elapsed
        y = y_front - 0.5 * length * math.sin(h)
        m = lateral_motion(10.0, 500.0, y, h, vx, vy, length, ROAD)
        assert m is not None
        assert m.y0 == pytest.approx(ROAD.lane_center(0))
        assert m.width == pytest.approx(3.75)
        assert m.tau == pytest.approx(3.0)
        assert m.profile == "linear"
        assert m.position(10.0)[1] == pytest.approx(y, abs=1e-9)
        assert m.position(m.t0 + m.tau + 5.0)[1] == pytest.approx(ROAD.lane_center(1))
    # to the right, last step: the front is already on the target centre
    y = ROAD.lane_center(1) - 0.5 * length * math.sin(-0.05)
    m = lateral_motion(4.0, 0.0, y, -0.05, 25.0, -vy, length, ROAD)
    assert m is not None and m.y0 == pytest.approx(ROAD.lane_center(2))
    assert lateral_motion(4.0, 0.0, 5.625, 0.0, 25.0, 0.0, length, ROAD) is None


def test_sumo_lane_changes_are_continuous_and_predictable_a_second_ahead() -> None:
    """LateralMotion from V2V predicts a changing TV's centre y 1 s later within cm."""
    errors: list[float] = []
    lateral: list[float] = []
    blinker_agrees: list[bool] = []
    pending: dict[int, list[tuple[str, LateralMotion]]] = {}
    with SumoSim(DEFAULT_NETWORK, STEP, 3, SumoOptions(lanechange_duration=3.0)) as sim:
        road = sim.road()
        populate(sim, road, 16.0, 3, 2000.0)
        for k in range(int(30.0 / STEP)):
            sim.step()
            snap = sim.snapshot()
            moving = snap.select(snap.changing)
            lateral += list(np.abs(moving.lateral_speed))
            for msg in messages(moving, road):
                assert msg.motion is not None  # C3: every TV moving sideways says how
                blinker_agrees.append(msg.intention == np.sign(msg.lateral_speed))
                pending.setdefault(k + round(1.0 / STEP), []).append((msg.vehicle_id, msg.motion))
            for vid, motion in pending.pop(k, []):
                if vid in snap.ids:
                    y_pred = float(motion.position(snap.time)[1])
                    errors.append(abs(y_pred - snap.y[snap.index(vid)]))
    assert len(errors) > 200
    assert np.mean(blinker_agrees) > 0.9  # the blinker shows the direction (off in the last step)
    # continuous: constant lateral speed W / D, not a one-step jump
    np.testing.assert_allclose(lateral, 3.75 / 3.0)
    e = np.array(errors)
    assert np.median(e) < 0.01
    assert np.percentile(e, 95) < 0.05
    assert e.max() < 0.12  # SUMO straightens the body gradually at the end of a change


def test_channel_delivers_within_range_after_the_latency() -> None:
    ch = V2VChannel(ROAD, range=100.0, latency=0.2, loss=0.0, seed=1)
    got = []
    for k in range(10):
        t = k * STEP
        snap = snapshot(t, [0.0 + t, 90.0, 150.0], [1.875, 5.625, 9.375])
        got.append(ch.exchange(snap, sv_x=0.0, sv_y=1.875))
    assert got[3] == []  # 0.15 s: nothing has arrived yet
    assert [m.vehicle_id for m in got[4]] == ["v0", "v1"]  # 0.2 s; v2 is out of range
    assert got[4][0].t == pytest.approx(0.0)  # the measurement is 0.2 s old
    assert got[9][0].t == pytest.approx(0.25)  # the newest delivered one wins
    assert got[9][0].x == pytest.approx(0.25)


def test_channel_loses_messages_at_the_set_rate_reproducibly() -> None:
    def run(seed: int) -> list[int]:
        ch = V2VChannel(ROAD, range=1000.0, loss=0.3, seed=seed, max_age=0.0)
        counts = []
        for k in range(400):
            snap = snapshot(k * STEP, list(np.arange(20.0) * 10.0), [5.625] * 20)
            counts.append(len(ch.exchange(snap, 0.0, 5.625)))
        assert ch.sent == 8000
        assert ch.lost / ch.sent == pytest.approx(0.3, abs=0.02)
        return counts

    a = run(5)
    assert a == run(5)
    assert a != run(6)
    assert np.mean(a) == pytest.approx(14.0, abs=0.5)


def test_stale_messages_expire() -> None:
    ch = V2VChannel(ROAD, range=50.0, max_age=0.5)
    ch.exchange(snapshot(0.0, [10.0], [5.625]), 0.0, 5.625)
    assert len(ch.exchange(snapshot(0.4, [80.0], [5.625]), 0.0, 5.625)) == 1  # left range
    assert ch.exchange(snapshot(0.6, [80.0], [5.625]), 0.0, 5.625) == []


def test_perception_mode_measures_state_with_noise_and_nothing_else() -> None:
    vy = 1.25
    snap = snapshot(1.0, [20.0] * 2000, [3.0] * 2000, lateral_speed=[vy] * 2000,
                    signals=[2] * 2000)  # fmt: skip
    v2v = V2VChannel(ROAD, mode="v2v").exchange(snap, 0.0, 3.0)
    assert all(m.intention == 1 and m.motion is not None for m in v2v)
    seen = V2VChannel(ROAD, mode="perception", seed=2).exchange(snap, 0.0, 3.0)
    assert all(m.intention == 0 and m.motion is None for m in seen)
    x = np.array([m.x for m in seen])
    speed = np.array([m.speed for m in seen])
    assert np.std(x) == pytest.approx(0.2, rel=0.1)
    assert np.mean(x) == pytest.approx(20.0, abs=0.03)
    assert np.std(speed) == pytest.approx(0.2, rel=0.1)


def test_scripted_vehicles_announce_their_own_plan() -> None:
    plan = LateralMotion(t0=0.5, tau=4.0, x0=0.0, y0=1.875, vx0=25.0, vxf=25.0, width=3.75)
    snap = snapshot(1.0, [10.0, 20.0, 30.0], [2.0, 5.625, 9.375], lateral_speed=[0.5, 0.0, 0.0],
                    signals=[0, 0, 2])  # fmt: skip
    ch = V2VChannel(ROAD)
    got = {m.vehicle_id: m
           for m in ch.exchange(snap, 0.0, 5.0, {"v0": Override(1, plan), "v2": Override(0, None)})}
    assert got["v0"].motion is plan and got["v0"].intention == 1  # "reference"
    assert got["v2"].motion is None and got["v2"].intention == 0  # "none": blinker not told
    assert got["v1"].motion is None and got["v1"].intention == 0
    seen = V2VChannel(ROAD, mode="perception").exchange(snap, 0.0, 5.0, {"v0": Override(1, plan)})
    assert all(m.motion is None and m.intention == 0 for m in seen)


def test_messages_built_once_for_receivers_of_one_snapshot() -> None:
    """A fleet's AVs hear rows of one snapshot: a vehicle's message is built once and
    handed to each (the message each would build), not where its measurement differs
    or it announces its own plan."""
    snap = snapshot(1.0, [10.0, 20.0, 30.0], [2.0, 5.625, 9.375],
                    lateral_speed=[0.5, 0.0, 0.0], signals=[0, 0, 2])
    plan = LateralMotion(t0=0.5, tau=4.0, x0=0.0, y0=1.875, vx0=25.0, vxf=25.0, width=3.75)
    shared: dict = {}
    first = messages(snap.select(np.array([True, True, False])), ROAD, None, shared)
    again = messages(snap, ROAD, {"v1": Override(1, plan)}, shared)
    assert again == messages(snap, ROAD, {"v1": Override(1, plan)})
    assert again[0] is first[0] and again[0].motion is not None  # built once
    assert again[1] is not first[1] and again[1].motion is plan  # its own plan
    moved = snapshot(1.0, [10.5, 20.0, 30.0], [2.0, 5.625, 9.375],
                     lateral_speed=[0.5, 0.0, 0.0], signals=[0, 0, 2])
    assert messages(moved, ROAD, None, shared)[0].x == 10.5


def test_bad_channel_settings_are_input_errors() -> None:
    with pytest.raises(InputError, match="loss"):
        V2VChannel(ROAD, loss=1.5)
    with pytest.raises(InputError, match="mode"):
        V2VChannel(ROAD, mode="radio")
    with pytest.raises(InputError, match="latency"):
        V2VChannel(ROAD, latency=-0.1)
