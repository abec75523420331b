"""Tests of cosim.control.allocation (eq. 20, 27, 29-30)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.control.allocation import allocate, virtual_inputs
from cosim.params import VehicleParams

VEHICLE = VehicleParams()


@given(
    delta=st.floats(-0.5, 0.5), dmz=st.floats(-3000.0, 3000.0), fa=st.floats(-8000.0, 8000.0)
)
def test_small_eps_reproduces_the_virtual_inputs(delta: float, dmz: float, fa: float) -> None:
    fx = allocate(VEHICLE, delta, dmz, fa, 1e-6)
    got_dmz, got_fa = virtual_inputs(VEHICLE, delta, fx)
    scale = 1e-6 + 1e-5 * (abs(dmz) + abs(fa))  # the eps error is relative to |v|
    assert got_dmz == pytest.approx(dmz, abs=scale)
    assert got_fa == pytest.approx(fa, abs=scale)


def test_large_eps_regularises_away_from_the_demand() -> None:
    fx = allocate(VEHICLE, 0.0, 500.0, 2000.0, 10.0)
    dmz, fa = virtual_inputs(VEHICLE, 0.0, fx)
    assert fa < 0.5 * 2000.0 and dmz < 0.5 * 500.0


def test_pure_drive_force_is_shared_equally_and_yaw_moment_by_sides() -> None:
    f1, f2, f3, f4 = allocate(VEHICLE, 0.0, 0.0, 4000.0, 1e-6)
    assert f1 == pytest.approx(1000.0) and f4 == pytest.approx(1000.0)
    f1, f2, f3, f4 = allocate(VEHICLE, 0.0, 710.0, 0.0, 1e-6)
    assert f1 == pytest.approx(-250.0, rel=1e-5) and f2 == pytest.approx(250.0, rel=1e-5)
    assert f3 == pytest.approx(f1) and f4 == pytest.approx(f2)


def test_allocation_is_the_least_squares_formula() -> None:
    import numpy as np

    delta, eps, v = 0.2, 1e-2, np.array([800.0, 1500.0])
    c, s = np.cos(delta), np.sin(delta)
    ls, lf = VEHICLE.half_track, VEHICLE.lf
    mm = np.array([[-ls * c + lf * s, ls * c + lf * s, -ls, ls], [c, c, 1.0, 1.0]])
    expected = mm.T @ np.linalg.solve(eps * np.eye(2) + mm @ mm.T, v)
    np.testing.assert_allclose(allocate(VEHICLE, delta, v[0], v[1], eps), expected, rtol=1e-12)
