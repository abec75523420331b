"""Lane keeping down to a standstill and back (stop-and-go): the closed loop's and the
reference's low-speed forms. No SUMO: one closed loop on a straight lane."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.control.closed_loop import ClosedLoop, LoopConfig
from cosim.control.reference import ReferencePath
from cosim.params import ControllerGains, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.plant import PlantStart

DT = 0.05


def straight(t: float, x: float, speed: float, accel: float) -> LaneChangeTrajectory:
    """A 1 s straight reference on y = 0 from `speed` changing at `accel` (never < 0)."""
    return LaneChangeTrajectory(t0=t, tau=1.0, x0=x, y0=0.0, vx0=speed,
                                vxf=max(speed + accel, 0.0), width=0.0, ax0=accel)


def stop_and_go(plant: str, controller: str, y0: float = 0.0) -> dict[str, np.ndarray]:
    """10 m/s -> brake at 2 m/s^2 to rest -> 5 s at rest -> 1 m/s^2 back to 8 m/s."""
    loop = ClosedLoop(LoopConfig(plant, controller), VehicleParams(), ControllerGains(), 0.8,
                      PlantStart(0.0, y0, 0.0, 10.0))
    v, t = 10.0, 0.0
    rows = []
    for _ in range(420):
        a = -2.0 if t < 10.0 else (1.0 if v < 8.0 else 0.0)
        ref = straight(t, float(loop.plant.state[0]), v, a)
        r = loop.advance(t, DT, 10, ref)
        rows.append((r.t, r.x, r.y, r.vx, r.delta_f, r.dmz, v))
        v = max(v + a * DT, 0.0)
        t += DT
    cols = np.array(rows)
    return {n: cols[:, i] for i, n in enumerate(("t", "x", "y", "vx", "delta", "dmz", "vref"))}


@pytest.mark.parametrize("plant", ["twotrack", "bicycle"])
@pytest.mark.parametrize("controller", ["mimo", "siso"])
def test_stops_holds_and_drives_off(plant: str, controller: str) -> None:
    # before the low-speed form this ended with "non-finite control output ... vx = 0.001"
    r = stop_and_go(plant, controller)
    rest = (r["t"] > 6.0) & (r["t"] < 10.0)
    assert np.all(np.abs(r["vx"][rest]) < 0.05)  # stands still
    assert np.ptp(r["x"][rest]) < 0.1  # and does not creep away
    assert r["vx"].min() > -0.05  # never reverses
    assert r["vx"][-1] == pytest.approx(8.0, abs=0.2)  # drives off to the new speed
    assert np.abs(r["y"]).max() < 1e-6  # on the lane centre throughout


@pytest.mark.parametrize("plant", ["twotrack", "bicycle"])
def test_lateral_offset_is_corrected_and_held_at_rest(plant: str) -> None:
    r = stop_and_go(plant, "mimo", y0=0.2)
    assert np.all(np.isfinite(r["y"]))
    rest = (r["t"] > 6.0) & (r["t"] < 10.0)
    # corrected while still moving (overshoot about 0.08 m while braking), then held:
    # at rest nothing winds up and the car does not drift sideways
    assert np.abs(r["y"][rest]).max() < 0.1
    assert np.ptp(r["y"][rest]) < 1e-3
    assert np.ptp(r["delta"][rest]) < 1e-3
    assert np.abs(r["dmz"][rest]).max() < 1.0  # no yaw moment pivots the car at rest
    assert np.abs(r["y"][-40:]).max() < 0.05  # and driving off does not throw it sideways


def test_reference_at_rest_points_along_the_road() -> None:
    # a reference standing still, and one starting from rest at 1 m/s^2
    rest = ReferencePath(LaneChangeTrajectory(t0=0.0, tau=1.0, x0=5.0, y0=0.0, vx0=0.0,
                                              vxf=0.0, width=0.0))
    e = rest.errors(0.5, 5.2, 0.1, 0.05, 0.0, 0.0, 0.0, 0.0)
    assert all(math.isfinite(v) for v in e)
    assert e.ye == pytest.approx(0.1)
    assert e.phi_e == pytest.approx(0.05)
    assert e.vx_ref == 0.0 and e.ax_ref == 0.0 and e.kappa == 0.0
    start = ReferencePath(LaneChangeTrajectory(t0=0.0, tau=1.0, x0=0.0, y0=0.0, vx0=0.0,
                                               vxf=1.0, width=0.0, ax0=1.0))
    v, a = start.speed(0.0)
    assert v == 0.0 and a == pytest.approx(1.0)  # the feed-forward is there from rest
