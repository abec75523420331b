"""Nonlinear tyre with combined slip: an isotropic normalised-slip magic formula.

Slips are scaled by the tyre's linear stiffness over its peak force, so that
`ux = C_kappa kappa / (mu Fz)` and `uy = C_alpha tan(alpha) / (mu Fz)` are in
units of "linear force / friction limit". The resultant force follows one
Pacejka-style curve `F = mu Fz sin(C atan(u / C))`, `u = |(ux, uy)|`, split
along the slip direction (a friction circle). Hence:

- initial slopes are exactly C_kappa and C_alpha (dF/du = mu Fz at u = 0), so the
  axle cornering stiffness equals Table 1's Cf, Cr at the static load;
- the resultant never exceeds mu Fz (peak at u = C tan(pi / (2 C))), and past
  the peak the tyre slides at mu Fz sin(C pi / 2);
- longitudinal slip uses up lateral grip and vice versa (combined slip).

Stiffnesses are per unit load (C = c Fz), so shifting load within an axle does
not change the axle's cornering stiffness at small slip.
"""

from __future__ import annotations

import math

from cosim.compiled import njit


@njit
def magic_formula(ux: float, uy: float, fz: float, mu: float, shape: float,
                  inv_shape: float) -> tuple[float, float]:
    """N, (Fx, Fy) from the normalised slips (ux, uy): the resultant
    mu Fz sin(C atan(u / C)) split along the slip direction. The two-track plant
    calls this for each wheel with its slips already normalised."""
    u = math.sqrt(ux * ux + uy * uy)
    d = mu * fz * (math.sin(shape * math.atan(u * inv_shape)) / u if u > 1e-9 else 1.0)
    return d * ux, d * uy


def tyre_forces(
    kappa: float, tan_alpha: float, fz: float, c_kappa: float, c_alpha: float,
    mu: float, shape: float,
) -> tuple[float, float]:
    """N, (Fx, Fy) in the wheel frame.

    kappa: longitudinal slip (-); tan_alpha: tangent of the slip angle, positive
    when the force points to the wheel's left; fz: vertical load (N); c_kappa,
    c_alpha: slip and cornering stiffness per unit load (1, 1/rad); mu: friction;
    shape: magic-formula C.
    """
    if fz <= 0.0:
        return 0.0, 0.0
    return magic_formula(c_kappa * kappa / mu, c_alpha * tan_alpha / mu, fz, mu, shape,
                         1.0 / shape)


def peak_slip(shape: float) -> float:
    """-, normalised slip u at which the resultant force peaks at mu Fz."""
    return shape * math.tan(math.pi / (2.0 * shape))
