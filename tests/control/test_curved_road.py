"""The controller on a curved road: the reference is given in the road frame (s, d),
the plant stays Cartesian (cosim.control.reference.frame_path_errors)."""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.control.closed_loop import ClosedLoop, LoopConfig
from cosim.control.cornering import (
    CAP,
    F_PREVIEW,
    cornering_params,
    curve_feed_forward,
    steady_cornering,
)
from cosim.control.grip import GRIP_USE, grip_moment_range
from cosim.control.reference import ReferencePath, frame_path_errors
from cosim.driving.following import lane_keeping_reference
from cosim.params import ControllerGains, G, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.road.frame import StraightFrame
from cosim.road.road import Road, load_road
from cosim.traffic.network import NETWORK_DIR
from cosim.vehicle.chassis import chassis_for
from cosim.vehicle.plant import PlantStart

sys.path.insert(0, str(Path(__file__).parent))
from arcs import arc_frame  # noqa: E402

V = 30.0  # m/s


@functools.cache
def curved() -> Road:
    return load_road(NETWORK_DIR / "curved_motorway.net.xml", ("e1", "e2", "e3", "e4"))


def drive(frame: object, plant: str, s0: float, d0: float, seconds: float,
          change_at: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, ClosedLoop]:
    """Lane keeping at V from (s0, d0), a lane change left at `change_at`: (ye, phi_e, d)."""
    x, y, theta = frame.to_cartesian(s0, d0)
    loop = ClosedLoop(LoopConfig(plant, "mimo"), VehicleParams(), ControllerGains(), 0.6,
                      PlantStart(float(x), float(y), float(theta), V), frame=frame)
    ref = lane_keeping_reference(0.0, s0, d0, V, 0.0)
    dt, out = 0.05, []
    for k in range(int(seconds / dt)):
        t = k * dt
        if k == int(change_at / dt):
            s, d, _ = loop.road_pose
            ref = LaneChangeTrajectory(t0=t, tau=4.0, x0=s, y0=d, vx0=V, vxf=V, width=3.75)
        r = loop.advance(t, dt, 10, ref)
        out.append((r.ye, r.phi_e, loop.road_pose[1]))
    a = np.array(out)
    return a[:, 0], a[:, 1], a[:, 2], loop


@pytest.mark.parametrize("plant", ["twotrack", "bicycle"])
def test_lane_keeping_and_a_lane_change_through_the_curves(plant: str) -> None:
    """Through the curved motorway's bends (R down to ~740 m) and a brisk lane change
    (tau 4 s at 30 m/s) outward on its S-bend, the car keeps within 6 mm of its path
    (measured: 4.1 mm two-track, 0.2 mm bicycle; the same change on the straight road:
    3.4 mm two-track; 15 mm before the yaw moment was held within the wheels' friction
    on curves, `grip`), ends at the target lane's centre, and its Cartesian pose agrees
    with the road pose it reports."""
    road = curved()
    ye, phi, d, loop = drive(road.frame, plant, 100.0, 5.625, 80.0, 45.0)
    assert np.abs(ye).max() < 0.006
    assert np.degrees(np.abs(phi)).max() < 0.6
    assert abs(d[-1] - 9.375) < 0.01
    s, dd, rel = loop.road_pose
    x, y, theta = road.frame.to_cartesian(s, dd)
    state = loop.plant.state
    assert math.hypot(float(x) - state[0], float(y) - state[1]) < 1e-6
    assert abs(float(theta) + rel - state[2]) < 1e-9


def test_the_straight_frame_gives_the_cartesian_errors_bit_for_bit() -> None:
    """On the straight road at the origin the frame's errors are path_errors' exactly."""
    ref = LaneChangeTrajectory(t0=1.0, tau=3.0, x0=20.0, y0=1.875, vx0=25.0, vxf=27.0,
                               width=3.75)
    path = ReferencePath(ref)
    fp, fr = StraightFrame(0.0, 0.0, 1000.0).packed()
    rng = np.random.default_rng(5)
    for _ in range(50):
        args = (float(rng.uniform(0.5, 5.0)), float(rng.uniform(0.0, 200.0)),
                float(rng.uniform(0.0, 7.0)), float(rng.uniform(-0.1, 0.1)), 25.0,
                float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.05, 0.05)))
        e = path.errors(*args, 2.0)
        f = frame_path_errors(path.coef, fp, fr, *args, 2.0, math.nan)
        assert tuple(e) == f[:11]


def test_the_two_track_car_holds_a_steady_curve_with_its_integrators_nearly_empty() -> None:
    """R 800 m at 31 m/s (1.2 m/s^2): the two-track car's tyres give less than eq. 21's
    linear model says (Magic Formula, load transfer, combined slip); the cornering
    feed-forward gives them the difference, so the law's integrators hold almost nothing
    at steady state (without it kyI int(ye) held 0.085 m/s^2; measured 3e-4) and the
    curve's entry (a curvature step) moves the car by at most 1.5 mm (without it 4.3 mm;
    with the feed-forward at the car instead of a relaxation length ahead 2.0 mm;
    measured 0.9 mm)."""
    frame = arc_frame(800.0, 800.0)
    s0, d0 = 100.0, 5.625
    x, y, theta = frame.to_cartesian(s0, d0)
    loop = ClosedLoop(LoopConfig("twotrack", "mimo"), VehicleParams(), ControllerGains(), 0.6,
                      PlantStart(float(x), float(y), float(theta), V + 1.0), frame=frame)
    dt, ye, s = 0.05, [], s0
    while s < 1000.0:  # 700 m into the arc
        t = len(ye) * dt
        r = loop.advance(t, dt, 10, lane_keeping_reference(t, s, d0, V + 1.0, 0.0))
        s = loop.road_pose[0]
        ye.append(r.ye)
    gains = ControllerGains()
    assert np.abs(ye).max() < 0.0015
    assert abs(ye[-1]) < 1e-4
    assert abs(gains.kyI * loop._int_ye) < 0.002
    assert abs(gains.kphiI * loop._int_phi) < 0.02


def test_the_feed_forward_is_what_the_plant_needs_on_a_steady_curve() -> None:
    """Against an independent steady state, the plant's own: the closed loop settled on
    a long R 800 m arc at 31 m/s (integrators and errors still), the steering it applies
    less eq. 21's steady-state steering is what the tyres need beyond the linear model.
    The feed-forward gives that within 1 % (0.24 %; with the load moved by Fa, drag
    included, and no combined slip it would be 6.8 % off), and more than the linear
    model (a left curve: more steering)."""
    vehicle = VehicleParams()
    frame = arc_frame(800.0, 1600.0)
    s0, d0 = 100.0, 5.625
    x, y, theta = frame.to_cartesian(s0, d0)
    loop = ClosedLoop(LoopConfig("twotrack", "mimo"), vehicle, ControllerGains(), 0.6,
                      PlantStart(float(x), float(y), float(theta), V + 1.0), frame=frame)
    dt, s, t = 0.05, s0, 0.0
    while s < 1800.0:  # 1400 m into the arc: settled
        r = loop.advance(t, dt, 10, lane_keeping_reference(t, s, d0, V + 1.0, 0.0))
        s, t = loop.road_pose[0], t + dt
    k = 1.0 / (800.0 - (d0 - 1.875))  # the lane's curvature (3.75 m inside the line)
    m, lf, lr, cf, cr = vehicle.mass, vehicle.lf, vehicle.lr, vehicle.cf, vehicle.cr
    vx = r.vx
    linear = (m * vx * vx + lf * cf - lr * cr) * k / cf  # -B^-1 A0's steering (eq. 21)
    needed = r.delta_f - linear
    f = cornering_params(vehicle, chassis_for(vehicle), 0.6, True)
    fa = vehicle.drag * vx * vx  # a steady speed: Fa holds the air's drag
    d_delta, _ = curve_feed_forward(f, vx, k, k, 0.0, fa)
    assert 0.5e-3 < needed < 1.0e-3
    assert d_delta == pytest.approx(needed, rel=0.01)


def test_the_curve_is_fed_forward_a_relaxation_length_ahead() -> None:
    """The tyres' lateral force lags their slip by the relaxation length (0.5 m): out of
    an R 800 m arc at 31 m/s (a curvature step) the car leaves its lane's centre by
    under 0.7 mm with the road's curvature taken that far ahead (measured 0.41 mm),
    by more than 1 mm with it taken at the car (measured 1.31 mm)."""
    out = []
    for preview in (True, False):
        frame = arc_frame(800.0, 800.0)
        s0, d0 = 600.0, 5.625
        x, y, theta = frame.to_cartesian(s0, d0)
        k = 1.0 / (800.0 - (d0 - 1.875))
        loop = ClosedLoop(LoopConfig("twotrack", "mimo"), VehicleParams(), ControllerGains(), 0.6,
                          PlantStart(float(x), float(y), float(theta), V + 1.0,
                                     yaw_rate=(V + 1.0) * k), frame=frame)
        if not preview:
            loop._ff[F_PREVIEW] = 0.0
        dt, ye, s = 0.05, [], s0
        while s < 1500.0:
            t = len(ye) * dt
            r = loop.advance(t, dt, 10, lane_keeping_reference(t, s, d0, V + 1.0, 0.0))
            s = loop.road_pose[0]
            if s > 1100.0:  # past the arc's end
                ye.append(r.ye)
        out.append(np.abs(ye).max())
    assert out[0] < 0.0007 < 0.001 < out[1]


def test_the_cornering_feed_forward_is_zero_on_a_straight_road_and_for_linear_tyres() -> None:
    """The paper's law is unchanged where the road is straight (k_road = 0) and for the
    bicycle plant, whose tyres are eq. 21's; on a curve it is odd in the curvature and
    held at CAP of the linear front slip near the tyres' peak."""
    vehicle = VehicleParams()
    on = cornering_params(vehicle, chassis_for(vehicle), 0.6, True)
    off = cornering_params(vehicle, chassis_for(vehicle), 0.6, False)
    assert curve_feed_forward(on, 31.0, 1.5e-3, 0.0, 0.3, 400.0) == (0.0, 0.0)
    assert curve_feed_forward(off, 31.0, 1.5e-3, 1e-3, 0.3, 400.0) == (0.0, 0.0)
    left = steady_cornering(on, 31.0, 1.25e-3, 0.0, 350.0)
    right = steady_cornering(on, 31.0, -1.25e-3, 0.0, 350.0)
    assert left[0] > 0.0 and left == pytest.approx((-right[0], -right[1]))
    # R 800 m at 31 m/s: ~7 % more front slip than the linear model's 9.5 mrad
    assert 0.5e-3 < left[0] < 1.0e-3
    # 2.9 m/s^2 (no steady state with zero sideslip on mu 0.6): held at the cap
    m, lr, cf, cr = vehicle.mass, vehicle.lr, vehicle.cf, vehicle.cr
    k = 3e-3
    alpha_lin = (m * 31.0**2 * k - cr * lr * k) / cf
    assert steady_cornering(on, 31.0, k, 0.0, 350.0)[0] == pytest.approx(CAP * alpha_lin)


def test_on_a_straight_road_the_curve_terms_change_nothing_bit_for_bit() -> None:
    """Where the road is straight (StraightFrame) the relaxation-length preview and the
    cornering feed-forward are never taken: a lane change on the two-track car gives the
    same records, bit for bit, with them (the default) and with both switched off."""
    out = []
    for on in (True, False):
        loop = ClosedLoop(LoopConfig("twotrack", "mimo"), VehicleParams(), ControllerGains(), 0.6,
                          PlantStart(0.0, 5.625, 0.0, V))
        if not on:
            loop._ff[:] = 0.0
        ref = LaneChangeTrajectory(t0=1.0, tau=4.0, x0=V, y0=5.625, vx0=V, vxf=V,
                                   width=3.75)
        out.append([loop.advance(k * 0.05, 0.05, 10, ref) for k in range(160)])
    assert out[0] == out[1]


def test_the_yaw_moment_on_a_curve_is_held_within_the_wheels_friction() -> None:
    """`grip`: driving straight on, every wheel may give GRIP_USE of its friction to the
    yaw moment, its differential force dMz / (4 ls) and the lateral force that balances
    the moment, dMz / (2 L) (the lighter front wheels bound it); on R 400 m at 28 m/s
    (2 m/s^2) the moment that holds the lane with zero sideslip fits, while at the
    3.5 m/s^2 of a lane change to the inner lane it would overload a wheel; where the path
    asks more than GRIP_USE of some wheel whatever the moment, the range is the moment
    that loads the worst wheel least (one point, within the bisection's tolerance)."""
    vehicle = VehicleParams()
    f = cornering_params(vehicle, chassis_for(vehicle), 0.8, True)
    lo, hi = grip_moment_range(f, 0.0, 0.0, 0.0, GRIP_USE)
    fz_front = vehicle.mass * G * vehicle.lr / (2.0 * vehicle.wheelbase)
    limit = GRIP_USE * 0.8 * fz_front / math.hypot(1.0 / (4.0 * vehicle.half_track),
                                                   1.0 / (2.0 * vehicle.wheelbase))
    assert (lo, hi) == pytest.approx((-limit, limit), rel=1e-3)
    vx = 28.0
    fa = vehicle.drag * vx * vx

    def hold(kappa: float) -> float:  # zero sideslip: kappa (L lr Cr - lf M vx^2)
        return kappa * (vehicle.wheelbase * vehicle.lr * vehicle.cr
                        - vehicle.lf * vehicle.mass * vx * vx)

    lo, hi = grip_moment_range(f, vx * vx / 400.0, 0.0, fa, GRIP_USE)
    assert lo < hold(1 / 400.0) < 0.0 < hi
    lo, hi = grip_moment_range(f, vx * vx * 0.0045, 0.0, fa, GRIP_USE)
    assert hold(0.0045) < lo < 0.0 < hi
    lo, hi = grip_moment_range(f, 7.0, 0.0, fa, GRIP_USE)
    assert lo <= hi and hi - lo < 50.0
