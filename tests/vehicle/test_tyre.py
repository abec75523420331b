"""Tests of cosim.vehicle.tyre: slopes, saturation at mu Fz, combined slip."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from cosim.vehicle.tyre import peak_slip, tyre_forces

FZ, CK, CA, MU, C = 4000.0, 20.0, 25.0, 0.6, 1.4


def test_initial_slopes_are_the_linear_stiffnesses() -> None:
    h = 1e-7
    fx, _ = tyre_forces(h, 0.0, FZ, CK, CA, MU, C)
    _, fy = tyre_forces(0.0, h, FZ, CK, CA, MU, C)
    assert math.isclose(fx / h, CK * FZ, rel_tol=1e-6)
    assert math.isclose(fy / h, CA * FZ, rel_tol=1e-6)


def test_peak_is_mu_fz_and_then_the_tyre_slides() -> None:
    u_peak = peak_slip(C)
    tan_alpha = u_peak * MU / CA
    _, f_peak = tyre_forces(0.0, tan_alpha, FZ, CK, CA, MU, C)
    _, f_more = tyre_forces(0.0, 3.0 * tan_alpha, FZ, CK, CA, MU, C)
    assert math.isclose(f_peak, MU * FZ, rel_tol=1e-9)
    assert f_more < f_peak
    assert math.isclose(
        tyre_forces(0.0, 1e6, FZ, CK, CA, MU, C)[1], MU * FZ * math.sin(C * math.pi / 2),
        rel_tol=1e-3,
    )


@given(
    kappa=st.floats(-2.0, 2.0), tan_alpha=st.floats(-3.0, 3.0),
    fz=st.floats(0.0, 2e4), mu=st.floats(0.1, 1.2),
)
def test_resultant_never_exceeds_the_friction_circle(
    kappa: float, tan_alpha: float, fz: float, mu: float
) -> None:
    fx, fy = tyre_forces(kappa, tan_alpha, fz, CK, CA, mu, C)
    assert math.hypot(fx, fy) <= mu * fz * (1.0 + 1e-12)
    assert fx * kappa >= 0.0 and fy * tan_alpha >= 0.0  # forces oppose the slip


def test_longitudinal_slip_uses_up_lateral_grip() -> None:
    tan_alpha = 0.02
    _, fy_free = tyre_forces(0.0, tan_alpha, FZ, CK, CA, MU, C)
    _, fy_braking = tyre_forces(-0.05, tan_alpha, FZ, CK, CA, MU, C)
    assert fy_braking < 0.8 * fy_free


def test_an_unloaded_wheel_makes_no_force() -> None:
    assert tyre_forces(0.1, 0.1, 0.0, CK, CA, MU, C) == (0.0, 0.0)
    assert tyre_forces(0.1, 0.1, -10.0, CK, CA, MU, C) == (0.0, 0.0)
