"""Tests of cosim.vehicle.tyre: Magic Formula slopes and peaks, combined-slip weights,
load sensitivity."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.errors import InputError
from cosim.vehicle.tyre import TyreParams, peak_slip, tyre_forces

FZ, KA, MU = 4000.0, 75000.0, 0.6
TYRE = TyreParams()


def test_small_slip_stiffnesses_are_k_alpha_and_c_kappa_fz_to_1e_9() -> None:
    h = 1e-8
    fx, _ = tyre_forces(h, 0.0, FZ, KA, MU)
    _, fy = tyre_forces(0.0, h, FZ, KA, MU)
    assert fx / h == pytest.approx(TYRE.slip_stiffness * FZ, rel=1e-9)
    assert fy / h == pytest.approx(KA, rel=1e-9)
    # the other slip's weight has zero slope at zero: a little kappa leaves K_alpha alone
    _, fy_k = tyre_forces(1e-5, h, FZ, KA, MU)
    assert fy_k / h == pytest.approx(KA, rel=1e-8)


def test_pure_slip_peaks_at_mu_fz_and_then_slides() -> None:
    c = TYRE.shape_lat
    b = KA / (c * MU * FZ)
    tan_peak = peak_slip(c) / b
    _, f_peak = tyre_forces(0.0, tan_peak, FZ, KA, MU)
    _, f_more = tyre_forces(0.0, 3.0 * tan_peak, FZ, KA, MU)
    assert f_peak == pytest.approx(MU * FZ, rel=1e-12)
    assert f_more < f_peak
    assert tyre_forces(0.0, 1e6, FZ, KA, MU)[1] == pytest.approx(
        MU * FZ * math.sin(c * math.pi / 2), rel=1e-3)


def test_peak_slip_with_curvature_solves_the_peak_condition() -> None:
    c, e = 1.6411, 0.46403
    x = peak_slip(c, e)
    assert c * math.atan(x - e * (x - math.atan(x))) == pytest.approx(math.pi / 2, rel=1e-12)


@given(
    kappa=st.floats(-1.0, 3.0), tan_alpha=st.floats(-3.0, 3.0),
    fz=st.one_of(st.just(0.0), st.floats(1.0, 2e4)), mu=st.floats(0.1, 1.2),
)
def test_each_force_stays_within_its_friction_limit_and_opposes_the_slip(
    kappa: float, tan_alpha: float, fz: float, mu: float
) -> None:
    fx, fy = tyre_forces(kappa, tan_alpha, fz, KA, mu)
    assert abs(fx) <= mu * fz * (1.0 + 1e-12) and abs(fy) <= mu * fz * (1.0 + 1e-12)
    assert fx * kappa >= 0.0 and fy * tan_alpha >= 0.0  # the weights never reverse a force


def test_weights_follow_pacejkas_g_functions() -> None:
    """Combined slip is pure slip times G_x,alpha = cos(C_xa atan(B_xa alpha)) with
    B_xa = r_bx1 cos(atan(r_bx2 kappa)), and G_y,kappa likewise (Pacejka sec. 4.3.2)."""
    kappa, tan_alpha = -0.04, 0.05
    fx0, _ = tyre_forces(kappa, 0.0, FZ, KA, MU)
    _, fy0 = tyre_forces(0.0, tan_alpha, FZ, KA, MU)
    fx, fy = tyre_forces(kappa, tan_alpha, FZ, KA, MU)
    t = TYRE
    g_xa = math.cos(t.r_cx1 * math.atan(t.r_bx1 * math.cos(math.atan(t.r_bx2 * kappa))
                                        * tan_alpha))
    g_yk = math.cos(t.r_cy1 * math.atan(t.r_by1 * math.cos(math.atan(t.r_by2 * tan_alpha))
                                        * kappa))
    assert fx == pytest.approx(g_xa * fx0, rel=1e-12)
    assert fy == pytest.approx(g_yk * fy0, rel=1e-12)
    # braking uses up lateral grip: past the peak slip (about -0.1) most of it
    assert fy < 0.97 * fy0
    assert tyre_forces(-0.1, tan_alpha, FZ, KA, MU)[1] < 0.85 * fy0


def test_load_sensitivity_lowers_friction_and_stiffness_per_unit_load() -> None:
    """mu(Fz) = mu (1 + p_D2 dfz); K_alpha peaks at p_Ky2 Fz0: shifting load from one
    wheel to the other of an axle loses axle stiffness and grip; without sensitivity,
    none."""
    d = 0.3 * FZ
    for tyre, loses in ((TYRE, True),
                        (TyreParams(friction_load=0.0, cornering_peak_load=math.inf), False)):
        def axle(tan_alpha: float, dz: float, tyre: TyreParams = tyre) -> float:
            return sum(tyre_forces(0.0, tan_alpha, FZ + s * dz, KA, MU, tyre, fz0=FZ)[1]
                       for s in (1.0, -1.0))
        small = (axle(1e-6, d) / axle(1e-6, 0.0), axle(1.0, d) / axle(1.0, 0.0))
        if loses:
            assert small[0] < 0.97 and small[1] < 0.999
        else:
            assert small == pytest.approx((1.0, 1.0), rel=1e-12)


def test_an_unloaded_wheel_makes_no_force() -> None:
    assert tyre_forces(0.1, 0.1, 0.0, KA, MU) == (0.0, 0.0)
    assert tyre_forces(0.1, 0.1, -10.0, KA, MU) == (0.0, 0.0)


@pytest.mark.parametrize(("key", "value"), [("shape_lat", 2.5), ("relaxation_lat", 0.0),
                                            ("friction_load", 0.9), ("damping_long", -1.0)])
def test_a_coefficient_outside_the_formula_is_an_input_error(key: str, value: float) -> None:
    with pytest.raises(InputError, match=key):
        TyreParams(**{key: value}).check()
