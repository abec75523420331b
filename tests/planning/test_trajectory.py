"""Min-jerk cluster (eq. 2, 4, 12, 14, 15): boundary conditions and jerk costs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from cosim.planning.trajectory import (
    BoundaryConditions,
    LaneChangeTrajectory,
    cluster,
    cluster_derivatives,
    jerk_costs,
)

RNG = np.random.default_rng(20200814)
CASES = [
    (RNG.uniform(15, 35), RNG.uniform(15, 35), RNG.choice([-1, 1]) * RNG.uniform(2.5, 4.5),
     RNG.uniform(1.0, 10.0))
    for _ in range(25)
]


@pytest.mark.parametrize(("vx0", "vxf", "W", "tau"), CASES)
def test_boundary_conditions_to_1e9(vx0: float, vxf: float, W: float, tau: float) -> None:
    ends = np.array([0.0, tau])
    d = cluster_derivatives(BoundaryConditions(vx0, vxf, W), [tau], ends, (0, 1, 2))
    (x, y), (xd, yd), (xdd, ydd) = d[0], d[1], d[2]
    # values at tau are evaluated just inside the manoeuvre (after it the motion is straight)
    inside = cluster_derivatives(BoundaryConditions(vx0, vxf, W), [tau], [tau * (1 - 1e-15)],
                                 (1, 2))
    np.testing.assert_allclose([x[0, 0], y[0, 0], yd[0, 0], ydd[0, 0], xdd[0, 0]], 0.0, atol=1e-9)
    assert xd[0, 0] == pytest.approx(vx0, abs=1e-9)
    assert y[0, 1] == pytest.approx(W, abs=1e-9)
    assert inside[1][0][0, 0] == pytest.approx(vxf, abs=1e-9)
    np.testing.assert_allclose([inside[1][1][0, 0], inside[2][0][0, 0], inside[2][1][0, 0]],
                               0.0, atol=1e-9)
    # eq. 2 and eq. 4 as printed
    t = np.linspace(0, tau, 7)
    xs, ys = cluster(BoundaryConditions(vx0, vxf, W), [tau], t)
    eq2 = (vx0 - vxf) / (2 * tau**3) * t**4 - (vx0 - vxf) / tau**2 * t**3 + vx0 * t
    s = t / tau
    eq4 = W * (6 * s**5 - 15 * s**4 + 10 * s**3)
    np.testing.assert_allclose(xs[0], eq2, atol=1e-9)
    np.testing.assert_allclose(ys[0], eq4, atol=1e-9)


def test_compiled_grid_matches_numpy_bit_for_bit() -> None:
    """A 2-D grid (the planner's and the prediction's) is evaluated by the compiled pass,
    any other shape by numpy's Horner sums: the same numbers to the last bit, past tau
    too (general start, per-candidate starts, every derivative order)."""
    rng = np.random.default_rng(7)
    taus = rng.uniform(1.0, 8.0, 9)
    t = rng.uniform(-1.0, 12.0, 31)
    v0, vy0 = rng.uniform(15.0, 30.0, (9, 1)), rng.uniform(-1.0, 1.0, (9, 1))

    def starts(per: tuple[int, ...]) -> list[BoundaryConditions]:
        return [BoundaryConditions(22.0, 27.0, -3.7, ax0=0.4, vy0=0.6, ay0=-0.3),
                BoundaryConditions(v0.reshape(per), v0[::-1].reshape(per) + 1.0, 3.75,
                                   vy0=vy0.reshape(per))]

    for bc, bc3 in zip(starts((9, 1)), starts((9, 1, 1)), strict=True):
        orders = (0, 1, 2, 3, 5)
        grid = cluster_derivatives(bc, taus, t, orders)  # (9, 31): compiled
        other = cluster_derivatives(bc3, taus[:, None, None], t[None, None, :], orders)  # 3-D
        for k in orders:
            for a, b in zip(grid[k], other[k], strict=True):
                assert a.tobytes() == b.reshape(a.shape).tobytes()


def test_trajectory_reads_its_cluster_bit_for_bit() -> None:
    """LaneChangeTrajectory keeps its coefficients: every read (any shape of t, before,
    during and after the change, read again) is `cluster` of its one duration."""
    tr = LaneChangeTrajectory(t0=3.0, tau=4.2, x0=100.0, y0=1.2, vx0=24.0, vxf=27.5,
                              width=3.1, ax0=0.3, vy0=0.2, ay0=-0.1)
    t = np.linspace(1.0, 10.0, 37).reshape(1, 37)
    for order in (0, 1, 2, 3):
        want = cluster(tr.boundary, [tr.tau], t.ravel() - tr.t0, order=order)
        if order == 0:  # positions: placed at the start
            want = (want[0] + tr.x0, want[1] + tr.y0)
        for _ in range(2):
            got = tr.derivative(t, order)
            for a, b in zip(got, want, strict=True):
                assert a.shape == t.shape and a.tobytes() == b.reshape(t.shape).tobytes()
        one = cluster(tr.boundary, [tr.tau], [2.0], order=order)[1][0, 0]
        assert tr.derivative(5.0, order)[1] == (one + tr.y0 if order == 0 else one)


def test_general_start_conditions() -> None:
    """A plan started mid-manoeuvre keeps the given y', y'', x'' at 0 and ends at rest."""
    tau, W = 4.0, 2.1
    d = cluster_derivatives(BoundaryConditions(25.0, 27.0, W, ax0=0.4, vy0=0.6, ay0=-0.3), [tau],
                            [0.0], (1, 2))
    assert d[1][1][0, 0] == pytest.approx(0.6)
    assert d[2][1][0, 0] == pytest.approx(-0.3)
    assert d[2][0][0, 0] == pytest.approx(0.4)
    end = cluster_derivatives(BoundaryConditions(25.0, 27.0, W, ax0=0.4, vy0=0.6, ay0=-0.3), [tau],
                              [tau * (1 - 1e-15)], (0, 1, 2))
    assert end[0][1][0, 0] == pytest.approx(W, abs=1e-9)
    assert end[1][0][0, 0] == pytest.approx(27.0, abs=1e-9)
    assert abs(end[1][1][0, 0]) < 1e-9 and abs(end[2][1][0, 0]) < 1e-9


@pytest.mark.parametrize(("vx0", "vxf", "W", "tau"), CASES[:6])
def test_jerk_costs_match_quadrature(vx0: float, vxf: float, W: float, tau: float) -> None:
    jx_closed, jy_closed = jerk_costs(vx0, vxf, W, tau)

    def jerk(t: float) -> tuple[float, float]:
        d = cluster_derivatives(BoundaryConditions(vx0, vxf, W), [tau], [t], (3,))[3]
        return float(d[0][0, 0]), float(d[1][0, 0])

    jx = quad(lambda t: 0.5 * jerk(t)[0] ** 2, 0, tau, epsabs=1e-12, epsrel=1e-10)[0]
    jy = quad(lambda t: 0.5 * jerk(t)[1] ** 2, 0, tau, epsabs=1e-12, epsrel=1e-10)[0]
    assert jx == pytest.approx(float(jx_closed), rel=1e-7, abs=1e-12)
    assert jy == pytest.approx(float(jy_closed), rel=1e-7)


def test_reference_speed_and_curvature() -> None:
    """eq. 14-15 against finite differences of the global path."""
    tr = LaneChangeTrajectory(t0=3.0, tau=5.0, x0=100.0, y0=1.875, vx0=22.0, vxf=25.0, width=3.75)
    t = np.linspace(3.2, 7.8, 9)
    h = 1e-5
    x1, y1 = tr.position(t + h)
    x0, y0 = tr.position(t - h)
    speed = np.hypot(x1 - x0, y1 - y0) / (2 * h)
    np.testing.assert_allclose(tr.speed(t), speed, rtol=1e-6)
    heading_rate = (tr.heading(t + h) - tr.heading(t - h)) / (2 * h)
    np.testing.assert_allclose(tr.curvature(t), heading_rate / tr.speed(t), atol=1e-7)


@pytest.mark.parametrize(("vx0", "vxf", "W", "tau"), CASES[:8])
def test_standard_positions_equal_the_general_form(vx0: float, vxf: float, W: float,
                                                   tau: float) -> None:
    from cosim.planning.trajectory import standard_positions

    taus = np.array([tau, tau + 0.5, tau + 3.0])
    t = np.linspace(0.0, 15.0, 61)
    fast = standard_positions(vx0, vxf, W, taus, t)
    slow = cluster(BoundaryConditions(vx0, vxf, W), taus, t)
    np.testing.assert_allclose(fast[0], slow[0], atol=1e-9)
    np.testing.assert_allclose(fast[1], slow[1], atol=1e-9)


def test_standard_velocities_equal_the_general_form() -> None:
    from cosim.planning.trajectory import standard_velocities

    vx0, vxf, W = 29.2, 25.0, -3.75
    taus = np.array([2.5, 4.0, 9.0])
    t = np.linspace(0.0, 12.0, 49)
    xd, yd = standard_velocities(vx0, vxf, W, taus[:, None], t[None, :])
    ref = cluster_derivatives(BoundaryConditions(vx0, vxf, W), taus, t, (1,))[1]
    np.testing.assert_allclose(xd, ref[0], atol=1e-9)
    np.testing.assert_allclose(yd, ref[1], atol=1e-9)
