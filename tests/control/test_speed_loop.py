"""Eq. 28's speed loop against the two-track car's wheel spin mode: no limit
cycle at any speed, down to a standstill and back, and the paper's gain where the
paper's cases drive. No SUMO: one closed loop on a straight lane."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.control.closed_loop import ClosedLoop, LoopConfig
from cosim.control.longitudinal import TYRE_LAG_FACTOR, speed_gain, speed_gain_inverse_lag
from cosim.params import ControllerGains, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.plant import PlantStart

DT = 0.05
GAINS = ControllerGains()
SIGMA = 0.06  # m, the default tyre's longitudinal relaxation length


def leader_speed(t: float) -> tuple[float, float]:
    """(m/s, m/s^2) of a leader: 30 m/s for 2 s, brakes at 2 m/s^2 to rest, stands until
    20 s, drives off at 1.5 m/s^2 back to 30 m/s."""
    if t < 2.0:
        return 30.0, 0.0
    if t < 17.0:
        return 30.0 - 2.0 * (t - 2.0), -2.0
    if t < 20.0:
        return 0.0, 0.0
    v = 1.5 * (t - 20.0)
    return (v, 1.5) if v < 30.0 else (30.0, 0.0)


def follow(plant: str, *, low_speed_gain: bool = True, duration: float = 42.0
           ) -> dict[str, np.ndarray]:
    """The SV tracks the leader's speed profile (the reference a car-follower at a fixed
    time offset would hand it), sampled every 0.05 s as the co-simulation records it."""
    loop = ClosedLoop(LoopConfig(plant, "mimo", low_speed_gain=low_speed_gain), VehicleParams(),
                      GAINS, 0.8, PlantStart(0.0, 0.0, 0.0, 30.0))
    rows = []
    t = 0.0
    for _ in range(int(round(duration / DT))):
        v, a = leader_speed(t)
        ref = LaneChangeTrajectory(t0=t, tau=1.0, x0=float(loop.plant.state[0]), y0=0.0,
                                   vx0=v, vxf=max(v + a, 0.0), width=0.0, ax0=a)
        r = loop.advance(t, DT, 10, ref)
        rows.append((r.t, r.vx, r.ax, a))
        t += DT
    cols = np.array(rows)
    return {n: cols[:, i] for i, n in enumerate(("t", "vx", "ax", "a_ref"))}


def sign_flips(a: np.ndarray, a_ref: np.ndarray, floor: float = 0.3) -> int:
    """Changes of sign between consecutive samples that both exceed `floor` (m/s^2),
    except within 0.5 s after the leader changes its own acceleration (a transient its
    motion explains: at 30 m/s the paper's kx1 rings for ~0.3 s after such a step)."""
    big = np.abs(a) > floor
    s = np.sign(a)
    flips = (s[1:] * s[:-1] < 0) & big[1:] & big[:-1]
    settled = np.ones(a.size, dtype=bool)
    for i in np.flatnonzero(np.diff(a_ref) != 0.0):
        settled[i + 1:i + 1 + int(round(0.5 / DT))] = False
    return int(np.sum(flips & settled[1:]))


@pytest.mark.parametrize("plant", ["twotrack", "bicycle"])
def test_following_a_leader_to_rest_and_back_has_no_chatter(plant: str) -> None:
    r = follow(plant)
    # the leader's own motion: brake, stand, drive off (no sign change between big samples)
    assert sign_flips(r["ax"], r["a_ref"]) == 0
    jumps = np.abs(np.diff(r["ax"]))
    # the leader changes its acceleration by at most 2 m/s^2 in one step; where the
    # low-speed form acts (below 21.6 m/s) the SV follows that, at 30 m/s the paper's
    # kx1 overshoots a 1.5 m/s^2 step by up to 2 m/s^2 (before the low-speed form: 7 m/s^2
    # every step below ~20 m/s, 300 m/s^3)
    low = r["vx"][1:] < 20.0
    assert jumps[low].max() < 2.5
    assert jumps.max() < 5.0
    # it stops (below 0.05 m/s) and drives back up to 30 m/s
    assert r["vx"].min() < 0.05
    assert r["vx"][-1] == pytest.approx(30.0, abs=0.1)


def test_the_paper_gain_as_printed_limit_cycles_at_low_speed() -> None:
    """The failure the low-speed form removes: eq. 28 with kx1 = 200 /s at every speed
    flips the two-track car's wheel force every step below ~20 m/s."""
    r = follow("twotrack", low_speed_gain=False, duration=17.0)
    low = (r["vx"][1:] < 16.0) & (r["vx"][1:] > 2.0)
    assert low.sum() > 100
    assert np.mean(np.abs(np.diff(r["ax"]))[low] > 5.0) > 0.3


def test_speed_gain_is_the_paper_gain_where_the_paper_cases_drive() -> None:
    slope = speed_gain_inverse_lag(SIGMA)
    assert slope == pytest.approx(1.0 / (TYRE_LAG_FACTOR * SIGMA))
    for v in (21.7, 22.2, 25.0, 30.6, 40.0):  # paper cases 5.1-5.3: 22.2-30.6 m/s
        assert speed_gain(GAINS.kx1, v, slope) == GAINS.kx1
    assert speed_gain(GAINS.kx1, 10.0, slope) == pytest.approx(10.0 * slope)
    assert speed_gain(GAINS.kx1, 0.0, slope) == pytest.approx(10.0)  # KX1_FLOOR
    assert speed_gain(GAINS.kx1, 10.0, 0.0) == GAINS.kx1  # off: the law as printed
    gains = [speed_gain(GAINS.kx1, v, slope) for v in np.linspace(0.0, 30.0, 61)]
    assert np.all(np.diff(gains) >= 0.0)  # never rises as the car slows
