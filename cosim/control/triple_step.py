"""The MIMO triple-step lateral law (eq. 21-25) and the SISO baseline.

Design model (eq. 21): y'' = A0 + A1 y' + B u, y = [ye, phi_e], u = [delta_f, dMz].
Law (eq. 22-24): u = us + uf + ue with us = -B^-1 A0, uf = 0 and
ue = -B^-1 (KP y + KI int(y) + KD y'), KD = diag(ky1, kphi1) + A1. On the design
model this leaves two decoupled error equations (eq. 42-43),
z''' + kz1 z'' + kz0 z' + kzI z = 0 (in int z), Hurwitz exactly when eq. 25 holds.

SISO baseline (the paper's comparison, its ref. [33]): steering only (dMz = 0),
the same triple-step structure on the single output ye; phi_e is left to the
zero dynamics, which is why it cannot regulate the heading error directly.
"""

from __future__ import annotations

import numpy as np

from cosim.errors import InputError
from cosim.params import ControllerGains, VehicleParams


def check_gains(gains: ControllerGains, source: str = "controller") -> None:
    """Raise InputError unless eq. 25 holds for z in {y, phi}:
    kz0 > 0, kzI > 0 and kz0 kz1 > kzI (the error polynomial is then Hurwitz)."""
    for z, k0, ki, k1 in (
        ("y", gains.ky0, gains.kyI, gains.ky1),
        ("phi", gains.kphi0, gains.kphiI, gains.kphi1),
    ):
        if not k0 > 0.0:
            raise InputError(source, f"k{z}0", k0, "eq. 25 needs > 0")
        if not ki > 0.0:
            raise InputError(source, f"k{z}I", ki, "eq. 25 needs > 0")
        if not k0 * k1 > ki:
            raise InputError(
                source, f"k{z}1", k1,
                f"eq. 25 needs k{z}0 * k{z}1 > k{z}I = {ki:g}, i.e. k{z}1 > {ki / k0:g}",
            )
    if not gains.kx1 > 0.0:
        raise InputError(source, "kx1", gains.kx1, "eq. 28 needs > 0")
    if not gains.allocation_eps > 0.0:
        raise InputError(source, "allocation_eps", gains.allocation_eps, "eq. 30 needs > 0")


def error_polynomial(k0: float, ki: float, k1: float) -> tuple[float, float, float, float]:
    """Coefficients (highest power first) of s^3 + k1 s^2 + k0 s + kI, the characteristic
    polynomial of eq. 42 / 43 written for int(z)."""
    return 1.0, k1, k0, ki


def is_hurwitz(coefficients: tuple[float, ...]) -> bool:
    """True when every root has a negative real part."""
    return bool(np.all(np.roots(coefficients).real < 0.0))


def design_terms(
    vehicle: VehicleParams, vx: float, phi_e: float, kappa: float
) -> tuple[float, float, float, float, float, float]:
    """(A0_1, A0_2, A1_11, A1_12, A1_21, A1_22) of eq. 21 at speed vx (m/s)."""
    v = vehicle
    m, iz, lf, lr, cf, cr = v.mass, v.yaw_inertia, v.lf, v.lr, v.cf, v.cr
    d1 = lf * cf - lr * cr
    d2 = lf * lf * cf + lr * lr * cr
    a0_1 = (cf + cr) / m * phi_e - (vx * vx + d1 / m) * kappa
    a0_2 = d1 / iz * phi_e - d2 / iz * kappa
    return (
        a0_1, a0_2,
        -(cf + cr) / (m * vx), -d1 / (m * vx),
        -d1 / (iz * vx), -d2 / (iz * vx),
    )


def mimo_law(
    vehicle: VehicleParams, gains: ControllerGains, vx: float, kappa: float,
    ye: float, phi_e: float, ye_dot: float, phi_e_dot: float, int_ye: float, int_phi: float,
) -> tuple[float, float]:
    """(delta_f rad, dMz N m) of eq. 22-24."""
    a0_1, a0_2, a11, a12, a21, a22 = design_terms(vehicle, vx, phi_e, kappa)
    g = gains
    # wanted y'' (eq. 42-43) minus the model's drift A0 + A1 y'
    w1 = -(g.ky0 * ye + g.kyI * int_ye + g.ky1 * ye_dot) - a0_1 - a11 * ye_dot - a12 * phi_e_dot
    w2 = (-(g.kphi0 * phi_e + g.kphiI * int_phi + g.kphi1 * phi_e_dot)
          - a0_2 - a21 * ye_dot - a22 * phi_e_dot)
    # u = B^-1 w, B = [[Cf/M, 0], [lf Cf/Iz, 1/Iz]]
    v = vehicle
    delta = v.mass / v.cf * w1
    dmz = v.yaw_inertia * w2 - v.lf * v.mass * w1
    return delta, dmz


def siso_law(
    vehicle: VehicleParams, gains: ControllerGains, vx: float, kappa: float,
    ye: float, phi_e: float, ye_dot: float, phi_e_dot: float, int_ye: float,
) -> float:
    """delta_f (rad): triple-step on ye alone, dMz = 0 (first row of eq. 21)."""
    a0_1, _, a11, a12, _, _ = design_terms(vehicle, vx, phi_e, kappa)
    g = gains
    w1 = -(g.ky0 * ye + g.kyI * int_ye + g.ky1 * ye_dot) - a0_1 - a11 * ye_dot - a12 * phi_e_dot
    return vehicle.mass / vehicle.cf * w1
