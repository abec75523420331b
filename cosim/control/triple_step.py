"""The MIMO triple-step lateral law (eq. 21-25) and the SISO baseline.

Design model (eq. 21): y'' = A0 + A1 y' + B u, y = [ye, phi_e], u = [delta_f, dMz].
Law (eq. 22-24): u = us + uf + ue with us = -B^-1 A0, uf = 0 and
ue = -B^-1 (KP y + KI int(y) + KD y'), KD = diag(ky1, kphi1) + A1. On the design
model this leaves two decoupled error equations (eq. 42-43),
z''' + kz1 z'' + kz0 z' + kzI z = 0 (in int z), Hurwitz exactly when eq. 25 holds.

SISO baseline (the paper's comparison, its ref. [33]): steering only (dMz = 0),
the same triple-step structure on the single output ye; phi_e is left to the
zero dynamics, which is why it cannot regulate the heading error directly.

The laws are compiled (`mimo_core`, `siso_core`, numba) for the closed loop's
compiled substep loop; `mimo_law` and `siso_law` wrap them for Python callers.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from cosim.compiled import Array, njit
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


def law_params(vehicle: VehicleParams, gains: ControllerGains) -> Array:
    """The constants of `mimo_core` / `siso_core` as one array: M, Iz, lf, lr, Cf, Cr,
    ky0, kyI, ky1, kphi0, kphiI, kphi1."""
    v, g = vehicle, gains
    return np.array([v.mass, v.yaw_inertia, v.lf, v.lr, v.cf, v.cr,
                     g.ky0, g.kyI, g.ky1, g.kphi0, g.kphiI, g.kphi1], dtype=float)


@njit
def design_core(p: Array, vx: float, phi_e: float, kappa: float
                ) -> tuple[float, float, float, float, float, float]:
    """(A0_1, A0_2, A1_11, A1_12, A1_21, A1_22) of eq. 21 at speed vx (m/s);
    p from `law_params`."""
    m, iz, lf, lr, cf, cr = p[0], p[1], p[2], p[3], p[4], p[5]
    d1 = lf * cf - lr * cr
    d2 = lf * lf * cf + lr * lr * cr
    a0_1 = (cf + cr) / m * phi_e - (vx * vx + d1 / m) * kappa
    a0_2 = d1 / iz * phi_e - d2 / iz * kappa
    return (
        a0_1, a0_2,
        -(cf + cr) / (m * vx), -d1 / (m * vx),
        -d1 / (iz * vx), -d2 / (iz * vx),
    )


@njit
def mimo_core(p: Array, vx: float, kappa: float, ye: float, phi_e: float, ye_dot: float,
              phi_e_dot: float, int_ye: float, int_phi: float) -> tuple[float, float]:
    """(delta_f rad, dMz N m) of eq. 22-24; p from `law_params`."""
    a0_1, a0_2, a11, a12, a21, a22 = design_core(p, vx, phi_e, kappa)
    ky0, kyI, ky1, kphi0, kphiI, kphi1 = p[6], p[7], p[8], p[9], p[10], p[11]
    # wanted y'' (eq. 42-43) minus the model's drift A0 + A1 y'
    w1 = -(ky0 * ye + kyI * int_ye + ky1 * ye_dot) - a0_1 - a11 * ye_dot - a12 * phi_e_dot
    w2 = (-(kphi0 * phi_e + kphiI * int_phi + kphi1 * phi_e_dot)
          - a0_2 - a21 * ye_dot - a22 * phi_e_dot)
    # u = B^-1 w, B = [[Cf/M, 0], [lf Cf/Iz, 1/Iz]]
    m, iz, lf, cf = p[0], p[1], p[2], p[4]
    delta = m / cf * w1
    dmz = iz * w2 - lf * m * w1
    return delta, dmz


@njit
def siso_core(p: Array, vx: float, kappa: float, ye: float, phi_e: float, ye_dot: float,
              phi_e_dot: float, int_ye: float) -> float:
    """delta_f (rad): triple-step on ye alone, dMz = 0 (first row of eq. 21)."""
    a0_1, _, a11, a12, _, _ = design_core(p, vx, phi_e, kappa)
    ky0, kyI, ky1 = p[6], p[7], p[8]
    w1 = -(ky0 * ye + kyI * int_ye + ky1 * ye_dot) - a0_1 - a11 * ye_dot - a12 * phi_e_dot
    return p[0] / p[4] * w1


def design_terms(
    vehicle: VehicleParams, vx: float, phi_e: float, kappa: float
) -> tuple[float, float, float, float, float, float]:
    """(A0_1, A0_2, A1_11, A1_12, A1_21, A1_22) of eq. 21 at speed vx (m/s)."""
    return design_core(law_params(vehicle, ControllerGains()), float(vx), float(phi_e),
                       float(kappa))


class LawErrors(NamedTuple):
    """What eq. 22-24 act on: the path errors (eq. 16) and their integrals."""

    ye: float  # m, lateral offset
    phi_e: float  # rad, heading error
    ye_dot: float  # m/s
    phi_e_dot: float  # rad/s
    int_ye: float = 0.0  # m s, int(ye)
    int_phi: float = 0.0  # rad s, int(phi_e) (the MIMO law's only)


def mimo_law(vehicle: VehicleParams, gains: ControllerGains, vx: float, kappa: float,
             errors: LawErrors) -> tuple[float, float]:
    """(delta_f rad, dMz N m) of eq. 22-24 at speed vx (m/s) on path curvature kappa (1/m)."""
    args = (vx, kappa, *errors)
    return mimo_core(law_params(vehicle, gains), *(float(a) for a in args))


def siso_law(vehicle: VehicleParams, gains: ControllerGains, vx: float, kappa: float,
             errors: LawErrors) -> float:
    """delta_f (rad): triple-step on ye alone, dMz = 0 (first row of eq. 21)."""
    args = (vx, kappa, *errors[:5])
    return siso_core(law_params(vehicle, gains), *(float(a) for a in args))
