"""Tests of cosim.control.reference: scalar evaluation agrees with
LaneChangeTrajectory, projection finds the closest point, error signs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.control.reference import ReferencePath, wrap_angle
from cosim.planning.trajectory import LaneChangeTrajectory

TRAJ = LaneChangeTrajectory(
    t0=2.0, tau=5.0, x0=100.0, y0=1.875, vx0=22.0, vxf=25.0, width=3.75,
    ax0=0.3, vy0=0.1, ay0=0.05,
)


def test_point_speed_and_curvature_match_the_trajectory_class() -> None:
    path = ReferencePath(TRAJ)
    for t in np.linspace(2.0, 10.0, 33):
        x, y, dx, dy, ddx, ddy = path.point(float(t))
        px, py = TRAJ.position(t)
        assert (x, y) == pytest.approx((float(px), float(py)), abs=1e-9)
        v, a = path.speed(float(t))
        assert v == pytest.approx(float(TRAJ.speed(t)), rel=1e-12)
        assert a == pytest.approx(float(TRAJ.acceleration(t)), abs=1e-12)
        kappa = (dx * ddy - dy * ddx) / (dx * dx + dy * dy) ** 1.5
        assert kappa == pytest.approx(float(TRAJ.curvature(t)), abs=1e-12)


def test_before_t0_the_path_extends_straight_back() -> None:
    path = ReferencePath(TRAJ)
    x, y, dx, dy, _, _ = path.point(1.0)
    assert (x, y) == pytest.approx((100.0 - 22.0, 1.875 - 0.1))
    assert (dx, dy) == pytest.approx((22.0, 0.1))


def test_projection_is_the_closest_point() -> None:
    path = ReferencePath(TRAJ)
    ts = np.linspace(0.0, 12.0, 240001)
    pts = np.array([path.point(float(t))[:2] for t in ts[::100]])
    dense_t = ts[::100]
    for qx, qy, guess in [(150.0, 4.0, 3.0), (180.0, 3.0, 6.0), (120.0, 0.5, 2.0)]:
        s, _ = path.project(qx, qy, guess)
        k = int(np.argmin(np.hypot(pts[:, 0] - qx, pts[:, 1] - qy)))
        assert s == pytest.approx(dense_t[k], abs=0.006)
        best = math.hypot(*(np.array(path.point(s)[:2]) - (qx, qy)))
        assert best <= np.hypot(pts[:, 0] - qx, pts[:, 1] - qy).min() + 1e-9


def test_error_signs_left_is_positive_heading_ccw_is_positive() -> None:
    straight = ReferencePath(
        LaneChangeTrajectory(t0=0.0, tau=4.0, x0=0.0, y0=0.0, vx0=20.0, vxf=20.0, width=0.0)
    )
    e = straight.errors(1.0, 21.0, 0.3, 0.02, 20.0, 0.0, 0.0, 1.0)
    assert e.ye == pytest.approx(0.3)
    assert e.phi_e == pytest.approx(0.02)
    assert e.ye_dot == pytest.approx(20.0 * math.sin(0.02))
    assert e.along == pytest.approx(1.0)
    assert e.kappa == 0.0
    assert e.vx_ref == pytest.approx(20.0)


def test_wrap_angle() -> None:
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(-0.1) == pytest.approx(-0.1)


def test_float_coefficients_are_numpys_bit_for_bit() -> None:
    """The reference's float coefficients (`_longitudinal`, `_lateral`: lane keeping
    rebuilds them every step) equal the trajectory's numpy ones exactly, not nearly: a
    last-bit difference would change every run's trace."""
    from cosim.control.reference import _lateral, _longitudinal
    from cosim.planning.trajectory import lateral_coefficients, longitudinal_coefficients

    rng = np.random.default_rng(7)
    for i in range(3000):
        tau = float(rng.choice([rng.uniform(0.5, 12.0), 2.0, 3.0]))
        vx0, vxf = (float(v) for v in rng.uniform(0.0, 40.0, 2))
        ax0 = float(rng.uniform(-5.0, 3.0)) if i % 3 else 0.0
        width = float(rng.choice([0.0, 3.75, rng.uniform(-4.0, 4.0)]))
        vy0 = float(rng.uniform(-1.0, 1.0)) if i % 2 else 0.0
        ay0 = float(rng.uniform(-2.0, 2.0)) if i % 5 else 0.0
        ours = _longitudinal.__wrapped__(vx0, vxf, tau, ax0)
        assert ours == tuple(float(c) for c in longitudinal_coefficients(vx0, vxf, tau, ax0))
        ours_y = _lateral.__wrapped__(width, tau, vy0, ay0)
        assert ours_y == tuple(float(c) for c in lateral_coefficients(width, tau, vy0, ay0))
